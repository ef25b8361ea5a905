"""The Newton backend: N copies of a robot plus static terrain in one Newton model, stepped by SolverMuJoCo
(mujoco_warp) under one captured graph, on the CPU or CUDA.

It implements the interface of cra_warp.sim.config.World. Every view aliases Warp memory: writing into
``joint_target`` or ``joint_qd`` reaches the solver, and the sim's updates are visible in the views without copies.
Nothing here loops over worlds in Python.
"""

from __future__ import annotations

import time

import numpy as np
import torch
import warp as wp

import newton

# Warp logs every kernel module load (hundreds per world); keep the console for our own progress output.
wp.config.quiet = True
wp.config.log_level = wp.LOG_WARNING
from newton import JointTargetMode
from mujoco_warp import OverflowType
from newton.sensors import SensorContact

from cra_warp.rotations import quat_rotate
from cra_warp.sim.config import FREE_Q, FREE_QD, TerrainBoxes, WorldConfig
from cra_warp.terrain.window import PARK_DEPTH, PARK_HALF, TerrainWindows
from robots.robot_config import RobotConfig, robot_urdf_text


class NewtonWorld:
    """A batched Newton world of ``num_envs`` robots on ``device`` (built by make_world, which checks them).

    Views (torch, on the sim's device, aliasing the sim's arrays):
      root_pos [N, 3], root_quat [N, 4] (xyzw), root_lin_vel [N, 3], root_ang_vel [N, 3] (world frame; the linear
      velocity is the base CoM's), joint_pos [N, J], joint_vel [N, J], joint_target [N, J] (PD position targets),
      body_pos [N, B, 3], body_quat [N, B, 4], body_lin_vel / body_ang_vel [N, B, 3], foot_forces [N, F, 3]
      (total contact force on each foot, world frame, refreshed once per env step), base_force [N, 6] (external
      wrench on the base CoM, world frame, applied at every substep until changed), joint_torque [N, J] (the PD
      torque applied in the last physics step, after the effort clamp).
    """

    def __init__(self, robot: RobotConfig, cfg: WorldConfig, terrain: TerrainBoxes | None, num_envs: int,
                 device: str):
        self.robot = robot
        self.cfg = cfg
        self.device = wp.get_device(device)
        # Warp's work goes on torch's current stream: the task writes the views with torch ops, which CUDA orders on
        # that stream, and Warp's own stream would race them. The CPU has no streams (None: Warp's scopes no-op).
        self._stream = wp.stream_from_torch(torch.cuda.current_stream(str(self.device))) if self.device.is_cuda \
            else None
        self.num_envs = N = num_envs
        t0 = time.perf_counter()

        model, self._body_names = self._build_model(robot, cfg, terrain, N, device)
        self.model = model
        self.num_bodies = B = model.body_count // N
        nj = robot.num_joints
        if model.joint_coord_count != N * (FREE_Q + nj) or model.joint_dof_count != N * (FREE_QD + nj):
            raise ValueError(f"{robot.name}: the simulator has {model.joint_dof_count // N - FREE_QD} driven dofs "
                             f"per robot, the config lists {nj}")

        nconmax, njmax = self._buffer_sizes(cfg, terrain)
        self.solver = newton.solvers.SolverMuJoCo(
            model, iterations=cfg.iterations, ls_iterations=cfg.ls_iterations, nconmax=nconmax, njmax=njmax,
            integrator=cfg.integrator, use_mujoco_contacts=True, disable_sensors=True)
        # Hitting the iteration cap is expected with few iterations (we measure the stand, not the residual);
        # mujoco_warp would printf a warning from inside the kernel at every step.
        self.solver.mjw_model.opt.warn_overflow &= ~int(OverflowType.ITERATIONS | OverflowType.LS_ITERATIONS)

        self.state_0, self.state_1 = model.state(), model.state()
        self.control = model.control()
        newton.eval_fk(model, model.joint_q, model.joint_qd, self.state_0)

        # Per-foot forces: the solver exports its contacts and their forces into these buffers (last substep only).
        self._contact_sensor = SensorContact(model, sensing_bodies=self._foot_body_indices().tolist(),
                                             request_contact_attributes=False)
        self._contacts = newton.CollisionPipeline(model, rigid_contact_max=self.solver.get_max_contact_count(),
                                                  soft_contact_max=0).contacts()
        self._observables = self.solver.observables(kinds=self._contact_sensor.solver_observable_kinds,
                                                    contacts=self._contacts)
        self._base_force_wp = wp.zeros(N * B, dtype=wp.spatial_vector, device=self.device)

        self._changed = 0  # ModelFlags of parameters set but not yet handed to the solver
        self._make_views()
        self.default_joint_q = self.joint_q.clone()
        self.windows: TerrainWindows | None = None
        if terrain is not None and cfg.terrain_window is not None:
            self._init_windows(terrain)
        self.graph = None
        # Warp captures graphs on the CPU, and on CUDA only with the stream-ordered memory pool (as Newton's
        # examples gate it); elsewhere the step launches its kernels one by one.
        if cfg.capture and (self.device.is_cpu or wp.is_mempool_enabled(self.device)):
            with wp.ScopedStream(self._stream):
                self._simulate()  # warm-up outside the capture: kernels compile and load here
                self.reset()
                with wp.ScopedCapture(device=self.device) as cap:
                    self._simulate()
            self.graph = cap.graph
            self.reset()
        self.build_seconds = time.perf_counter() - t0

    # ---------------------------------------------------------------- building
    @staticmethod
    def _build_model(robot: RobotConfig, cfg: WorldConfig, terrain: TerrainBoxes | None, num_envs: int, device: str):
        proto = newton.ModelBuilder()
        newton.solvers.SolverMuJoCo.register_custom_attributes(proto)
        proto.rigid_gap = cfg.contact_gap
        proto.default_shape_cfg.gap = cfg.contact_gap
        proto.default_shape_cfg.mu = cfg.friction
        proto.default_joint_cfg = newton.ModelBuilder.JointDofConfig(armature=robot.armature)
        proto.add_urdf(robot_urdf_text(robot), floating=True, enable_self_collisions=False,
                       collapse_fixed_joints=True, joint_ordering="dfs")
        names = [proto.joint_label[i].split("/")[-1] for i in range(1, proto.joint_count)]
        if tuple(names) != robot.joint_names:
            raise ValueError(f"{robot.name}: the URDF's depth-first joint order {names} differs from the config's "
                             f"canonical order; reorder the URDF or the config")
        # Standing pose and PD drives on every driven dof (dof 0..5 are the free base).
        proto.joint_q[:3] = [0.0, 0.0, robot.base_height]
        proto.joint_q[3:7] = [0.0, 0.0, 0.0, 1.0]
        proto.joint_q[FREE_Q:] = list(robot.default_q)
        for j in range(robot.num_joints):
            d = FREE_QD + j
            proto.joint_target_mode[d] = int(JointTargetMode.POSITION)
            proto.joint_target_ke[d] = robot.kp[j]
            proto.joint_target_kd[d] = robot.kd[j]
            proto.joint_effort_limit[d] = robot.effort_limit[j]
            proto.joint_target_q[FREE_Q + j] = robot.default_q[j]
        body_names = [lbl.split("/")[-1] for lbl in proto.body_label]
        if cfg.contacts == "feet":
            foot_bodies = {body_names.index(n) for n in robot.foot_links}
            for s in range(proto.shape_count):
                if proto.shape_body[s] not in foot_bodies:
                    proto.shape_flags[s] &= ~int(newton.ShapeFlags.COLLIDE_SHAPES)

        # MuJoCo gives a contact the larger friction of its two geoms: (nearly) frictionless terrain lets each world's robot
        # shapes set the friction, so it can be randomised per world without per-world terrain copies.
        terrain_mu = 1e-3  # ~0 (MuJoCo warns below 1e-5)
        windowed = terrain is not None and cfg.terrain_window is not None
        if windowed:  # this world's window slots: static boxes, placed by _follow_terrain
            slot_cfg = newton.ModelBuilder.ShapeConfig(mu=terrain_mu, gap=cfg.contact_gap)
            for _ in range(cfg.terrain_window.slots):
                proto.add_shape_box(-1, xform=wp.transform(wp.vec3(0.0, 0.0, PARK_DEPTH), wp.quat_identity()),
                                    hx=PARK_HALF, hy=PARK_HALF, hz=PARK_HALF, cfg=slot_cfg)

        builder = newton.ModelBuilder()
        builder.rigid_gap = cfg.contact_gap
        builder.default_shape_cfg.gap = cfg.contact_gap
        builder.replicate(proto, num_envs, spacing=(0.0, 0.0, 0.0))
        builder.default_shape_cfg.mu = terrain_mu
        builder.add_ground_plane()
        if terrain is not None and not windowed:
            for c, h, q in zip(terrain.centers, terrain.half_extents, terrain.quats):
                builder.add_shape_box(-1, xform=wp.transform(wp.vec3(*c), wp.quat(*q)), hx=h[0], hy=h[1], hz=h[2])
        return builder.finalize(device=device), body_names

    @staticmethod
    def _buffer_sizes(cfg: WorldConfig, terrain: TerrainBoxes | None) -> tuple[int, int]:
        # A sole box on a plane makes 4 contacts, on a stair edge up to 8; limbs add a few when "all" collide.
        nconmax = cfg.nconmax or (16 if cfg.contacts == "feet" else 32) * (2 if terrain is not None else 1)
        njmax = cfg.njmax or 4 * nconmax + 32  # pyramidal cone: 4 rows per contact, plus joint limits
        return nconmax, njmax

    def _foot_body_indices(self) -> np.ndarray:
        """Global body indices of the feet, [N * F], world-major."""
        local = [self._body_names.index(n) for n in self.robot.foot_links]
        return (np.arange(self.num_envs)[:, None] * self.num_bodies + np.asarray(local)[None, :]).reshape(-1)

    def _make_views(self):
        N, B, nj = self.num_envs, self.num_bodies, self.robot.num_joints
        t = wp.to_torch
        self.joint_q = t(self.state_0.joint_q).view(N, FREE_Q + nj)
        self.joint_qd = t(self.state_0.joint_qd).view(N, FREE_QD + nj)
        self.root_pos, self.root_quat = self.joint_q[:, 0:3], self.joint_q[:, 3:7]
        self.root_lin_vel, self.root_ang_vel = self.joint_qd[:, 0:3], self.joint_qd[:, 3:6]
        self.joint_pos, self.joint_vel = self.joint_q[:, FREE_Q:], self.joint_qd[:, FREE_QD:]
        self.joint_target = t(self.control.joint_target_q).view(N, FREE_Q + nj)[:, FREE_Q:]
        body_q = t(self.state_0.body_q).view(N, B, 7)
        body_qd = t(self.state_0.body_qd).view(N, B, 6)
        self.body_pos, self.body_quat = body_q[..., 0:3], body_q[..., 3:7]
        self.body_lin_vel, self.body_ang_vel = body_qd[..., 0:3], body_qd[..., 3:6]
        self.foot_forces = t(self._contact_sensor.total_force).view(N, len(self.robot.foot_links), 3)
        self.base_force = t(self._base_force_wp).view(N, B, 6)[:, 0]
        # qfrc_actuator is the PD output after the joint's effort clamp (actuator_force is the unclamped request)
        self.joint_torque = t(self.solver.mjw_data.qfrc_actuator).view(N, -1)[:, FREE_QD:]
        self.body_index = {n: i for i, n in enumerate(self._body_names)}
        # Physical parameters per world [N, ...] (randomise through the set_* methods, which keep them consistent).
        self.body_mass = t(self.model.body_mass).view(N, B)              # [N, B] kg
        self.body_com = t(self.model.body_com).view(N, B, 3)             # [N, B, 3] body frame
        self.body_inertia = t(self.model.body_inertia).view(N, B, 3, 3)  # [N, B, 3, 3] about the CoM
        self.joint_kp = t(self.model.joint_target_ke).view(N, -1)[:, FREE_QD:]
        self.joint_kd = t(self.model.joint_target_kd).view(N, -1)[:, FREE_QD:]
        self.joint_effort_limit = t(self.model.joint_effort_limit).view(N, -1)[:, FREE_QD:]
        self.joint_armature = t(self.model.joint_armature).view(N, -1)[:, FREE_QD:]
        self._nominal = {k: getattr(self, k).clone() for k in
                         ("body_mass", "body_com", "body_inertia", "joint_kp", "joint_kd", "joint_effort_limit",
                          "joint_armature")}
        shape_body = self.model.shape_body.numpy()
        self._robot_shapes = torch.as_tensor(np.flatnonzero(shape_body >= 0).reshape(N, -1))  # [N, S] world-major
        # The constraint solver starts from the previous step's accelerations; a reset world must not inherit them,
        # so that its trajectory depends only on the state it was reset to.
        self._warmstart = t(self.solver.mjw_data.qacc_warmstart)

    def _init_windows(self, terrain: TerrainBoxes):
        N, dev = self.num_envs, self.joint_q.device
        self.windows = TerrainWindows(terrain.centers, terrain.half_extents, terrain.quats, N, self.cfg.terrain_window,
                                      dev)
        shape_body, shape_world = self.model.shape_body.numpy(), self.model.shape_world.numpy()
        slots = np.flatnonzero((shape_body == -1) & (shape_world >= 0))
        self._slot_shapes = torch.as_tensor(slots.reshape(N, self.cfg.terrain_window.slots), device=dev)  # [N, K]
        self._shape_pose = wp.to_torch(self.model.shape_transform)   # [S, 7] position, quaternion xyzw
        self._shape_scale = wp.to_torch(self.model.shape_scale)      # [S, 3] a box's half extents
        self._follow_terrain()

    def _follow_terrain(self):
        """Refill the windows of the worlds whose robot moved away from its window's centre (walking, or reset
        to another place)."""
        ids = self.windows.stale(self.root_pos[:, :2])
        if len(ids) == 0:
            return
        centers, half, quats = self.windows.select(ids, self.root_pos[ids, :2])
        shapes = self._slot_shapes[ids]
        self._shape_pose[shapes] = torch.cat([centers, quats], -1)
        self._shape_scale[shapes] = half
        self._changed |= int(newton.ModelFlags.SHAPE_PROPERTIES)
        self.commit_physics()  # with any parameters set since: one conversion

    def usd_recorder(self, path: str, fps: int, num_frames: int):
        """An animated USD stage of this world (Newton's ViewerUSD): call ``.frame(t)`` after each step you want
        recorded, ``.close()`` at the end. Static shapes are drawn once, so a windowed world records its first
        windows only: build it with terrain_window=None to record a whole course."""
        import newton.viewer

        viewer = newton.viewer.ViewerUSD(path, fps=fps, num_frames=num_frames)
        viewer.set_model(self.model)
        world = self

        class _Recorder:
            def frame(self, t: float):
                viewer.begin_frame(t)
                viewer.log_state(world.state_0)
                viewer.end_frame()

            def close(self):
                viewer.close()

        return _Recorder()

    # ---------------------------------------------------------------- stepping
    def _simulate(self):
        s0, s1 = self.state_0, self.state_1
        dt = self.cfg.sim_dt
        for k in range(self.cfg.substeps):
            wp.copy(s0.body_f, self._base_force_wp)
            last = k == self.cfg.substeps - 1
            self.solver.step(s0, s1, self.control, self._contacts if last else None, dt,
                             observables=self._observables if last else None)
            s0, s1 = s1, s0
        self._contact_sensor.update(s0, self._contacts, observables=self._observables)

    def step(self):
        """Advance one env step (substeps x sim_dt). The views hold the new state afterwards."""
        with wp.ScopedStream(self._stream):
            if self.windows is not None:
                self._follow_terrain()
            if self.graph is not None:
                wp.capture_launch(self.graph)
            else:
                self._simulate()

    def com(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Whole-body centre of mass [N, 3] and its velocity [N, 3], world frame: mass-weighted link CoMs (the
        randomised masses and base CoM offset included)."""
        m = self.body_mass.unsqueeze(-1)                                    # [N, B, 1]
        link_com = self.body_pos + quat_rotate(self.body_quat, self.body_com)
        total = m.sum(1)
        return (m * link_com).sum(1) / total, (m * self.body_lin_vel).sum(1) / total

    # ---------------------------------------------------------------- resets and perturbations
    def reset(self, env_ids: torch.Tensor | None = None, joint_q: torch.Tensor | None = None,
              joint_qd: torch.Tensor | None = None):
        """Set the full state of the worlds ``env_ids`` (all if None); other worlds are untouched.

        joint_q [n, 7 + J] (base position, base quaternion xyzw, joint positions) and joint_qd [n, 6 + J]
        (base CoM linear and angular velocity in the world frame, joint velocities). Defaults: the initial standing
        pose at rest. PD targets of the reset worlds go to the reference pose, external forces to zero.
        """
        dev = self.joint_q.device
        ids = torch.arange(self.num_envs, device=dev) if env_ids is None else env_ids.to(dev, torch.long)
        self.joint_q[ids] = self.default_joint_q[ids] if joint_q is None else joint_q
        self.joint_qd[ids] = 0.0 if joint_qd is None else joint_qd
        self.joint_target[ids] = self.default_joint_q[ids, FREE_Q:]
        self.base_force[ids] = 0.0
        self.foot_forces[ids] = 0.0
        self._warmstart[ids] = 0.0
        mask = torch.zeros(self.num_envs, dtype=torch.bool, device=dev)
        mask[ids] = True
        with wp.ScopedStream(self._stream):
            newton.eval_fk(self.model, self.state_0.joint_q, self.state_0.joint_qd, self.state_0,
                           mask=wp.from_torch(mask))

    # ---------------------------------------------------------------- physical parameters (domain randomisation)
    def set_mass_scale(self, env_ids: torch.Tensor, scale: torch.Tensor):
        """Scale every link's mass and inertia of the given worlds by ``scale`` [n, B] relative to nominal."""
        self.body_mass[env_ids] = self._nominal["body_mass"][env_ids] * scale
        self.body_inertia[env_ids] = self._nominal["body_inertia"][env_ids] * scale[..., None, None]
        self._changed |= int(newton.ModelFlags.BODY_INERTIAL_PROPERTIES)

    def set_base_com_offset(self, env_ids: torch.Tensor, offset: torch.Tensor):
        """Move the base link's CoM of the given worlds by ``offset`` [n, 3] (base frame, m) from nominal."""
        self.body_com[env_ids, 0] = self._nominal["body_com"][env_ids, 0] + offset
        self._changed |= int(newton.ModelFlags.BODY_INERTIAL_PROPERTIES)

    def set_actuators(self, env_ids: torch.Tensor, strength: torch.Tensor, kp_scale: torch.Tensor | None = None,
                      kd_scale: torch.Tensor | None = None):
        """Actuators of the given worlds, each [n, J] relative to nominal: the PD gains are off by ``kp_scale`` and
        ``kd_scale`` (None: 1), and the motor delivers ``strength`` x the PD torque (its effort limit too)."""
        kp_scale = 1.0 if kp_scale is None else kp_scale
        kd_scale = 1.0 if kd_scale is None else kd_scale
        self.joint_kp[env_ids] = self._nominal["joint_kp"][env_ids] * strength * kp_scale
        self.joint_kd[env_ids] = self._nominal["joint_kd"][env_ids] * strength * kd_scale
        self.joint_effort_limit[env_ids] = self._nominal["joint_effort_limit"][env_ids] * strength
        self._changed |= int(newton.ModelFlags.JOINT_DOF_PROPERTIES | newton.ModelFlags.ACTUATOR_PROPERTIES)

    def set_armature(self, env_ids: torch.Tensor, scale: torch.Tensor):
        """Rotor inertia of every driven joint of the given worlds: ``scale`` [n, J] x the robot's armature."""
        self.joint_armature[env_ids] = self._nominal["joint_armature"][env_ids] * scale
        self._changed |= int(newton.ModelFlags.JOINT_DOF_INERTIAL_PROPERTIES)

    def set_friction(self, env_ids: torch.Tensor, mu: torch.Tensor):
        """Friction coefficient [n] of every robot shape in the given worlds (the terrain is frictionless: see build)."""
        mus = wp.to_torch(self.model.shape_material_mu)
        shapes = self._robot_shapes[env_ids.cpu()].to(mus.device)
        mus[shapes] = mu.unsqueeze(1).expand(-1, shapes.shape[1]).to(mus.dtype)
        self._changed |= int(newton.ModelFlags.SHAPE_PROPERTIES)

    def commit_physics(self):
        """Hand the parameters changed by set_* to the solver (one conversion for all of them, between steps)."""
        if self._changed:
            with wp.ScopedStream(self._stream):
                self.solver.notify_model_changed(self._changed)
            self._changed = 0

    def apply_impulse(self, env_ids: torch.Tensor, delta_v: torch.Tensor):
        """Add ``delta_v`` [n, 3] (m/s, world frame) to the base velocity of the given worlds (a push)."""
        self.joint_qd[env_ids, 0:3] += delta_v


def build_mjcf(robot: RobotConfig, cfg: WorldConfig, terrain: TerrainBoxes | None = None) -> str:
    """cra_warp.sim.mjcf's builder: SolverMuJoCo's MJCF export of a one-world, uncaptured Newton model."""
    import dataclasses
    import tempfile

    one = dataclasses.replace(cfg, capture=False, terrain_window=None, backend="newton")
    model, _ = NewtonWorld._build_model(robot, one, terrain, 1, "cpu")
    nconmax, njmax = NewtonWorld._buffer_sizes(one, terrain)
    with tempfile.TemporaryDirectory() as tmp:
        path = f"{tmp}/model.xml"
        newton.solvers.SolverMuJoCo(model, iterations=cfg.iterations, ls_iterations=cfg.ls_iterations,
                                    nconmax=nconmax, njmax=njmax, integrator=cfg.integrator,
                                    use_mujoco_contacts=True, disable_sensors=True, save_to_mjcf=path)
        with open(path) as f:
            return f.read()
