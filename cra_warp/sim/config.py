"""The simulator interface: what a task may use of a batched world, its settings, and its terrain boxes.

A backend (cra_warp.sim.newton, cra_warp.sim.mujoco) implements :class:`World`; tasks, CLIs and tools see nothing
else of it. Conventions at this boundary: positions in metres, world frame z up; quaternions xyzw; body twists
(linear velocity of the CoM, angular velocity) in the world frame; driven joints in the robot config's order;
float32 torch tensors on the world's device. The actuator law is the robot's explicit PD,
tau = clamp(kp (q* - q) - kd qd, +-effort), evaluated at every physics step (WorldConfig.integrator "euler", the
default, in both backends). Body quantities (body_*, com(), foot_forces, joint_torque) are those of the last physics
step: Newton evaluates the bodies at the new state, MuJoCo's sensors at the start of that step (5 ms earlier).
This module imports no simulator.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Literal, Protocol, get_args

import numpy as np
import torch

from cra_warp.terrain.window import TerrainWindows, WindowConfig
from robots.robot_config import RobotConfig

FREE_Q, FREE_QD = 7, 6  # coordinates and dofs of the floating base joint

# The simulator backends' names, written here only: WorldConfig.backend's type and check, make_world's choice, and
# every command's --sim (cra_warp.cli.Sim and SIMS are these; tools/soak and tools/figures take their choices here).
Backend = Literal["newton", "mujoco"]
BACKENDS: tuple[str, ...] = get_args(Backend)


def check_backend_device(backend: str, device: str) -> None:
    """The one statement of which backend runs where: MuJoCo C (mujoco.batch) steps host memory only."""
    if backend == "mujoco" and device != "cpu":
        raise ValueError(f"mujoco runs on the CPU only, got device {device!r}")


@dataclass
class WorldConfig:
    """Physics settings of the batched world. Defaults are the ones benchmarked on the 2-core CPU. The world's size
    and device are make_world's arguments (a task owns them: LocoConfig.num_envs, .device), not settings here."""

    # Fields of configs stored before the size and device moved out (env.world.num_envs, .device in config.json and
    # checkpoints): from_data skips them; the task's own values were always the ones used.
    RETIRED_FIELDS: ClassVar[tuple[str, ...]] = ("num_envs", "device")
    # "newton": Newton + mujoco_warp (CPU or CUDA, graph capture); "mujoco": MuJoCo C through mujoco.batch's
    # thread pool (CPU only), the same MjModel. Both run the same PD law and contact settings.
    backend: Backend = "newton"
    threads: int = 0                    # MuJoCo backend: batch threads; 0 = the cores this process may use
    sim_dt: float = 0.005               # physics step [s]
    substeps: int = 4                   # physics steps per env step (0.02 s); must be even (captured state swap)
    contacts: Literal["feet", "all"] = "feet"  # robot shapes that collide with the terrain (never with each other)
    contact_gap: float = 0.01           # contact detection margin [m]; Newton's 0.1 default makes ~8x more contacts
    friction: float = 1.0               # robot shapes; per world with set_friction()
    # The actuator law: an explicit PD tau = clamp(kp (q* - q) - kd qd, +-effort) at every physics step, as the
    # robot's drives and a deploy loop run it. MuJoCo's Euler integrator evaluates the PD actuators explicitly;
    # "implicitfast" (Newton's default) integrates their damping implicitly, a law the robot does not have.
    integrator: Literal["euler", "implicitfast"] = "euler"
    iterations: int = 5                 # constraint solver iterations (early exit on tolerance)
    ls_iterations: int = 10
    nconmax: int | None = None          # contacts per world; None: sized from the contact mode and the terrain
    njmax: int | None = None            # constraint rows per world; None: sized from nconmax
    capture: bool = True                # record one env step as a graph and replay it (CPU and CUDA)
    # Terrain boxes: each world holds the boxes near its robot (cra_warp.terrain.window); None: every world
    # collides with the whole course (its broad phase then grows with the box count).
    terrain_window: WindowConfig | None = field(default_factory=WindowConfig)

    def __post_init__(self):
        if self.substeps < 2 or self.substeps % 2:
            raise ValueError(f"WorldConfig.substeps must be even and >= 2 (the captured state swap), got {self.substeps}")
        if self.sim_dt <= 0:
            raise ValueError(f"WorldConfig.sim_dt must be > 0, got {self.sim_dt}")
        if self.backend not in BACKENDS:
            raise ValueError(f"WorldConfig.backend must be {' or '.join(BACKENDS)}, got {self.backend!r}")

    @property
    def env_dt(self) -> float:
        return self.sim_dt * self.substeps


@dataclass
class TerrainBoxes:
    """Static terrain boxes (stairs, grid cells, slope slabs), in each world's window or shared by all worlds.
    Arrays of length B."""

    centers: np.ndarray                  # [B, 3] m
    half_extents: np.ndarray             # [B, 3] m
    quats: np.ndarray | None = None      # [B, 4] xyzw; None = axis aligned (filled with identities)

    def __post_init__(self):
        if self.quats is None:
            self.quats = np.tile([0.0, 0.0, 0.0, 1.0], (len(self.centers), 1))


class World(Protocol):
    """N robots on static terrain. Views ([N, ...] torch tensors of the sim's current state; writing into
    ``joint_target``, ``base_force`` or the state views reaches the sim at the next ``step()``):

      joint_q [N, 7 + J] (base position, base quaternion xyzw, joint positions), joint_qd [N, 6 + J] (base CoM
      linear and angular velocity, joint velocities), and their parts root_pos [N, 3], root_quat [N, 4],
      root_lin_vel [N, 3], root_ang_vel [N, 3], joint_pos [N, J], joint_vel [N, J];
      joint_target [N, J] (PD position targets); joint_torque [N, J] (PD torque of the last physics step, clamped);
      body_pos [N, B, 3], body_quat [N, B, 4], body_lin_vel / body_ang_vel [N, B, 3];
      foot_forces [N, F, 3] (total contact force on each foot, last physics step);
      base_force [N, 6] (external wrench on the base CoM, applied at every physics step until changed);
      body_mass [N, B], body_com [N, B, 3], joint_kp / joint_kd / joint_effort_limit / joint_armature [N, J]: the
      current per-world parameters (change them through the set_* methods only).
    """

    robot: RobotConfig
    cfg: WorldConfig
    num_envs: int
    num_bodies: int
    body_index: dict[str, int]
    default_joint_q: torch.Tensor
    windows: TerrainWindows | None
    joint_q: torch.Tensor
    joint_qd: torch.Tensor
    root_pos: torch.Tensor
    root_quat: torch.Tensor
    root_lin_vel: torch.Tensor
    root_ang_vel: torch.Tensor
    joint_pos: torch.Tensor
    joint_vel: torch.Tensor
    joint_target: torch.Tensor
    joint_torque: torch.Tensor
    body_pos: torch.Tensor
    body_quat: torch.Tensor
    body_lin_vel: torch.Tensor
    body_ang_vel: torch.Tensor
    foot_forces: torch.Tensor
    base_force: torch.Tensor
    body_mass: torch.Tensor
    body_com: torch.Tensor
    joint_kp: torch.Tensor
    joint_kd: torch.Tensor
    joint_effort_limit: torch.Tensor
    joint_armature: torch.Tensor

    def step(self) -> None: ...
    def reset(self, env_ids: torch.Tensor | None = None, joint_q: torch.Tensor | None = None,
              joint_qd: torch.Tensor | None = None) -> None: ...
    def com(self) -> tuple[torch.Tensor, torch.Tensor]: ...
    def apply_impulse(self, env_ids: torch.Tensor, delta_v: torch.Tensor) -> None: ...
    def set_mass_scale(self, env_ids: torch.Tensor, scale: torch.Tensor) -> None: ...
    def set_base_com_offset(self, env_ids: torch.Tensor, offset: torch.Tensor) -> None: ...
    def set_actuators(self, env_ids: torch.Tensor, strength: torch.Tensor, kp_scale: torch.Tensor | None = None,
                      kd_scale: torch.Tensor | None = None) -> None: ...
    def set_armature(self, env_ids: torch.Tensor, scale: torch.Tensor) -> None: ...
    def set_friction(self, env_ids: torch.Tensor, mu: torch.Tensor) -> None: ...
    def commit_physics(self) -> None: ...
