"""The MuJoCo C backend: N simulations of the MjModel Newton's SolverMuJoCo builds for one world, stepped together
by MuJoCo's batched simulation (mujoco.batch: one state row per world, a thread pool; CPU only).

It implements cra_warp.sim.config.World with the same physics as the Newton backend (same model, options, PD
actuators and contact settings; tests hold the two to the same trajectories). Physical parameters are per world
(the batch's per-simulation model fields). One env step is ``substeps`` physics steps of every world; the state rows
carry the solver's warm start from one physics step to the next, as Newton does.

MuJoCo keeps float64 state with wxyz quaternions and a free joint whose linear velocity is the body origin's and
whose angular velocity is in the body frame; the views are float32 torch tensors in this interface's conventions
(xyzw, base CoM velocity, world-frame angular velocity), converted once per step in batched torch. A world whose
state view was written (reset, push, or directly) is converted back before the next step; the others keep their
float64 state exactly. Body poses and velocities, the whole-body CoM, foot forces and joint torques come from MuJoCo
sensors of the last physics step, evaluated at its start (one physics step, 5 ms, before the state); the sensors
are off in the env step's other physics steps, whose values nobody reads. A reset world gets them from a forward
pass at its new state. No Python loop runs over worlds.
"""

from __future__ import annotations

import os
import re
import time
import warnings

import mujoco
import numpy as np
import torch
from mujoco.batch import Batch, SimulationError

from cra_warp.rotations import quat_rotate, quat_rotate_inv
from cra_warp.sim import mjcf
from cra_warp.sim.config import FREE_Q, FREE_QD, TerrainBoxes, WorldConfig
from robots.robot_config import RobotConfig

_NO_SENSORS = int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
# model fields that differ per world (domain randomisation); mj_setConst derives the rest from them
_PER_WORLD = ("body_mass", "body_inertia", "body_ipos", "actuator_gainprm", "actuator_biasprm", "jnt_actfrcrange",
              "geom_friction", "dof_armature")
_BODY_SENSORS = 13  # per body: position (3), quaternion wxyz (4) of its frame, CoM linear (3), angular velocity (3)


def _wxyz_to_xyzw(q: torch.Tensor) -> torch.Tensor:
    return torch.cat([q[..., 1:4], q[..., :1]], -1)


def _xyzw_to_wxyz(q: torch.Tensor) -> torch.Tensor:
    return torch.cat([q[..., 3:4], q[..., :3]], -1)


class MujocoWorld:
    """A batched MuJoCo C world of ``num_envs`` robots on the CPU (built by make_world, which checks the size and
    device); see cra_warp.sim.config.World for the views."""

    def __init__(self, robot: RobotConfig, cfg: WorldConfig, terrain: TerrainBoxes | None, num_envs: int):
        self.robot = robot
        self.cfg = cfg
        t0 = time.perf_counter()
        self.num_envs = N = num_envs
        J, F = robot.num_joints, len(robot.foot_links)
        xml = mjcf(robot, cfg, terrain)
        prefix = f"{robot.name}_"
        self._body_names = re.findall(r'<body name="([^"]+)"', xml)
        names = [b[len(prefix):] for b in self._body_names]
        self.num_bodies = B = len(names)
        self.body_index = {n: i for i, n in enumerate(names)}
        base = mujoco.MjModel.from_xml_string(self._with_sensors(xml, prefix))
        base.opt.timestep = cfg.sim_dt  # Newton passes dt per step; its MJCF leaves the default
        joints = [base.joint(j + 1).name[len(prefix):] for j in range(base.njnt - 1)]
        actuated = [int(base.actuator_trnid[a, 0]) for a in range(base.nu)]
        if tuple(joints) != robot.joint_names or actuated != list(range(1, J + 1)) or base.nq != FREE_Q + J:
            raise ValueError(f"{robot.name}: the MuJoCo model's joints {joints} are not the config's {robot.joint_names}")
        self._base = base
        self._batch = batch = Batch(base, N, nthread=cfg.threads or len(os.sched_getaffinity(0)))
        batch.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)  # every state row: the model's defaults
        self._fields = {f: batch.expand(f) for f in _PER_WORLD}                           # [N, ...] numpy views
        self._flags = batch.expand("opt.disableflags")                                    # [N]
        self._body_ids = np.array([base.body(n).id for n in self._body_names])           # [B] MuJoCo body ids
        self._robot_geoms = np.flatnonzero(base.geom_bodyid > 0)                          # robot geoms (not world)

        # float64 torch aliases of the batch's state rows (its time, qpos, qvel, warm start and inputs) and sensors
        self._time, self._qpos64, self._qvel64 = (torch.from_numpy(batch.bind(f)) for f in ("time", "qpos", "qvel"))
        self._warmstart = torch.from_numpy(batch.bind("qacc_warmstart"))
        self._ctrl64, self._xfrc64 = torch.from_numpy(batch.bind("ctrl")), torch.from_numpy(batch.bind("xfrc_applied"))
        self._xfrc_base = self._xfrc64[:, int(self._body_ids[0])]                         # [N, 6] the base's wrench
        with warnings.catch_warnings():  # read-only output, refreshed in place by every batch call; only read here
            warnings.simplefilter("ignore", UserWarning)
            self._sens64 = torch.from_numpy(batch.bind("sensordata"))
        self._warnings = batch.warning[..., 1]                                            # [N, kinds] counts

        # float32 views in the interface's conventions
        f32 = dict(dtype=torch.float32)
        self.joint_q, self.joint_qd = torch.zeros(N, FREE_Q + J, **f32), torch.zeros(N, FREE_QD + J, **f32)
        self._published_q, self._published_qd = self.joint_q.clone(), self.joint_qd.clone()
        self.root_pos, self.root_quat = self.joint_q[:, 0:3], self.joint_q[:, 3:7]
        self.root_lin_vel, self.root_ang_vel = self.joint_qd[:, 0:3], self.joint_qd[:, 3:6]
        self.joint_pos, self.joint_vel = self.joint_q[:, FREE_Q:], self.joint_qd[:, FREE_QD:]
        self.joint_target = torch.tensor(robot.default_q, **f32).repeat(N, 1)
        self.base_force = torch.zeros(N, 6, **f32)
        self._bodies = torch.zeros(N, B, _BODY_SENSORS, **f32)
        self.body_pos, self.body_quat = self._bodies[..., 0:3], self._bodies[..., 3:7]
        self.body_lin_vel, self.body_ang_vel = self._bodies[..., 7:10], self._bodies[..., 10:13]
        self.foot_forces = torch.zeros(N, F, 3, **f32)
        self.joint_torque = torch.zeros(N, J, **f32)
        self._com = torch.zeros(N, 6, **f32)
        self._sensor_slices()

        # per-world physical parameters [N, ...] (float32 mirrors of the models'; set_* then commit_physics)
        mass = torch.tensor(base.body_mass[self._body_ids], **f32)
        self.body_mass = mass.repeat(N, 1)
        self.body_com = torch.tensor(base.body_ipos[self._body_ids], **f32).repeat(N, 1, 1)
        self._inertia0 = base.body_inertia[self._body_ids].copy()  # principal moments, body_iquat frame
        self.joint_kp = torch.tensor(base.actuator_gainprm[:, 0], **f32).repeat(N, 1)
        self.joint_kd = torch.tensor(-base.actuator_biasprm[:, 2], **f32).repeat(N, 1)
        self.joint_effort_limit = torch.tensor(base.jnt_actfrcrange[1:, 1], **f32).repeat(N, 1)
        self.joint_armature = torch.tensor(base.dof_armature[FREE_QD:], **f32).repeat(N, 1)
        self._friction = torch.full((N,), float(base.geom_friction[self._robot_geoms[0], 0]), **f32)
        self._nominal = {k: getattr(self, k).clone() for k in
                         ("body_mass", "body_com", "joint_kp", "joint_kd", "joint_effort_limit", "joint_armature")}
        self._dirty = torch.zeros(N, dtype=torch.bool)
        self.windows = None  # every terrain box is in the model

        # the initial state: the robot's standing pose at rest, in every world
        self.default_joint_q = torch.zeros(N, FREE_Q + J, **f32)
        self.default_joint_q[:, 2] = robot.base_height
        self.default_joint_q[:, 6] = 1.0
        self.default_joint_q[:, FREE_Q:] = torch.tensor(robot.default_q, **f32)
        self.reset()
        self.build_seconds = time.perf_counter() - t0

    # ---------------------------------------------------------------- building
    def _with_sensors(self, xml: str, prefix: str) -> str:
        """The model's MJCF with the sensors the views read, in this order: per body (Newton's body order) its
        frame position and quaternion, CoM linear and angular velocity; per foot the net contact force; per joint
        the actuator torque; the whole-body CoM and its velocity."""
        rows = []
        for b in self._body_names:
            rows += [f'<framepos objtype="xbody" objname="{b}"/>', f'<framequat objtype="xbody" objname="{b}"/>',
                     f'<framelinvel objtype="body" objname="{b}"/>', f'<frameangvel objtype="body" objname="{b}"/>']
        rows += [f'<contact body1="{prefix}{f}" data="force" reduce="netforce" num="1"/>' for f in self.robot.foot_links]
        rows += [f'<jointactuatorfrc joint="{prefix}{j}"/>' for j in self.robot.joint_names]
        root = self._body_names[0]
        rows += [f'<subtreecom body="{root}"/>', f'<subtreelinvel body="{root}"/>']
        xml = re.sub(r'\s*<flag sensor="disable"[^/]*/>', "", xml)
        return xml.replace("</mujoco>", "<sensor>\n" + "\n".join(rows) + "\n</sensor>\n</mujoco>")

    def _sensor_slices(self):
        B, F, J = self.num_bodies, len(self.robot.foot_links), self.robot.num_joints
        n_bodies = B * _BODY_SENSORS
        self._s_bodies = slice(0, n_bodies)
        self._s_feet = slice(n_bodies, n_bodies + 3 * F)
        self._s_torque = slice(self._s_feet.stop, self._s_feet.stop + J)
        self._s_com = slice(self._s_torque.stop, self._s_torque.stop + 6)
        if self._s_com.stop != self._base.nsensordata:
            raise AssertionError("sensor layout does not match the model's sensordata")

    # ---------------------------------------------------------------- state conversion
    def _publish(self, ids: torch.Tensor | None = None):
        """float64 MuJoCo state and sensors -> the float32 views (all worlds, or ``ids``)."""
        ids = slice(None) if ids is None else ids
        qpos, qvel = self._qpos64[ids], self._qvel64[ids]
        quat = _wxyz_to_xyzw(qpos[:, 3:7])
        w_world = quat_rotate(quat, qvel[:, 3:6])
        c = quat_rotate(quat, self.body_com[ids, 0].double())                     # base CoM offset, world frame
        v_com = qvel[:, 0:3] + torch.cross(w_world, c, dim=-1)
        self.joint_q[ids] = torch.cat([qpos[:, 0:3], quat, qpos[:, 7:]], -1).float()
        self.joint_qd[ids] = torch.cat([v_com, w_world, qvel[:, 6:]], -1).float()
        s = self._sens64[ids]
        bodies = s[:, self._s_bodies].view(-1, self.num_bodies, _BODY_SENSORS)
        self._bodies[ids] = torch.cat([bodies[..., 0:3], _wxyz_to_xyzw(bodies[..., 3:7]), bodies[..., 7:]], -1).float()
        self.foot_forces[ids] = -s[:, self._s_feet].view(-1, len(self.robot.foot_links), 3).float()  # on the foot
        self.joint_torque[ids] = s[:, self._s_torque].float()
        self._com[ids] = s[:, self._s_com].float()
        self._published_q[ids] = self.joint_q[ids]     # what the sim holds: a later change is a write to push
        self._published_qd[ids] = self.joint_qd[ids]

    def _write_back(self, rows: torch.Tensor):
        """The float32 views of worlds ``rows`` -> their float64 MuJoCo state (inverse of _publish)."""
        q, qd = self.joint_q[rows].double(), self.joint_qd[rows].double()
        quat = q[:, 3:7] / q[:, 3:7].norm(dim=-1, keepdim=True)
        c = quat_rotate(quat, self.body_com[rows, 0].double())
        v_origin = qd[:, 0:3] - torch.cross(qd[:, 3:6], c, dim=-1)
        self._qpos64[rows] = torch.cat([q[:, 0:3], _xyzw_to_wxyz(quat), q[:, 7:]], -1)
        self._qvel64[rows] = torch.cat([v_origin, quat_rotate_inv(quat, qd[:, 3:6]), qd[:, 6:]], -1)

    def _advance(self, nstep: int) -> np.ndarray:
        """``nstep`` physics steps of every world; returns the ids of worlds MuJoCo raised an error in (they keep
        their state)."""
        try:
            self._batch.step(nstep=nstep)
        except SimulationError as e:
            return e.ids
        return np.zeros(0, dtype=np.int64)

    # ---------------------------------------------------------------- stepping
    def step(self):
        """Advance one env step (substeps x sim_dt). The views hold the new state afterwards."""
        changed = ((self.joint_q != self._published_q).any(1) | (self.joint_qd != self._published_qd).any(1))
        if changed.any():
            self._write_back(changed.nonzero().flatten())
        self._ctrl64[:] = self.joint_target
        self._xfrc_base[:] = self.base_force
        # MuJoCo silently resets a world whose state is not finite, or turns so during the step (to the model's
        # qpos0, time 0), and it warns (and goes on) when its contact or constraint buffer is full. Such a world is
        # made non-finite instead, so the task sees it, resets it and counts it, as on Newton: its clock ends short
        # of start + one env step, or its warning counts rose.
        broken = ~(torch.isfinite(self._qpos64).all(1) & torch.isfinite(self._qvel64).all(1))
        t_end = self._time + 0.5 * self.cfg.env_dt
        warned = self._warnings.sum(1)
        self._flags |= _NO_SENSORS
        failed = self._advance(self.cfg.substeps - 1)
        self._flags &= ~_NO_SENSORS
        failed = np.union1d(failed, self._advance(1))
        broken |= (self._time < t_end) | torch.from_numpy(self._warnings.sum(1) > warned)
        broken[torch.from_numpy(failed)] = True
        if broken.any():
            self._qvel64[broken] = float("nan")
        self._publish()

    def reset(self, env_ids: torch.Tensor | None = None, joint_q: torch.Tensor | None = None,
              joint_qd: torch.Tensor | None = None):
        """Set the full state of the worlds ``env_ids`` (all if None); other worlds are untouched. Same arguments
        and conventions as the Newton backend: targets to the reference pose, external forces to zero."""
        ids = torch.arange(self.num_envs) if env_ids is None else env_ids.cpu().long()
        self.joint_q[ids] = self.default_joint_q[ids] if joint_q is None else joint_q.float()
        self.joint_qd[ids] = 0.0 if joint_qd is None else joint_qd.float()
        self.joint_target[ids] = self.default_joint_q[ids, FREE_Q:]
        self.base_force[ids] = 0.0
        self._write_back(ids)
        self._time[ids] = 0.0
        self._warmstart[ids] = 0.0
        self._xfrc64[ids] = 0.0
        self._ctrl64[ids] = self.joint_target[ids].double()
        self._batch.forward(ids.numpy())  # the sensors at the new state, as the last step's output
        self._publish(ids)
        self.foot_forces[ids] = 0.0  # no contact force before the first step, as in Newton

    def com(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Whole-body CoM [N, 3] and its velocity [N, 3] (MuJoCo's subtree sensors of the base)."""
        return self._com[:, 0:3], self._com[:, 3:6]

    def apply_impulse(self, env_ids: torch.Tensor, delta_v: torch.Tensor):
        """Add ``delta_v`` [n, 3] (m/s, world frame) to the base velocity of the given worlds (a push)."""
        self.joint_qd[env_ids.cpu(), 0:3] += delta_v.cpu()

    # ---------------------------------------------------------------- physical parameters (domain randomisation)
    def set_mass_scale(self, env_ids: torch.Tensor, scale: torch.Tensor):
        """Scale every link's mass and inertia of the given worlds by ``scale`` [n, B] relative to nominal."""
        ids = env_ids.cpu()
        self.body_mass[ids] = self._nominal["body_mass"][ids] * scale.cpu()
        self._dirty[ids] = True

    def set_base_com_offset(self, env_ids: torch.Tensor, offset: torch.Tensor):
        """Move the base link's CoM of the given worlds by ``offset`` [n, 3] (base frame, m) from nominal."""
        ids = env_ids.cpu()
        self.body_com[ids, 0] = self._nominal["body_com"][ids, 0] + offset.cpu()
        self._dirty[ids] = True

    def set_actuators(self, env_ids: torch.Tensor, strength: torch.Tensor, kp_scale: torch.Tensor | None = None,
                      kd_scale: torch.Tensor | None = None):
        """As the Newton backend: PD gains off by ``kp_scale`` / ``kd_scale``, torque (and limit) x ``strength``."""
        ids, strength = env_ids.cpu(), strength.cpu()
        kp_scale = 1.0 if kp_scale is None else kp_scale.cpu()
        kd_scale = 1.0 if kd_scale is None else kd_scale.cpu()
        self.joint_kp[ids] = self._nominal["joint_kp"][ids] * strength * kp_scale
        self.joint_kd[ids] = self._nominal["joint_kd"][ids] * strength * kd_scale
        self.joint_effort_limit[ids] = self._nominal["joint_effort_limit"][ids] * strength
        self._dirty[ids] = True

    def set_armature(self, env_ids: torch.Tensor, scale: torch.Tensor):
        """Rotor inertia of every driven joint of the given worlds: ``scale`` [n, J] x the robot's armature."""
        ids = env_ids.cpu()
        self.joint_armature[ids] = self._nominal["joint_armature"][ids] * scale.cpu()
        self._dirty[ids] = True

    def set_friction(self, env_ids: torch.Tensor, mu: torch.Tensor):
        """Friction coefficient [n] of every robot geom in the given worlds (the terrain is frictionless)."""
        ids = env_ids.cpu()
        self._friction[ids] = mu.cpu().float()
        self._dirty[ids] = True

    def commit_physics(self):
        """Write the parameters changed by set_* into the changed worlds' model fields, then their derived
        constants (body subtree masses, inverse weights: mj_setConst)."""
        ids = self._dirty.nonzero().flatten().numpy()
        if not len(ids):
            return
        f, rows, bodies, geoms = self._fields, ids[:, None], self._body_ids, self._robot_geoms
        mass, kp, kd = self.body_mass[ids].double(), self.joint_kp[ids].double(), self.joint_kd[ids].double()
        effort = self.joint_effort_limit[ids].double()
        f["body_mass"][rows, bodies] = mass.numpy()
        f["body_inertia"][rows, bodies] = self._inertia0 * (mass / self._nominal["body_mass"][ids]).unsqueeze(-1).numpy()
        f["body_ipos"][rows, bodies] = self.body_com[ids].double().numpy()
        f["actuator_gainprm"][ids, :, 0] = kp.numpy()
        f["actuator_biasprm"][ids, :, 1] = -kp.numpy()
        f["actuator_biasprm"][ids, :, 2] = -kd.numpy()
        f["jnt_actfrcrange"][ids, 1:, 0] = -effort.numpy()
        f["jnt_actfrcrange"][ids, 1:, 1] = effort.numpy()
        f["geom_friction"][rows, geoms, 0] = self._friction[ids].double().unsqueeze(-1).numpy()
        f["dof_armature"][ids, FREE_QD:] = self.joint_armature[ids].double().numpy()
        self._batch.set_const(ids)
        self._dirty[:] = False

    def close(self):
        self._batch = None  # its threads and buffers go with it
