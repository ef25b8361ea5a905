"""The adaptive gait clock of CRA-Loco (paper III-E): a per-env phase whose rate and leg offsets the policy sets.

    phi(t + dt) = phi(t) + (1 + alpha * d0) dt          global phase [s], wrapped to [0, T_cycle)
    s(t) = sin(2 pi (phi / T_cycle + d1))                left leg signal
    c(t) = sin(2 pi (phi / T_cycle + d2 + psi))          right leg signal, psi = 0.5: legs half a cycle apart
    m_stance = [s >= gamma, c >= gamma]                  gamma < 0: a double-support band around the crossings
    depth = clip((gamma - [s, c]) / (1 + gamma), 0, 1)   how deep each leg is in swing: 0 at gamma, 1 mid-swing

(d0, d1, d2) are the last three action entries times beta_scale. All tensors are [N, ...] on one device.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch


@dataclass
class GaitClockConfig:
    cycle_time: float = 0.8    # T_cycle, the reference period [s] (the vendor's Adam Lite policies: 0.75-0.8 s)
    alpha: float = 0.5         # how strongly d0 changes the phase rate: rate in [0.5, 1.5] for d0 in [-1, 1]
    psi: float = 0.5           # right-leg offset in cycles
    gamma: float = -0.1        # stance threshold; negative = both feet in stance near the crossings
    beta_scale: float = 1.0    # scale applied to the raw gait actions
    # [rad] Beyond the paper (its III-E: s(t) and c(t) "can be used to drive each foot's ... swing trajectory"):
    # each leg's swing joints get swing_feedforward x depth x the robot's swing_profile (robots/<robot>/loco.py)
    # added to their PD targets, so a zero action marches in place with the clock and the policy learns to balance
    # and steer a stepping gait instead of having to discover stepping from standing (0 = off).
    swing_feedforward: float = 0.0
    # [rad per m/s] Beyond the paper, a stride for the forward command: each leg's hip pitch gets
    # stride_feedforward x v_cmd_x x cos(leg angle) towards the front, so the thigh is furthest forward where the clock
    # puts the foot down (s rising through 0) and furthest back where it lifts it, and sweeps back through stance. A
    # zero action's stance then sweeps about the stride the command needs (0.25: 2 x 0.25 x v rad over half a 0.8 s
    # cycle on a ~0.8 m leg), so the policy starts from a forward gait rather than a march in place (0 = off).
    stride_feedforward: float = 0.0
    # [rad per m/s] and [rad per rad/s] Beyond the paper, the same sweep for the other two commands: each leg's
    # lateral joint (hip roll) gets lateral_feedforward x v_cmd_y x cos(leg angle) and its turn joint (hip yaw)
    # turn_feedforward x yaw_rate_cmd x cos(leg angle), signed so the foot lands displaced and turned towards the
    # command and sweeps back under the body in stance (0.2: a 0.5 rad/s turn rotates the pelvis ~0.4 rad per 0.8 s
    # cycle, two stances of 2 x 0.1 rad). Without them the policy must discover side steps and turning steps alone.
    lateral_feedforward: float = 0.0
    turn_feedforward: float = 0.0
    # Start each episode's clock at a random phase instead of 0. With the feedforward on and every episode starting
    # left foot first, the first steps from rest turn the robot one way (a scripted march of the feedforward alone
    # turns ~0.8 rad/s clockwise from phase 0 and as fast anticlockwise from half a cycle), and the policies trained
    # so took that turn up and kept it whatever the yaw command. A deploy program may still start at 0.
    random_start_phase: bool = False

    def __post_init__(self):
        if self.cycle_time <= 0:
            raise ValueError(f"GaitClockConfig.cycle_time must be > 0, got {self.cycle_time}")
        if not -1.0 < self.gamma < 1.0:
            raise ValueError(f"GaitClockConfig.gamma must be in (-1, 1), got {self.gamma}")
        if self.swing_feedforward < 0:
            raise ValueError(f"GaitClockConfig.swing_feedforward must be >= 0, got {self.swing_feedforward}")
        for f in ("stride_feedforward", "lateral_feedforward", "turn_feedforward"):
            if getattr(self, f) < 0:
                raise ValueError(f"GaitClockConfig.{f} must be >= 0, got {getattr(self, f)}")


class GaitClock:
    """Per-env adaptive clock. ``advance`` takes the raw gait actions [N, 3] and returns the leg signals [N, 2]."""

    def __init__(self, num_envs: int, cfg: GaitClockConfig | None = None, device: str | torch.device = "cpu"):
        self.cfg = cfg or GaitClockConfig()
        self.phase = torch.zeros(num_envs, device=device)            # phi [N], seconds in [0, T_cycle)
        self.deltas = torch.zeros(num_envs, 3, device=device)        # last scaled (d0, d1, d2) [N, 3]
        self.signals = self._signals()                               # (s, c) [N, 2]

    @property
    def leg_angles(self) -> torch.Tensor:
        """[N, 2] 2 pi (phi / T_cycle + d1) and 2 pi (phi / T_cycle + d2 + psi): the legs' (s, c) = sin of these."""
        cyc = self.phase / self.cfg.cycle_time
        offsets = torch.stack([self.deltas[:, 1], self.deltas[:, 2] + self.cfg.psi], 1)
        return 2.0 * math.pi * (cyc.unsqueeze(1) + offsets)

    def _signals(self) -> torch.Tensor:
        return torch.sin(self.leg_angles)

    def advance(self, gait_actions: torch.Tensor, dt: float) -> torch.Tensor:
        """phi += (1 + alpha d0) dt with d = beta_scale * gait_actions [N, 3]; returns (s, c) [N, 2] (the clock's
        own buffer, updated by the next call: clone it to keep it)."""
        # Buffers are updated in place: rsl-rl steps envs under torch.inference_mode, and a buffer re-created there
        # could not be written outside it later (e.g. by a reset).
        self.deltas.copy_(self.cfg.beta_scale * gait_actions)
        # A negative rate would run the clock backwards; clamp at a standstill instead.
        rate = (1.0 + self.cfg.alpha * self.deltas[:, 0]).clamp(min=0.0)
        self.phase.copy_(torch.remainder(self.phase + rate * dt, self.cfg.cycle_time))
        self.signals.copy_(self._signals())
        return self.signals

    @property
    def phase_obs(self) -> torch.Tensor:
        """[N, 2] (sin, cos) of the global phase 2 pi phi / T_cycle: the clock as the policy observes it. Unlike
        (s, c) it tells every phase apart whatever the offsets (s = -c whenever d1 = d2)."""
        angle = 2.0 * math.pi * self.phase / self.cfg.cycle_time
        return torch.stack([torch.sin(angle), torch.cos(angle)], -1)

    @property
    def stance_mask(self) -> torch.Tensor:
        """[N, 2] bool: which foot (left, right) the clock wants on the ground."""
        return self.signals >= self.cfg.gamma

    @property
    def swing_depth(self) -> torch.Tensor:
        """[N, 2] in [0, 1]: how deep each leg (left, right) is in swing, 0 in stance, 1 at the swing's middle."""
        return swing_depth(self.signals, self.cfg.gamma)

    def reset(self, env_ids: torch.Tensor, phase: torch.Tensor | None = None):
        """Restart the clock of ``env_ids`` at ``phase`` [n] seconds (default 0) with zero deltas."""
        self.phase[env_ids] = 0.0 if phase is None else phase
        self.deltas[env_ids] = 0.0
        self.signals.copy_(self._signals())


def swing_depth(signals, gamma: float):
    """0 where a leg signal is at or above the stance threshold gamma, rising to 1 at its minimum -1."""
    return ((gamma - signals) / (1.0 + gamma)).clip(0.0, 1.0)
