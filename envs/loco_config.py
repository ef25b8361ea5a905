"""Configuration of the locomotion task (paper III-A, III-C, III-D, IV-A).

Where the paper is silent we take what the legged-locomotion field does; every such choice is written here:
- Control: policy at 50 Hz (env step 0.02 s = 4 x 0.005 s physics steps, the vendor's Isaac Gym setting).
  q* = q_ref + s_j * a_j with a per-joint scale s_j = 0.5 effort_j / kp_j (capped at 1 rad; see
  action_scale_effort); actions clipped to +-clip_joint_actions and the three gait actions to +-1 (with alpha 0.5 the gait rate stays within 0.5x..1.5x).
- "Average angular speed" (one actor input) is the low-pass filtered yaw rate, as in the vendor's (PNDbotics')
  policies whose per-frame observation has the same order as the paper's (filter time constant below).
- Observation scales are the vendor's (angular velocity 0.25, joint velocity 0.05, command (2, 2, 0.25)); uniform
  noise as in legged_gym, on the actor's observation only (the critic sees it without noise).
- Total reward r = sum_i w_i r_i per env step, no dt scaling (the paper's formula), clipped at 0 from below
  (``only_positive_rewards``, as legged_gym and the vendor's config do): with Table I's penalties a
  young policy's step reward is negative, and without the clip ending the episode early (falling) pays.
- Episodes last 20 s; a robot has fallen when its pelvis is less than fall_height above the lowest ground under it
  or under a sole (``fall_ground``), or less than SIT_FRACTION of it above the ground under it (seated), or its base
  is tilted by more than ~60 deg (gravity z in the base frame above -0.5).
- The robot is a name (``robot``) in the registry robots.ROBOTS: its RobotConfig (joints, drives, limits) and its
  LocoRobotConfig (the joint groups the rewards and the clock read, the scripted stand's gains, and the numbers at
  its size: base height and clearance targets, feet distance, contact force threshold, fall height). A field of
  those numbers left unset (None) takes the robot's when the config is made, so a stored run holds the numbers it
  trained with. Both sit with the robot (robots/<robot>/), as mjlab keeps tasks/<task>/config/<robot>/.
- Actuators: the robot's explicit PD (its RobotConfig, cra_warp.sim) at every 5 ms physics step.
- Physical randomisation (mass, CoM, motor strength, PD gains +-20%, friction) is resampled per env at every
  reset; pushes and external forces come on per-env timers during episodes. An optional difficulty curriculum
  (DifficultyConfig, envs/difficulty.py) starts with small commands and/or the nominal robot and widens both as
  the robots survive longer.
- Heading mode: the yaw-rate command is set from the heading error at the end of each step, before the
  observation, so the command a policy observes is the one its next reward tracks.
- Gait phase input (2 of the paper's 84): sin and cos of the global phase 2 pi phi / T_cycle. The leg signals
  s, c add the offsets d1, d2, which the policy sees in its previous action; (s, c) themselves would not tell
  phi from 0.5 - phi whenever d1 = d2 (always in fixed_cycle).
- Clock modes (LocoConfig.variant; envs/methods.py maps methods to them): "adaptive" (ours), "fixed_cycle" (the
  gait actions are ignored, so the clock runs at T_cycle with zero offsets; the action keeps its 3 gait entries so
  the network is the same as ours), "clock_free" (no clock inputs and no gait actions: actor observation and action
  5 and 3 smaller; the contact-pattern reward is off).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Literal

from cra_warp.gait import GaitClockConfig
from cra_warp.terrain import TerrainConfig
from cra_warp.terrain.course import EvalCourseConfig
from cra_warp.terrain.curriculum import RULES as CURRICULUM_RULES
from cra_warp.sim import WorldConfig
from robots import robot_by_name

# the gait clock a method runs (envs/methods.py); stored as LocoConfig.variant, the name every config.json uses
ClockMode = Literal["adaptive", "fixed_cycle", "clock_free"]
CLOCK_MODES: tuple[str, ...] = ("adaptive", "fixed_cycle", "clock_free")


# Under fall_ground "lowest" a pelvis less than this fraction of the fall height above the ground under it has fallen
# too (sat down; the lowest ground may be steps below it): upright past a 35 cm riser it is 0.43 m up (the robots the
# old rule ended there), seated on the step much less (the test: 0.15 m).
SIT_FRACTION = 0.5


@dataclass
class CommandConfig:
    lin_vel_x: tuple[float, float] = (-0.5, 1.0)     # [m/s]
    lin_vel_y: tuple[float, float] = (-0.3, 0.3)     # [m/s]
    ang_vel_yaw: tuple[float, float] = (-0.5, 0.5)   # [rad/s], used when heading_mode is off
    heading_mode: bool = True                        # yaw rate from a sampled heading (P-controller)
    heading_gain: float = 0.5
    resample_time: float = 8.0                       # [s]
    standing_fraction: float = 0.1                   # share of envs commanded to stand still
    min_speed: float = 0.1                           # xy commands below this are set to zero
    # Beyond the paper (issue 35): robots on the tiles they must climb out of (pits, ROBOT_WAY "climbs") are told to
    # walk up a fall line, as the evaluation course meets its ascents head-on: heading along the tile axis that points
    # from the tile centre towards the robot (a random axis near the centre), forward only at pit_lin_vel_x. Given
    # any heading, robots left 7 deg pits across the fall line and side-stepped along the course's slopes (focus7).
    pit_fall_line: bool = False
    pit_lin_vel_x: tuple[float, float] = (0.15, 0.6)  # [m/s] their forward commands (the reach rule needs > 0.2)


@dataclass
class ObsConfig:
    lin_vel_scale: float = 2.0
    ang_vel_scale: float = 0.25
    joint_vel_scale: float = 0.05
    command_scale: tuple[float, float, float] = (2.0, 2.0, 0.25)
    yaw_rate_filter_tau: float = 0.2                 # [s] low-pass of the "average angular speed" input
    noise: bool = True
    noise_gravity: float = 0.05
    noise_joint_pos: float = 0.01                    # [rad]
    noise_joint_vel: float = 1.5                     # [rad/s]
    noise_ang_vel: float = 0.2                       # [rad/s]
    clip: float = 100.0


@dataclass
class RewardConfig:
    """Weights are Table I's (and 0 for the shaping terms beyond it); the term functions live in envs/rewards.py."""

    weights: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_WEIGHTS))
    tracking_sigma: float = 0.25
    torso_sigma: float = 0.1
    # None: the robot's (its LocoRobotConfig), filled in when the LocoConfig is made (ROBOT_REWARD_NUMBERS)
    base_height_target: float | None = None          # [m] pelvis above the soles
    feet_clearance_target: float | None = None       # [m] swing-foot sole height above the ground
    yaw_bias_tau: float = 1.0                        # [s] low-pass of the yaw-rate error yaw_bias penalises
    stall_min_command: float = 0.2                   # [m/s] stall counts only under a planar command this fast
    feet_min_lateral_distance: float | None = None   # d_min [m]
    contact_force_threshold: float | None = None     # F_th [N]
    soft_limit: float = 0.9                          # joint position/velocity/torque limits at 90% of the range
    contact_threshold: float = 5.0                   # [N] a foot with more vertical force is in contact
    power_floor: float = 0.1                         # keeps the joint-power ratio finite for a standing robot
    only_positive_rewards: bool = True               # clip the summed reward at 0 (see the module docstring)
    # Each term's step reward is w_i x r_i x dt when set: Table I's weights are rates per second in the legged_gym
    # convention (reward scales multiplied by the policy dt), which keeps returns near 1-10, the scale that PPO's
    # clipped value loss (clip 0.2 per update) assumes. Off: w_i x r_i per step, 50x larger at 50 Hz. Off by default:
    # on flat ground it learned within the seed spread of per-step weights (tools/results/ab_scale_by_dt).
    scale_by_dt: bool = False
    # Added to the (clipped) step reward of a robot that falls (x dt with scale_by_dt, like the terms); not a Table I
    # term (the paper gives none), 0 = off.
    termination_penalty: float = 0.0
    swing_amplitude: float = 0.25                    # [rad] A of swing_reference (robot's swing_profile x A)
    swing_scale: float = 0.5                         # [rad] of joint error at which swing_reference falls to 1/e


# Table I of the paper, in its order.
DEFAULT_WEIGHTS: dict[str, float] = {
    "lin_vel_tracking": 3.0,
    "ang_vel_tracking": 3.0,
    "lin_vel_z": -0.5,
    "ang_vel_xy": -0.025,
    "orientation": -1.25,
    "torso_orientation": 2.0,
    "joint_acc": -2.5e-7,
    "joint_power": -2.5e-5,
    "body_height": -0.1,          # Table I: +0.1 on a squared error; we penalise the error (its intent)
    "feet_clearance": -0.25,
    "action_rate": -0.01,
    "smoothness": -0.01,
    "feet_stumble": -0.5,
    "torques": -2.5e-6,
    "joint_velocity": -1e-4,
    "joint_tracking_error": -0.25,
    "arm_joint_deviation": -0.1,
    "hip_joint_deviation": -0.5,
    "waist_joint_deviation": -1.5,
    "joint_pos_limits": -2.0,
    "joint_vel_limits": -0.1,
    "torque_limits": -0.1,
    "no_fly": 0.25,
    "feet_lateral_distance": 1.0,
    "feet_slip": -0.05,
    "feet_ground_parallel": -2.0,
    "feet_contact_force": -1e-2,
    "feet_parallel": -2.5,
    "contact_momentum": -2.5e-2,
    "contact_pattern": 1.0,
}
TABLE_I_TERMS: tuple[str, ...] = tuple(DEFAULT_WEIGHTS)
# Beyond Table I: off unless a run sets a weight (e.g. --override rewards.weights.swing_reference=2).
DEFAULT_WEIGHTS["swing_reference"] = 0.0
DEFAULT_WEIGHTS["yaw_bias"] = 0.0
DEFAULT_WEIGHTS["stall"] = 0.0


@dataclass
class DomainRandConfig:
    enabled: bool = True
    mass_scale: tuple[float, float] = (0.95, 1.05)        # every link, +-5%
    base_com_offset: float = 0.05                         # [m] per axis, +-5 cm
    motor_strength: tuple[float, float] = (0.8, 1.2)      # per joint: torque delivered / PD torque (paper)
    kp_scale: tuple[float, float] = (0.8, 1.2)            # per joint: PD stiffness / nominal (drive calibration)
    kd_scale: tuple[float, float] = (0.8, 1.2)            # per joint: PD damping / nominal
    friction: tuple[float, float] = (0.4, 1.25)
    # per joint: rotor inertia / the robot's armature. (1, 1) keeps it nominal. The vendor's MJCF has none but
    # 0.001 kg m^2 on ankle pitch against our 0.01 on every drive; cra-sim2sim on it tracked 1.8x worse than
    # with our armature (issue 12). Not in the critic's privileged state (its layout, and so every checkpoint's,
    # would change); the critic sees its effect through the joint motions.
    armature_scale: tuple[float, float] = (1.0, 1.0)
    push_interval: float = 8.0                            # [s]
    push_max_vel: float = 0.8                             # [m/s] horizontal speed change of a push, 0..max
    force_interval: float = 4.0                           # [s] between external forces on the base
    force_duration: float = 0.5                           # [s] each force acts this long (a shove, not a wind)
    force_max: float = 50.0                               # [N] per axis, +-

    def __post_init__(self):
        for name in ("mass_scale", "motor_strength", "kp_scale", "kd_scale", "friction", "armature_scale"):
            lo, hi = getattr(self, name)
            if not 0.0 <= lo <= hi:
                raise ValueError(f"randomization.{name} must be a range 0 <= low <= high, got {(lo, hi)}")


@dataclass
class DifficultyConfig:
    """What the difficulty curriculum (envs/difficulty.py) scales with its level, and how the level moves."""

    commands: bool = False            # velocity commands x level (small ones become "stand still")
    randomization: bool = False       # physical randomisation ranges shrunk towards nominal, pushes/shoves x level
    start: float = 0.0                # level at the start of training
    step: float = 0.05                # change per move
    interval: int = 24                # [env steps] between moves (24: once per PPO iteration)
    promote: float = 0.5              # up when the episodes ended in the window lasted >= this x the episode length
    demote: float = 0.25              # down when they lasted < this x the episode length

    def __post_init__(self):
        if not 0.0 <= self.start <= 1.0 or self.step <= 0 or self.interval < 1 or self.demote > self.promote:
            raise ValueError(f"DifficultyConfig needs 0 <= start <= 1, step > 0, interval >= 1 and demote <= promote, "
                             f"got {self}")


@dataclass
class LocoConfig:
    # a name in robots.ROBOTS; this default is also the robot of every stored run written before the field existed
    robot: str = "adam_lite"
    num_envs: int = 64                                    # the world's size and device: LocoEnv hands them to
    device: str = "cpu"                                   # make_world (WorldConfig holds physics settings only)
    variant: ClockMode = "adaptive"                       # the clock mode
    episode_length_s: float = 20.0
    world: WorldConfig = field(default_factory=WorldConfig)
    gait: GaitClockConfig = field(default_factory=GaitClockConfig)
    commands: CommandConfig = field(default_factory=CommandConfig)
    obs: ObsConfig = field(default_factory=ObsConfig)
    rewards: RewardConfig = field(default_factory=RewardConfig)
    randomization: DomainRandConfig = field(default_factory=DomainRandConfig)
    difficulty: DifficultyConfig = field(default_factory=DifficultyConfig)
    terrain: str = "flat"                                 # "flat", "rough" (the curriculum course) or "eval"
    course: EvalCourseConfig = field(default_factory=EvalCourseConfig)  # terrain "eval": the evaluation course
    terrain_curriculum: str = "path"                      # terrain "rough": its promotion rule (curriculum.RULES)
    rough: TerrainConfig = field(default_factory=TerrainConfig)  # terrain "rough": its tiles (seed: the run's)
    clip_joint_actions: float = 10.0
    # 0: q* = q_ref + robot.action_scale a on every joint (the vendor's 0.5). > 0: a per-joint scale of
    # action_scale_effort x effort_limit / kp, so a unit action asks every joint for the same share of its torque
    # limit (mjlab scales its actions so); joints without stiffness keep robot.action_scale. With the vendor's soft
    # ankles the uniform 0.5 gives ankle pitch 12.5 N m per unit action against hip pitch's 152: the policy did not
    # learn to use its ankles. 0.5 (ankle pitch 20 N m, hip pitch 115 N m per unit): in a 2-seed A/B of 100 flat
    # iterations (N=256) the reward ended at 229 vs 139 and the episode length at 80 vs 75 steps
    # (tools/results/ab_action_scale.json).
    action_scale_effort: float = 0.5
    action_scale_max: float = 1.0                         # [rad] cap of the per-joint scale (the soft arms)
    # PD gains other than the robot's, {joint or joint without side: [kp, kd]} (RobotConfig.with_gains), for
    # studies of the actuator; the run's stored robot, its checks and the deploy JSON carry the gains trained with.
    joint_gains: dict[str, tuple[float, float]] = field(default_factory=dict)
    fall_height: float | None = None                      # [m] pelvis above fall_ground; None: the robot's
    # what fall_height is measured from: "lowest", the lowest ground under the pelvis or under a sole; "base", the
    # ground under the pelvis alone, the rule before issue 35's diagnosis: on stairs a pelvis past the next riser
    # read one rise lower, so upright robots (pelvis 0.65-0.81 m above their lower sole) were ended as fallen on
    # every 30-35 cm flight at its first riser and crouched ones from 15 cm (docs/experiments.md). Kept for the A/B
    # and for stored runs; the evaluators judge every policy by "lowest".
    fall_ground: Literal["lowest", "base"] = "lowest"
    fall_gravity_z: float = -0.5                          # base-frame gravity z above this = tilted over
    seed: int = 0

    def __post_init__(self):
        self._fill_robot_numbers()
        if self.num_envs < 1:
            raise ValueError(f"LocoConfig.num_envs must be >= 1, got {self.num_envs}")
        if self.variant not in CLOCK_MODES:
            raise ValueError(f"LocoConfig.variant (the clock mode) must be one of {CLOCK_MODES}, got {self.variant!r}")
        if self.fall_ground not in ("lowest", "base"):
            raise ValueError(f"LocoConfig.fall_ground must be 'lowest' or 'base', got {self.fall_ground!r}")
        if self.episode_length_s <= 0:
            raise ValueError(f"LocoConfig.episode_length_s must be > 0, got {self.episode_length_s}")
        unknown = set(self.rewards.weights) - set(DEFAULT_WEIGHTS)
        if unknown:
            raise ValueError(f"LocoConfig.rewards.weights has unknown terms {sorted(unknown)}")
        if self.terrain_curriculum not in CURRICULUM_RULES:
            raise ValueError(f"LocoConfig.terrain_curriculum must be one of {CURRICULUM_RULES}, got "
                             f"{self.terrain_curriculum!r}")
        trials = len(self.course.kinds) * self.course.num_levels
        if self.terrain == "eval" and self.num_envs % trials:
            raise ValueError(f"LocoConfig.num_envs must be a multiple of {trials} (course kinds x levels) on the "
                             f"evaluation course, got {self.num_envs}")

    def _fill_robot_numbers(self):
        """The robot's numbers into the fields left None (a new rewards object: a RewardConfig passed in is not
        changed). Set values stay, so a config rebuilt from a stored run keeps the numbers it trained with, and a
        robot named here afterwards (dataclasses.replace) keeps the first robot's: make a new config for another."""
        try:
            robot = robot_by_name(self.robot)
        except ValueError as e:
            raise ValueError(f"LocoConfig.robot: {e}") from None
        unset = {k: getattr(robot, k) for k in ROBOT_REWARD_NUMBERS if getattr(self.rewards, k) is None}
        if unset:
            self.rewards = dataclasses.replace(self.rewards, **unset)
        if self.fall_height is None:
            self.fall_height = robot.fall_height

    @property
    def uses_clock(self) -> bool:
        return self.variant != "clock_free"


# RewardConfig's fields whose default is the robot's number of the same name (LocoRobotConfig); so is fall_height.
ROBOT_REWARD_NUMBERS = ("base_height_target", "feet_clearance_target", "feet_min_lateral_distance",
                        "contact_force_threshold")
