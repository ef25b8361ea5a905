"""Quaternion helpers for batched torch tensors. Quaternions are xyzw (Newton's convention), shape [..., 4]."""

from __future__ import annotations

import torch


def quat_rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate v [..., 3] by the unit quaternion q [..., 4] (body -> world)."""
    q, v = torch.broadcast_tensors(q, torch.cat([v, v[..., :1]], -1))  # broadcast leading dims
    u, w, v = q[..., :3], q[..., 3:4], v[..., :3]
    t = 2.0 * torch.cross(u, v, dim=-1)
    return v + w * t + torch.cross(u, t, dim=-1)


def quat_rotate_inv(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate v [..., 3] by the inverse of q [..., 4] (world -> body)."""
    return quat_rotate(torch.cat([-q[..., :3], q[..., 3:4]], -1), v)


def yaw(q: torch.Tensor) -> torch.Tensor:
    """Heading angle [...] of q [..., 4] about the world z axis."""
    x, y, z, w = q.unbind(-1)
    return torch.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def yaw_quat(yaw: torch.Tensor) -> torch.Tensor:
    """[..., 4] xyzw rotation about world z by ``yaw`` [...] (rad)."""
    z = torch.zeros_like(yaw)
    return torch.stack([z, z, torch.sin(yaw / 2), torch.cos(yaw / 2)], -1)


def wrap_angle(a: torch.Tensor) -> torch.Tensor:
    return torch.remainder(a + torch.pi, 2.0 * torch.pi) - torch.pi
