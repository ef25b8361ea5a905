"""Named training recipes: a recipe is a set of dotted-path overrides (the --override namespace: env paths, and
learner paths under "learner.") that cra-train applies on top of the dataclass defaults and before the user's own
--override. Adding a recipe is one entry in RECIPES.

- paper: Table I's weights and the paper's clock (III-E) as published, no feedforward, no shaping beyond Table I.
  These are also today's dataclass defaults; writing them out keeps the recipe the paper's if a default moves.
  What the defaults (and so this recipe) still do differently from the paper is in docs/paper.md; the one change
  to a Table I number is body_height's sign (a penalty, as its intent; envs/rewards.py).
- walk: what the shipped walkers (robots/adam_lite/policies/flat_walk_v2, rough_walk_v0) trained with: the clock's
  swing, stride, lateral and turn feedforward, lin_vel_tracking 9 (Table I: 3), contact_momentum at a tenth,
  alpha 5 with beta_scale 0.1 (the rate range stays 0.5-1.5x, the leg offsets are held within +-0.1 cycle),
  commands at their full range from the start (the randomisation curriculum kept) and a slower difficulty step.
  Heading mode differs by task as it did between the two policies: off on flat ground (flat_walk_v2: a robot that
  always turns is not punished under heading mode), on for rough ground (rough_walk_v0: robots walk at the
  terrain instead of circling). tests/envs/test_recipes.py holds it to both policies' config.json.
- climb: walk, and on rough ground what the climbing campaign (climb_fall_line, issue 35) settled on: the reach
  promotion rule, a foothold curriculum (stairs from 2 cm, slopes from 1 deg, half the columns pits), slower forward
  commands with a sharper tracking kernel, pit robots told to walk up the fall line, and the low-passed yaw penalty.
  Flat ground is walk's. Each key, and the figure behind it, is a row of docs/paper.md ("climb").

A method without a clock (clock_free: no clock inputs, no gait actions) cannot use a recipe's clock settings
(gait.*: the feedforward, alpha, beta_scale): ``resolve`` leaves them out and says so, and the env skips the
clock's reward terms (contact_pattern, swing_reference) for it. A fair pair for it is ours with the same keys left
out (under walk: ours with the four gait.*_feedforward at 0, alpha 0.5 and beta_scale 1); cra-grid trains it beside
clock_free as ours_as_clock_free.
"""

from __future__ import annotations

from dataclasses import dataclass, field

# Table I of the paper as printed (weights w_i, its order and signs).
TABLE_I: dict[str, float] = {
    "lin_vel_tracking": 3.0, "ang_vel_tracking": 3.0, "lin_vel_z": -0.5, "ang_vel_xy": -0.025,
    "orientation": -1.25, "torso_orientation": 2.0, "joint_acc": -2.5e-7, "joint_power": -2.5e-5,
    "body_height": 0.1, "feet_clearance": -0.25, "action_rate": -0.01, "smoothness": -0.01, "feet_stumble": -0.5,
    "torques": -2.5e-6, "joint_velocity": -1e-4, "joint_tracking_error": -0.25, "arm_joint_deviation": -0.1,
    "hip_joint_deviation": -0.5, "waist_joint_deviation": -1.5, "joint_pos_limits": -2.0, "joint_vel_limits": -0.1,
    "torque_limits": -0.1, "no_fly": 0.25, "feet_lateral_distance": 1.0, "feet_slip": -0.05,
    "feet_ground_parallel": -2.0, "feet_contact_force": -1e-2, "feet_parallel": -2.5, "contact_momentum": -2.5e-2,
    "contact_pattern": 1.0,
}
# Where we do not take Table I's number as printed (docs/paper.md says why).
TABLE_I_SIGN_FLIPS = ("body_height",)   # +0.1 on a squared error would reward the error: a penalty instead
BEYOND_TABLE_I = ("swing_reference", "yaw_bias", "stall")  # our shaping terms, off in the paper recipe


@dataclass(frozen=True)
class Recipe:
    doc: str                                            # one line: what it is and where it comes from
    overrides: dict[str, object]                        # dotted path -> value, every task
    per_task: dict[str, dict[str, object]] = field(default_factory=dict)  # task -> more overrides


def _paper() -> dict[str, object]:
    weights = {f"rewards.weights.{k}": (-v if k in TABLE_I_SIGN_FLIPS else v) for k, v in TABLE_I.items()}
    weights |= {f"rewards.weights.{k}": 0.0 for k in BEYOND_TABLE_I}
    # III-E: psi 0.5 (its default), gamma "e.g. 0 or -0.1"; alpha ("a small gain"), beta_scale ("optionally") and
    # T_cycle are not given: 0.5, 1 (unscaled) and 0.8 s (the vendor's Adam Lite policies)
    clock = {"gait.cycle_time": 0.8, "gait.alpha": 0.5, "gait.psi": 0.5, "gait.gamma": -0.1, "gait.beta_scale": 1.0,
             "gait.swing_feedforward": 0.0, "gait.stride_feedforward": 0.0, "gait.lateral_feedforward": 0.0,
             "gait.turn_feedforward": 0.0, "gait.random_start_phase": False}
    return weights | clock


_WALK = Recipe(
    "what the shipped walkers trained with: clock feedforward, lin_vel_tracking 9, contact_momentum / 10, "
    "alpha 5, beta_scale 0.1, full-range commands",
    {"gait.swing_feedforward": 0.25, "gait.stride_feedforward": 0.5, "gait.lateral_feedforward": 0.25,
     "gait.turn_feedforward": 0.2, "gait.alpha": 5.0, "gait.beta_scale": 0.1,
     "rewards.weights.lin_vel_tracking": 9.0, "rewards.weights.contact_momentum": -0.0025,
     "rewards.weights.swing_reference": 0.0, "difficulty.step": 0.02, "difficulty.commands": False},
    per_task={"flat": {"commands.heading_mode": False}, "rough": {"commands.heading_mode": True}})
RECIPES: dict[str, Recipe] = {
    "paper": Recipe("Table I and the paper's clock as published, no feedforward (the dataclass defaults)", _paper()),
    "walk": _WALK,
    "climb": Recipe(
        "walk, plus on rough ground the climbing campaign's: reach rule, foothold tiles, slow commands on a sharp "
        "kernel, fall-line commands on pits, yaw_bias -30 (beyond the paper)",
        _WALK.overrides,
        per_task={"flat": _WALK.per_task["flat"],
                  "rough": {**_WALK.per_task["rough"],
                            "terrain_curriculum": "reach",
                            "rough.num_cols": 8, "rough.proportions": [1.0, 1.0, 2.0, 1.0, 2.0, 1.0],
                            "rough.step_height": [0.02, 0.35], "rough.slope_deg": [1.0, 34.0],
                            "commands.lin_vel_x": [-0.3, 0.6], "rewards.tracking_sigma": 0.1,
                            "commands.pit_fall_line": True, "rewards.weights.yaw_bias": -30.0}}),
}
DEFAULT_RECIPE = "walk"

# Keys a method without a clock cannot use, and why (the grid prints it beside the method).
CLOCK_KEYS = "gait."
NO_CLOCK_REASON = "no clock inputs or gait actions, so no clock settings or feedforward"


def resolve(name: str, task: str, uses_clock: bool = True) -> tuple[dict[str, object], dict[str, str]]:
    """(overrides to apply, {left-out key: why}) of recipe ``name`` for ``task`` and a method with or without the
    gait clock. KeyError naming the recipes for an unknown name."""
    if name not in RECIPES:
        raise KeyError(f"unknown recipe {name!r}: one of {', '.join(RECIPES)}")
    r = RECIPES[name]
    out = {**r.overrides, **r.per_task.get(task, {})}
    dropped = {k: NO_CLOCK_REASON for k in out if not uses_clock and k.startswith(CLOCK_KEYS)}
    return {k: v for k, v in out.items() if k not in dropped}, dropped


def describe(name: str, uses_clock: bool = True) -> str:
    """One line: the recipe and, for a method without a clock, what of it the method does not use."""
    if uses_clock:
        return name
    left = sorted({k for k in RECIPES[name].overrides if k.startswith(CLOCK_KEYS)})
    return f"{name} without {', '.join(left)} ({NO_CLOCK_REASON})" if left else name
