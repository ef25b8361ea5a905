"""Differentiable batched forward kinematics of a robot: link poses and sole points from base pose and joints.

Built on pytorch-kinematics from the same URDF text the simulator loads (``robot_urdf_text``: the config's
fixed_joints welded), so kinematics and sim share one description; tests cross-check it against Newton's body poses.

Conventions at this boundary:
- joint positions q [N, J] in the robot config's canonical order (mapped to pytorch-kinematics' order here);
- base quaternions and returned quaternions are xyzw (Newton's). pytorch-kinematics uses wxyz: the conversion
  happens only inside this module;
- poses are of link frame origins (not CoMs), in the world frame: position [N, L, 3], rotation [N, L, 3, 3].

pytorch-kinematics has no floating joint: the chain is rooted at the base link and the base pose is composed here.
Gradients flow to base position, base quaternion and q (pytorch-kinematics' analytic Jacobian for the joints:
first order only, no create_graph through the joints).

Cost: one call runs FK for every frame of the tree (26 for Adam Lite; the per-link selection is applied after), a
few batched 4x4 matmuls per tree level; the base composition is applied to the selected links only. Measured on
this 2-core CPU, float32, one torch thread, best of 10, while another process held the other core: ``feet`` at
N=256 ~4 ms forward, ~8 ms forward + backward; at N=4096 ~54 ms / ~92 ms (~3% of a Newton env step at that N).
Two torch threads with the other core busy were several times slower (thread contention). Call ``feet`` once per
step when both foot poses and sole points are needed: each public method is one FK pass.
"""

from __future__ import annotations

import re
from typing import NamedTuple, Sequence

import pytorch_kinematics as pk
import torch
from pytorch_kinematics.transforms import matrix_to_quaternion, quaternion_to_matrix, wxyz_to_xyzw, xyzw_to_wxyz

from cra_warp.rotations import quat_rotate
from robots.robot_config import RobotConfig, robot_urdf_text


class FootKinematics(NamedTuple):
    """Foot frames and sole points in the world frame, F = len(robot.foot_links) (left first)."""

    pos: torch.Tensor           # [N, F, 3] foot link origin
    quat: torch.Tensor          # [N, F, 4] xyzw
    sole_corners: torch.Tensor  # [N, F, 4, 3] front-left, front-right, back-left, back-right (foot frame x fwd, y left)
    sole_centres: torch.Tensor  # [N, F, 3]


def _strip_geometry(urdf: str) -> str:
    # Kinematics needs no geometry, and pytorch-kinematics' URDF parser and Newton read capsule attributes
    # differently: drop <collision> and <visual> blocks rather than depend on either reading.
    return re.sub(r"<(collision|visual)\b.*?</\1>", "", urdf, flags=re.S)


class Kinematics:
    """Batched FK of ``robot`` on ``device`` in ``dtype``; built once, called every env step."""

    def __init__(self, robot: RobotConfig, device: str | torch.device = "cpu", dtype: torch.dtype = torch.float32):
        self.robot = robot
        self.device = torch.device(device)
        self.dtype = dtype
        self.chain = pk.build_chain_from_urdf(_strip_geometry(robot_urdf_text(robot))).to(dtype=dtype,
                                                                                         device=self.device)
        root = self.chain.idx_to_frame[0]
        if root != robot.base_link:  # FK is relative to the root: it must be the floating base
            raise ValueError(f"{robot.urdf_path.name}: the kinematic root is {root!r}, "
                             f"the config's base_link is {robot.base_link!r}")

        # Canonical -> pytorch-kinematics column order, by name, once: q_pk = q[:, self._pk_cols].
        pk_names = self.chain.get_joint_parameter_names()
        if sorted(pk_names) != sorted(robot.joint_names):
            raise ValueError(f"{robot.urdf_path.name}: movable joints {sorted(pk_names)} differ from the config's "
                             f"joint_names {sorted(robot.joint_names)}")
        self._pk_cols = torch.tensor([robot.joint_names.index(n) for n in pk_names], device=self.device)

        self.link_names: tuple[str, ...] = tuple(self.chain.frame_to_idx)  # every link, incl. fixed-joint children
        self._link_ids: dict[tuple[str, ...], torch.Tensor] = {}

        hx, hy = robot.sole_half_size
        off = torch.tensor(robot.sole_offset, dtype=dtype, device=self.device)
        half = torch.tensor([[hx, hy, 0.0], [hx, -hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0]], dtype=dtype,
                            device=self.device)
        self.sole_corners_local = off + half  # [4, 3] foot frame, order as in FootKinematics
        self.sole_centre_local = off          # [3] foot frame

    @property
    def num_joints(self) -> int:
        return self.robot.num_joints

    def link_ids(self, links: Sequence[str]) -> torch.Tensor:
        """Frame indices of ``links`` in pytorch-kinematics' output (cached per tuple of names)."""
        key = tuple(links)
        ids = self._link_ids.get(key)
        if ids is None:
            missing = [n for n in key if n not in self.chain.frame_to_idx]
            if missing:
                raise ValueError(f"{self.robot.name}: no link named {missing[0]!r} "
                                 f"(links: {', '.join(self.link_names)})")
            ids = self._link_ids[key] = torch.tensor([self.chain.frame_to_idx[n] for n in key], device=self.device)
        return ids

    # ---------------------------------------------------------------- FK
    def link_frames(self, base_pos: torch.Tensor, base_quat: torch.Tensor, q: torch.Tensor,
                    links: Sequence[str] | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """World poses of ``links`` (all of ``self.link_names`` if None).

        base_pos [N, 3], base_quat [N, 4] xyzw (need not be unit: it is normalised), q [N, J] canonical order.
        Returns position [N, L, 3] and rotation matrix [N, L, 3, 3] (columns: the link's axes in the world).
        """
        if q.shape[-1] != self.num_joints:
            raise ValueError(f"q has {q.shape[-1]} columns, {self.robot.name} has {self.num_joints} joints")
        q = q.to(self.dtype)
        # [frames, N, 4, 4] in the base frame; the selection comes after FK because pk computes the whole tree anyway.
        T = self.chain.forward_kinematics_tensor(q[:, self._pk_cols])
        if links is not None:
            T = T.index_select(0, self.link_ids(links))
        T = T.transpose(0, 1)                                              # [N, L, 4, 4]
        R_base = quaternion_to_matrix(xyzw_to_wxyz(base_quat.to(self.dtype)))  # [N, 3, 3]; scales by 1/|q|^2
        rot = R_base[:, None] @ T[..., :3, :3]
        pos = base_pos.to(self.dtype)[:, None] + torch.einsum("nij,nlj->nli", R_base, T[..., :3, 3])
        return pos, rot

    def link_poses(self, base_pos: torch.Tensor, base_quat: torch.Tensor, q: torch.Tensor,
                   links: Sequence[str] | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """As ``link_frames`` but rotations as quaternions [N, L, 4] xyzw with w >= 0."""
        pos, rot = self.link_frames(base_pos, base_quat, q, links)
        return pos, _matrix_to_xyzw(rot)

    def feet(self, base_pos: torch.Tensor, base_quat: torch.Tensor, q: torch.Tensor) -> FootKinematics:
        """Foot link poses and sole corners/centres from one FK pass (inputs as in ``link_frames``)."""
        pos, rot = self.link_frames(base_pos, base_quat, q, self.robot.foot_links)
        corners = pos[:, :, None] + torch.einsum("nfij,kj->nfki", rot, self.sole_corners_local)
        centres = pos + torch.einsum("nfij,j->nfi", rot, self.sole_centre_local)
        return FootKinematics(pos, _matrix_to_xyzw(rot), corners, centres)

    def feet_at(self, foot_pos: torch.Tensor, foot_quat: torch.Tensor) -> FootKinematics:
        """Sole corners/centres of feet whose link poses are known (the simulator holds them: no FK pass).
        foot_pos [N, F, 3], foot_quat [N, F, 4] xyzw."""
        corners = foot_pos[:, :, None] + quat_rotate(foot_quat[:, :, None], self.sole_corners_local.expand(
            *foot_pos.shape[:2], -1, -1))
        centres = foot_pos + quat_rotate(foot_quat, self.sole_centre_local.expand_as(foot_pos))
        return FootKinematics(foot_pos, foot_quat, corners, centres)

    def sole_points(self, base_pos: torch.Tensor, base_quat: torch.Tensor,
                    q: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Sole corners [N, F, 4, 3] and sole centres [N, F, 3] in the world frame."""
        f = self.feet(base_pos, base_quat, q)
        return f.sole_corners, f.sole_centres


def _matrix_to_xyzw(rot: torch.Tensor) -> torch.Tensor:
    q = matrix_to_quaternion(rot)                 # wxyz (pytorch-kinematics)
    q = torch.where(q[..., :1] < 0, -q, q)        # one of the two signs, so equal rotations give equal quats
    return wxyz_to_xyzw(q)
