"""The locomotion task as an rsl-rl 5.5.1 VecEnv (paper III-A, III-C, III-D, IV-A), for the robot its config names.

One env step (DESIGN.md): actions [N, A] -> gait clock -> PD targets written into the sim -> Newton world steps
(4 physics substeps, PD torques at each) -> kinematics and terrain sampling -> observations, rewards, dones ->
the env resets the worlds that ended. Everything after the sim step is batched torch on the sim's device.
Choices the paper leaves open are listed in envs/loco_config.py.
"""

from __future__ import annotations

import math

import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from cra_warp.gait import GaitClock
from cra_warp.kinematics import Kinematics
from cra_warp.stand import ScriptedStand
from cra_warp.terrain.curriculum import PathMeter
from cra_warp.rotations import quat_rotate_inv, wrap_angle, yaw, yaw_quat
from cra_warp.sim import make_world
from envs import observations as obs_layout
from envs.difficulty import Difficulty
from envs.ground import Ground
from envs.loco_config import SIT_FRACTION, LocoConfig
from envs.rewards import TERMS
from robots import robot_by_name

GRAVITY = 9.81


class LocoEnv(VecEnv):
    def __init__(self, cfg: LocoConfig | None = None):
        self.cfg = cfg = cfg or LocoConfig()
        # the robot as the task sees it (joint groups, stand gains) and as it is driven (cfg.joint_gains applied)
        self.loco_robot = loco = robot_by_name(cfg.robot)
        self.robot = robot = loco.robot.with_gains(cfg.joint_gains) if cfg.joint_gains else loco.robot
        self.device = torch.device(cfg.device)
        self.num_envs = N = cfg.num_envs
        J = robot.num_joints
        self.num_actions = J + (3 if cfg.uses_clock else 0)
        # [num_actions] what step() clips each action to: the joints to +-clip_joint_actions, the gait actions to +-1
        self.action_bounds = torch.tensor([cfg.clip_joint_actions] * J + [1.0] * (self.num_actions - J),
                                          device=self.device)
        self.dt = cfg.world.env_dt
        self.max_episode_length = math.ceil(cfg.episode_length_s / self.dt)
        self.gen = torch.Generator(device=self.device).manual_seed(cfg.seed)

        self.ground = Ground(cfg.terrain, N, self.device, seed=cfg.seed, course=cfg.course,
                             curriculum_rule=cfg.terrain_curriculum, rough=cfg.rough)
        self.world = make_world(robot, cfg.world, self.ground.boxes, num_envs=N, device=cfg.device)
        self.kin = Kinematics(robot, self.device)
        self.clock = GaitClock(N, cfg.gait, self.device)
        self.difficulty = Difficulty(cfg.difficulty, self.max_episode_length, self.device)
        self.stand = ScriptedStand(robot, loco.stand, self.device)
        self._all_ids = torch.arange(N, device=self.device)
        d = dict(device=self.device)

        # constants [J] / index sets
        self.default_q = torch.tensor(robot.default_q, **d)
        lo, hi = torch.tensor(robot.pos_lower, **d), torch.tensor(robot.pos_upper, **d)
        mid, half = (lo + hi) / 2, (hi - lo) / 2 * cfg.rewards.soft_limit
        self.soft_pos_lower, self.soft_pos_upper = mid - half, mid + half
        self.soft_vel_limit = torch.tensor(robot.velocity_limit, **d) * cfg.rewards.soft_limit
        self.soft_torque_limit = torch.tensor(robot.effort_limit, **d) * cfg.rewards.soft_limit
        self.arm_joints = torch.tensor(robot.joint_ids(loco.arm_joints), **d)
        self.hip_joints = torch.tensor(robot.joint_ids(loco.hip_joints), **d)
        self.waist_joints = torch.tensor(robot.joint_ids(loco.waist_joints), **d)
        self.swing_joints = torch.tensor([robot.joint_ids(leg) for leg in loco.swing_joints], dtype=torch.long,
                                         device=self.device).view(len(loco.swing_joints), len(loco.swing_profile))
        self.swing_profile = torch.tensor(loco.swing_profile, **d)
        self.command_sweeps = self._command_sweeps()
        self.torso_body = self.world.body_index[loco.torso_link]
        self._down = torch.tensor([0.0, 0.0, -1.0], **d)  # gravity direction, world frame
        self.foot_bodies = torch.tensor([self.world.body_index[n] for n in robot.foot_links], **d)
        self.robot_weight = float(self.world.body_mass[0].sum()) * GRAVITY
        kp0, effort = torch.tensor(robot.kp, **d), torch.tensor(robot.effort_limit, **d)
        self.action_scale = torch.full((J,), robot.action_scale, **d)
        if cfg.action_scale_effort > 0:
            per_joint = (cfg.action_scale_effort * effort / kp0.clamp(min=1e-6)).clamp(max=cfg.action_scale_max)
            self.action_scale = torch.where(kp0 > 0, per_joint, self.action_scale)
        self.kp = self.world.joint_kp  # [N, J] view: current (randomised) gains
        self.torques = self.world.joint_torque  # [N, J] view: the PD torque of the last physics step (clamped)

        # buffers
        z = lambda *s: torch.zeros(*s, **d)  # noqa: E731
        self.actions, self.last_actions, self.last_last_actions = z(N, self.num_actions), z(N, self.num_actions), \
            z(N, self.num_actions)
        self.commands = z(N, 3)
        self.heading = z(N)
        self.steer_held = False  # hold_commands(steer=True): steer to the heading out of heading mode too
        self.avg_yaw_rate = z(N)
        self.slow_yaw_error = z(N)  # yaw_bias's low-passed (commanded - measured) yaw rate
        self.last_joint_vel = z(N, J)
        self.last_contact = torch.zeros(N, len(robot.foot_links), dtype=torch.bool, device=self.device)
        self.episode_length_buf = torch.zeros(N, dtype=torch.long, device=self.device)
        self.command_timer = z(N)
        self.push_timer = z(N)
        self.force_timer = z(N)
        self.episode_sums = {k: z(N) for k in (*TERMS, "termination")}
        self.path = PathMeter(N, window=max(1, round(1.0 / self.dt)), device=self.device)  # the curriculum's measure
        self.commanded_dist = z(N)
        self.nonfinite_resets = 0

        # randomised physical parameters (also critic inputs) [N, ...]
        self.nominal_mass = self.world.body_mass.sum(1).clone()
        self.mass_offset, self.com_offset = z(N), z(N, 3)
        self.motor_strength, self.friction = torch.ones(N, J, **d), torch.ones(N, **d)
        self.kp_scale, self.kd_scale = torch.ones(N, J, **d), torch.ones(N, J, **d)

        self.layout = obs_layout.actor_layout(J, cfg.uses_clock)
        self.num_obs = obs_layout.size(self.layout)
        o = cfg.obs
        self.command_scale = torch.tensor(o.command_scale, **d)
        self.noise_scale = torch.zeros(self.num_obs, **d)  # uniform noise half-width per actor input
        self.noise_scale[self.layout["gravity"]] = o.noise_gravity
        self.noise_scale[self.layout["joint_pos"]] = o.noise_joint_pos
        self.noise_scale[self.layout["joint_vel"]] = o.noise_joint_vel * o.joint_vel_scale
        self.noise_scale[self.layout["ang_vel"]] = o.noise_ang_vel * o.ang_vel_scale
        self.priv_layout = obs_layout.privileged_layout(J, len(robot.foot_links), self.ground.foot_map_cells,
                                                        self.num_obs)
        self.reset_idx(torch.arange(N, device=self.device))
        self._refresh()
        self._heading_control()
        self.obs = self._observations()

    # ------------------------------------------------------------------ rsl-rl VecEnv
    def get_observations(self) -> TensorDict:
        return self.obs

    def step(self, actions: torch.Tensor):
        cfg = self.cfg
        finite = torch.isfinite(actions).all(-1)
        actions = torch.where(finite.unsqueeze(-1), actions, 0.0)  # a non-finite action never reaches the sim
        J = self.robot.num_joints
        a = actions.clamp(-self.action_bounds, self.action_bounds)
        self.last_last_actions.copy_(self.last_actions)
        self.last_actions.copy_(self.actions)
        self.actions.copy_(a)

        self.world.joint_target.copy_(self.default_q + self.action_scale * a[:, :J])
        if cfg.uses_clock:
            gait = a[:, J:] if cfg.variant == "adaptive" else torch.zeros_like(a[:, J:])
            self.clock.advance(gait, self.dt)
            if cfg.gait.swing_feedforward:
                ff = cfg.gait.swing_feedforward * self.clock.swing_depth.unsqueeze(-1) * self.swing_profile
                self.world.joint_target[:, self.swing_joints] += ff
            if self.command_sweeps:
                sweep = torch.cos(self.clock.leg_angles)  # [N, legs]: +1 where a foot goes down, -1 where it lifts
                for joints, gain, c in self.command_sweeps:
                    self.world.joint_target[:, joints] += gain * self.commands[:, c:c + 1] * sweep
        self._perturb()
        self.world.step()

        self.episode_length_buf += 1
        self.command_timer -= self.dt
        self._refresh()
        rew, terms = self._rewards()
        fell, nonfinite = self._terminations()
        time_out = self.episode_length_buf >= self.max_episode_length
        dones = fell | time_out | nonfinite
        if cfg.rewards.termination_penalty:
            terms["termination"] = cfg.rewards.termination_penalty * self.reward_dt * fell.float()
            rew = rew + terms["termination"]
        rew = torch.where(nonfinite, 0.0, rew)  # nothing from a broken world reaches the learner
        for k, v in terms.items():
            self.episode_sums[k] += v
        self._advance_history()

        extras = {"time_outs": time_out & ~fell & ~nonfinite, "log": {}}
        self.difficulty.record(self.episode_length_buf, dones & ~nonfinite)
        ids = dones.nonzero().flatten()
        if len(ids):
            extras["log"] = self._episode_log(ids)
            self.nonfinite_resets += int(nonfinite.sum())
            self.reset_idx(ids, fell[ids])
            self._refresh()  # the reset worlds' observations show their new state
        extras["log"]["/nonfinite_resets"] = float(self.nonfinite_resets)
        if self.world.windows is not None:  # terrain boxes left out of a full window (none on our courses)
            extras["log"]["/terrain_window_overflows"] = float(self.world.windows.overflows)
        self._resample_commands(self.command_timer <= 0)
        self._heading_control()  # the yaw-rate command observed now is the one the next step's reward tracks
        self.obs = self._observations()
        return self.obs, rew, dones.long(), extras

    def _command_sweeps(self) -> list[tuple[torch.Tensor, torch.Tensor, int]]:
        """The clock's stride, lateral and turn feedforward that are on: (joint per leg [legs], signed gain per leg
        [legs], command index)."""
        g, loco, d = self.cfg.gait, self.loco_robot, {"device": self.device}
        if not self.cfg.uses_clock:
            return []
        stride = tuple((leg[0], loco.swing_profile[0]) for leg in loco.swing_joints)  # hip sign: thigh forward
        out = []
        for c, (field, legs) in enumerate((("stride", stride), ("lateral", loco.lateral_joints),
                                           ("turn", loco.turn_joints))):
            gain = getattr(g, f"{field}_feedforward")
            if gain:
                if not legs:
                    raise ValueError(f"gait.{field}_feedforward needs the robot's joints for it ({loco.name})")
                out.append((torch.tensor(self.robot.joint_ids(tuple(j for j, _ in legs)), dtype=torch.long, **d),
                            gain * torch.tensor([sign for _, sign in legs], dtype=torch.float32, **d), c))
        return out

    def stand_actions(self) -> torch.Tensor:
        """[N, A] actions of the scripted stand (cra_warp.stand) at the current state; gait actions 0."""
        a = torch.zeros(self.num_envs, self.num_actions, device=self.device)
        a[:, :self.robot.num_joints] = self.stand.actions(self.world, self.action_scale)
        return a

    # ------------------------------------------------------------------ state
    def _refresh(self):
        """Derived tensors of the current state, shared by observations, rewards and terminations. Pure: it may run
        twice in a step (again after resets, so the reset worlds' observations show their new state)."""
        w = self.world
        q = w.root_quat
        self.root_pos = w.root_pos
        self.base_lin_vel = quat_rotate_inv(q, w.root_lin_vel)
        self.base_ang_vel = quat_rotate_inv(q, w.root_ang_vel)
        self.projected_gravity = quat_rotate_inv(q, self._down)
        self.torso_gravity = quat_rotate_inv(w.body_quat[:, self.torso_body], self._down)
        self.joint_pos, self.joint_vel, self.joint_target = w.joint_pos, w.joint_vel, w.joint_target
        self.joint_acc = (w.joint_vel - self.last_joint_vel) / self.dt

        feet = self.kin.feet_at(w.body_pos[:, self.foot_bodies], w.body_quat[:, self.foot_bodies])  # no FK pass
        self.sole_corners, self.sole_centres, self.feet_quat = feet.sole_corners, feet.sole_centres, feet.quat
        self.feet_lin_vel = w.body_lin_vel[:, self.foot_bodies]
        self.foot_forces = w.foot_forces
        self.contact = self.foot_forces[..., 2] > self.cfg.rewards.contact_threshold
        self.first_contact = self.contact & ~self.last_contact
        self.sole_corner_height = self.sole_corners[..., 2] - self.ground.heights(self.sole_corners[..., :2])
        ground_under_soles = self.ground.heights(self.sole_centres[..., :2])                       # [N, F]
        self.sole_height = self.sole_centres[..., 2] - ground_under_soles
        rel = self.sole_centres - w.root_pos.unsqueeze(1)
        self.feet_pos_yaw = quat_rotate_inv(yaw_quat(yaw(q)).unsqueeze(1), rel)
        self.ground_under_base = self.ground.heights(w.root_pos[:, :2])
        # the ground a fall is measured from (LocoConfig.fall_ground): on a stair the pelvis passes over the next
        # riser while the stance sole is a rise below it
        self.fall_floor = (torch.minimum(self.ground_under_base, ground_under_soles.amin(-1))
                           if self.cfg.fall_ground == "lowest" else self.ground_under_base)

    def _advance_history(self):
        """Per-step memory, advanced once per step after rewards and terminations read it (buffers in place: see
        GaitClock.advance)."""
        self.last_joint_vel.copy_(self.world.joint_vel)
        self.last_contact.copy_(self.contact)
        alpha = self.dt / (self.cfg.obs.yaw_rate_filter_tau + self.dt)
        self.avg_yaw_rate += alpha * (self.base_ang_vel[:, 2] - self.avg_yaw_rate)
        beta = self.dt / (self.cfg.rewards.yaw_bias_tau + self.dt)
        self.slow_yaw_error += beta * (self.commands[:, 2] - self.base_ang_vel[:, 2] - self.slow_yaw_error)

    def _terminations(self):
        nonfinite = ~(torch.isfinite(self.world.joint_q).all(-1) & torch.isfinite(self.world.joint_qd).all(-1))
        low = self.root_pos[:, 2] - self.fall_floor < self.cfg.fall_height
        if self.cfg.fall_ground == "lowest":
            # and sitting: a pelvis on a stair with the feet some steps below is far above the lowest ground
            low |= self.root_pos[:, 2] - self.ground_under_base < SIT_FRACTION * self.cfg.fall_height
        tilted = self.projected_gravity[:, 2] > self.cfg.fall_gravity_z
        return (low | tilted) & ~nonfinite, nonfinite

    @property
    def reward_dt(self) -> float:
        """What a term's weighted value is multiplied by per step: dt when Table I's weights are rates per second."""
        return self.dt if self.cfg.rewards.scale_by_dt else 1.0

    def _rewards(self):
        total = torch.zeros(self.num_envs, device=self.device)
        terms = {}
        for name, weight in self.cfg.rewards.weights.items():
            if weight == 0.0 or (getattr(TERMS[name], "needs_clock", False) and not self.cfg.uses_clock):
                continue
            r = weight * self.reward_dt * torch.nan_to_num(TERMS[name](self), nan=0.0, posinf=0.0, neginf=0.0)
            terms[name] = r
            total += r
        if self.cfg.rewards.only_positive_rewards:
            total = total.clamp(min=0.0)
        return total, terms

    # ------------------------------------------------------------------ observations
    def _observations(self) -> TensorDict:
        o = self.cfg.obs
        parts = {
            "command": self.commands * self.command_scale,
            "gravity": self.projected_gravity,
            "joint_pos": self.joint_pos - self.default_q,
            "joint_vel": self.joint_vel * o.joint_vel_scale,
            "prev_action": self.actions,
            "ang_vel": self.base_ang_vel * o.ang_vel_scale,
            "avg_ang_speed": (self.avg_yaw_rate * o.ang_vel_scale).unsqueeze(-1),
        }
        if self.cfg.uses_clock:
            parts["gait_phase"] = self.clock.phase_obs
        actor = self._assemble(parts, self.layout)
        noisy = actor
        if o.noise:
            unit = 2 * torch.rand(actor.shape, device=self.device, generator=self.gen) - 1
            noisy = actor + unit * self.noise_scale

        w = self.world
        com, _ = w.com()
        force = w.base_force[:, :3]
        priv = self._assemble({
            "base_lin_vel": self.base_lin_vel * o.lin_vel_scale,
            "com_pos": quat_rotate_inv(w.root_quat, com - w.root_pos),
            "foot_height_maps": self.ground.foot_height_maps(self.sole_centres, self.feet_quat).flatten(1),
            "foot_contact": self.contact.float(),
            "foot_forces": (self.foot_forces / self.robot_weight).flatten(1),
            "mass_offset": self.mass_offset.unsqueeze(-1), "com_offset": self.com_offset,
            "motor_strength": self.motor_strength, "kp_scale": self.kp_scale, "kd_scale": self.kd_scale,
            "friction": self.friction.unsqueeze(-1),
            "external_force": force / max(self.cfg.randomization.force_max, 1.0),
            "actor": actor,
        }, self.priv_layout)
        hmap = self.ground.height_map(w.root_pos, w.root_quat).unsqueeze(1)
        clip = o.clip
        return TensorDict({"policy": noisy.clamp(-clip, clip), "privileged": priv.clamp(-clip, clip),
                           "height_map": hmap.clamp(-clip, clip)}, batch_size=[self.num_envs], device=self.device)

    @staticmethod
    def _assemble(parts: dict[str, torch.Tensor], layout: dict[str, slice]) -> torch.Tensor:
        """The observation in the layout's order (envs/observations.py is the one list of what sits where); a part
        whose width differs from its slice is a bug, caught here rather than as shifted inputs."""
        for name, where in layout.items():
            if parts[name].shape[-1] != where.stop - where.start:
                raise RuntimeError(f"observation part {name!r} is {parts[name].shape[-1]} wide, its slice "
                                   f"{where.stop - where.start}")
        return torch.cat([parts[k] for k in layout], -1)

    # ------------------------------------------------------------------ resets, commands, randomisation
    def reset_idx(self, ids: torch.Tensor, fell: torch.Tensor | None = None):
        """Start envs ``ids`` [n] again; ``fell`` [n] bool: their episodes ended in a fall (the curriculum's)."""
        n = len(ids)
        if n == 0:
            return
        if self.episode_length_buf[ids].gt(0).any():
            xy = self.root_pos[ids, :2]
            # judged against the whole episode at the mean commanded speed: an early fall is a demotion
            lived = self.episode_length_buf[ids].clamp(min=1).float() * self.dt
            expected = self.commanded_dist[ids] / lived * self.cfg.episode_length_s
            self.ground.update_curriculum(ids, self.path.walked(ids, xy), self.path.farthest(ids, xy), expected,
                                          fell)
        origins = self.ground.spawn_origins(ids)  # [n, 3] ground point
        q = self.world.default_joint_q[ids].clone()
        q[:, :2] = origins[:, :2]
        q[:, 2] = origins[:, 2] + self.robot.base_height + 0.01
        yaw0 = self.ground.spawn_yaw(ids)
        if yaw0 is None:
            yaw0 = (2 * torch.rand(n, device=self.device, generator=self.gen) - 1) * math.pi
        q[:, 3:7] = yaw_quat(yaw0)
        self.randomize_physics(ids)  # before the state: a backend derives the reset state's CoM from them
        self.world.reset(ids, joint_q=q)
        self.path.reset(ids, origins[:, :2])
        self.commanded_dist[ids] = 0.0
        self.actions[ids] = 0.0
        self.last_actions[ids] = 0.0
        self.last_last_actions[ids] = 0.0
        self.last_joint_vel[ids] = self.world.joint_vel[ids]
        self.avg_yaw_rate[ids] = 0.0
        self.slow_yaw_error[ids] = 0.0
        self.last_contact[ids] = False
        self.episode_length_buf[ids] = 0
        rd = self.cfg.randomization
        self.push_timer[ids] = rd.push_interval * torch.rand(n, device=self.device, generator=self.gen)
        self.force_timer[ids] = rd.force_interval * torch.rand(n, device=self.device, generator=self.gen)
        g = self.cfg.gait
        self.clock.reset(ids, self._uniform(0.0, g.cycle_time, n) if g.random_start_phase else None)
        for s in self.episode_sums.values():
            s[ids] = 0.0
        self._resample_commands(ids)

    def restore_terrain_levels(self, levels) -> None:
        """Put every robot on the tile of its saved terrain level [N] (a resumed run) and start all episodes
        again there. The episodes cut short were walked on the tiles the env was built on (level 0): judged, a
        pit robot would climb out of its easy tile and be promoted above its saved level, a jump of 0.3-0.5 mean
        level after every resume."""
        self.ground.curriculum.restore(levels)
        self.episode_length_buf.zero_()  # not judged by the curriculum (reset_idx judges episodes that ran)
        self.reset_idx(torch.arange(self.num_envs, device=self.device))
        self._refresh()
        self._heading_control()
        self.obs = self._observations()

    def _uniform(self, lo: float, hi: float, *shape) -> torch.Tensor:
        return lo + (hi - lo) * torch.rand(*shape, device=self.device, generator=self.gen)

    def _resample_commands(self, ids: torch.Tensor):
        """New commands for the envs ``ids``: indices [n], or a mask [N] (drawn for all, kept where set: no host
        sync in the step)."""
        masked = ids.dtype == torch.bool
        n = self.num_envs if masked else len(ids)
        if n == 0:
            return
        c = self.cfg.commands
        cmd = torch.stack([self._uniform(*c.lin_vel_x, n), self._uniform(*c.lin_vel_y, n),
                           self._uniform(*c.ang_vel_yaw, n)], -1) * self.difficulty.command_scale
        cmd[:, :2] *= (cmd[:, :2].norm(dim=-1, keepdim=True) >= c.min_speed)
        standing = torch.rand(n, device=self.device, generator=self.gen) < c.standing_fraction
        cmd = torch.where(standing.unsqueeze(-1), 0.0, cmd)
        heading = self._uniform(-math.pi, math.pi, n)
        climbing = self.ground.climbing_envs() if c.pit_fall_line else None
        if climbing is not None:  # up a fall line, forward only (CommandConfig.pit_fall_line)
            axis = torch.randint(0, 4, (self.num_envs,), device=self.device, generator=self.gen)
            up = self.ground.fall_line_heading(self.world.root_pos[:, :2], axis)
            climbing, up = (climbing, up) if masked else (climbing[ids], up[ids])
            vx = self._uniform(*c.pit_lin_vel_x, n) * self.difficulty.command_scale
            cmd[:, 0] = torch.where(climbing & ~standing, vx, cmd[:, 0])
            cmd[:, 1] = torch.where(climbing, 0.0, cmd[:, 1])
            heading = torch.where(climbing, up, heading)
        if masked:
            self.commands.copy_(torch.where(ids.unsqueeze(-1), cmd, self.commands))
            self.heading.copy_(torch.where(ids, heading, self.heading))
            self.command_timer.masked_fill_(ids, c.resample_time)
        else:
            self.commands[ids] = cmd
            self.heading[ids] = heading
            self.command_timer[ids] = c.resample_time

    def hold_commands(self, lin_vel_xy: torch.Tensor, heading: torch.Tensor, refresh: bool = True,
                      yaw_rate: float = 0.0, steer: bool = False):
        """Command base velocities [N, 2] and world headings [N] instead of random ones: the yaw rate steers to the
        heading (heading mode, or ``steer``) or is ``yaw_rate`` (ignored when steered). They hold until the next
        call (a reset robot draws random ones until then, and while ``steer`` holds it is steered to its random
        heading). ``steer`` steers a policy trained on yaw-rate commands (heading mode off) at the heading as well, as
        a driver would: the evaluation course aims every robot at its target. ``refresh``: recompute the observation
        so the next action already sees them; a caller that steers every step can skip it, as step() re-applies the
        heading before its observation."""
        self.commands[:, :2] = lin_vel_xy
        self.heading.copy_(heading)
        self.command_timer.fill_(math.inf)
        self.steer_held = steer
        if self.cfg.commands.heading_mode or steer:
            self._heading_control()
        else:
            self.commands[:, 2] = yaw_rate
        if refresh:
            self.obs = self._observations()

    def _heading_control(self):
        c = self.cfg.commands
        if not (c.heading_mode or self.steer_held):
            return
        err = wrap_angle(self.heading - yaw(self.world.root_quat))
        moving = self.commands[:, :2].norm(dim=-1) > 0
        self.commands[:, 2] = torch.where(moving, (c.heading_gain * err).clamp(*c.ang_vel_yaw), 0.0)

    def _perturb(self):
        """Pushes and external forces on per-env timers; integrates the commanded and the walked distance."""
        rd = self.cfg.randomization
        self.commanded_dist += self.commands[:, :2].norm(dim=-1) * self.dt
        self.path.update(self.root_pos[:, :2])
        if not rd.enabled:
            return
        # masked updates (drawn for every env, applied where due): no host sync in the step
        N = self.num_envs
        self.push_timer -= self.dt
        push = self.push_timer <= 0
        angle = self._uniform(-math.pi, math.pi, N)
        s = self.difficulty.randomization_scale
        speed = self._uniform(0.0, s * rd.push_max_vel, N) * push
        dv = torch.stack([speed * torch.cos(angle), speed * torch.sin(angle), torch.zeros_like(speed)], -1)
        self.world.apply_impulse(self._all_ids, dv)
        self.push_timer.masked_fill_(push, rd.push_interval)
        self.force_timer -= self.dt
        shove = (self.force_timer <= 0).unsqueeze(-1)
        force = self._uniform(-s * rd.force_max, s * rd.force_max, N, 3)
        self.world.base_force[:, :3] = torch.where(shove, force, self.world.base_force[:, :3])
        self.force_timer.masked_fill_(shove.squeeze(-1), rd.force_interval)
        over = self.force_timer < rd.force_interval - rd.force_duration
        self.world.base_force[:, :3] *= ~over.unsqueeze(-1)

    def randomize_physics(self, ids: torch.Tensor):
        """Sample mass, base CoM, actuators (strength, gains, rotor inertia) and friction for ``ids`` and hand them to
        the solver."""
        rd, n, B, J = self.cfg.randomization, len(ids), self.world.num_bodies, self.robot.num_joints
        if not rd.enabled:
            return
        s = self.difficulty.randomization_scale

        def around(lo: float, hi: float, *shape, nominal: float = 1.0):  # shrunk towards nominal by the difficulty
            if isinstance(s, torch.Tensor):  # (the curriculum is on; off, the configured range exactly)
                lo, hi = nominal + s * (lo - nominal), nominal + s * (hi - nominal)
            return self._uniform(lo, hi, *shape)

        self.world.set_mass_scale(ids, around(*rd.mass_scale, n, B))
        self.mass_offset[ids] = self.world.body_mass[ids].sum(1) / self.nominal_mass[ids] - 1.0
        self.com_offset[ids] = self._uniform(-s * rd.base_com_offset, s * rd.base_com_offset, n, 3)
        self.world.set_base_com_offset(ids, self.com_offset[ids])
        self.motor_strength[ids] = around(*rd.motor_strength, n, J)
        self.kp_scale[ids] = around(*rd.kp_scale, n, J)
        self.kd_scale[ids] = around(*rd.kd_scale, n, J)
        self.world.set_actuators(ids, self.motor_strength[ids], self.kp_scale[ids], self.kd_scale[ids])
        if tuple(rd.armature_scale) != (1.0, 1.0):  # (no draw when off: the other draws stay as they were)
            self.world.set_armature(ids, around(*rd.armature_scale, n, J))
        self.friction[ids] = around(*rd.friction, n, nominal=self.cfg.world.friction)
        self.world.set_friction(ids, self.friction[ids])
        self.world.commit_physics()

    def _episode_log(self, ids: torch.Tensor) -> dict:
        secs = (self.episode_length_buf[ids].float() * self.dt).clamp(min=self.dt)
        log = {f"/reward/{k}": (v[ids] / secs).mean() for k, v in self.episode_sums.items()}
        log["/episode_length_s"] = secs.mean()
        log["/terrain_level"] = self.ground.mean_level()
        for name, level in self.ground.mean_level_by_type().items():
            log[f"/terrain_level/{name}"] = level
        log["/difficulty"] = self.difficulty.level.clone()
        return log

