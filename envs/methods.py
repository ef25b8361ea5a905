"""The method registry (paper IV-A) and the one place a method, a task and a recipe become the env and learner configs.

A method is a record of three choices and, for a baseline, the learner settings its paper adds:
- clock_mode: the gait clock the task runs (LocoConfig.variant: "adaptive", "fixed_cycle", "clock_free");
- contrast_pairing: what InfoNCE pairs (ContrastConfig.variant: "same_step", "sequential" or "none");
- actor_kind: the actor's representation (ActorConfig.kind: "gru", or a baseline's estimator);
- learner: LearnerConfig settings (dotted paths) applied before the recipe's and the caller's overrides.
Each baseline comes twice: on our adaptive clock (dreamwaq, dwl: the actors alone differ from ours) and as close to
its paper as this task allows (dreamwaq_clock_free: no clock, as DreamWaQ has none, and its AdaBoot;
dwl_fixed_cycle: a clock of fixed period that the gait actions do not move, as DWL's). docs/paper.md says more.
The stored field names stay "variant" (every checkpoint's config.json uses them); new code says clock_mode and
contrast_pairing. cra-train's --method (alias --variant, the name stored runs use) picks a row.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal, get_args

Method = Literal["ours", "sequential", "no_contrast", "fixed_cycle", "clock_free", "dreamwaq", "dwl",
                 "dreamwaq_clock_free", "dwl_fixed_cycle"]
Task = Literal["flat", "rough"]
TASKS: tuple[str, ...] = get_args(Task)


@dataclass(frozen=True)
class MethodSpec:
    clock_mode: str          # LocoConfig.variant
    contrast_pairing: str    # ContrastConfig.variant
    actor_kind: str          # ActorConfig.kind
    learner: tuple[tuple[str, object], ...] = ()   # (LearnerConfig dotted path, value): what the method turns on

    @property
    def uses_clock(self) -> bool:
        return self.clock_mode != "clock_free"


METHODS: dict[str, MethodSpec] = {
    "ours": MethodSpec("adaptive", "same_step", "gru"),
    "sequential": MethodSpec("adaptive", "sequential", "gru"),      # contrast with the next step
    "no_contrast": MethodSpec("adaptive", "none", "gru"),
    "fixed_cycle": MethodSpec("fixed_cycle", "same_step", "gru"),   # the gait actions ignored
    "clock_free": MethodSpec("clock_free", "same_step", "gru"),     # no clock inputs, no gait actions
    # the baselines keep our clock, rewards and critic; their actors are cra_warp/learning/baselines.py's
    "dreamwaq": MethodSpec("adaptive", "none", "dreamwaq"),
    "dwl": MethodSpec("adaptive", "none", "dwl"),
    # the baselines' own pairings: DreamWaQ has no clock and trains with AdaBoot; DWL's clock has a fixed period
    "dreamwaq_clock_free": MethodSpec("clock_free", "none", "dreamwaq", (("dreamwaq.adaboot", True),)),
    "dwl_fixed_cycle": MethodSpec("fixed_cycle", "none", "dwl"),
}
assert tuple(METHODS) == get_args(Method)


def build_configs(method: str, task: str, *, recipe: str | None = None, overrides: dict[str, object] | None = None,
                  num_envs: int = 128, device: str = "cpu", sim: str = "newton", seed: int = 0, threads: int = 0,
                  curriculum: bool = True, contrast_weight: float = 0.1, contrast_tau: float = 0.1,
                  epochs: int = 2, mini_batches: int = 4, mixed_precision: bool = False, save_interval: int = 20):
    """(LocoConfig, LearnerConfig, recipe record) of a run: the method's row (its learner settings included) and the
    arguments, then the recipe's overrides (minus what the method cannot use), then ``overrides`` (dotted paths;
    learner ones under "learner.").
    The learner's privileged_slices need the env's layout: set them with ``bind_learner`` once the env is built.
    ValueError (one line, naming the override) for an override that does not fit."""
    from cra_warp.config_io import with_overrides
    from cra_warp.learning.config import LearnerConfig
    from cra_warp.sim import WorldConfig
    from envs.loco_config import DifficultyConfig, LocoConfig
    from envs.recipes import DEFAULT_RECIPE, resolve

    spec, recipe = METHODS[method], recipe or DEFAULT_RECIPE
    from_recipe, dropped = resolve(recipe, task, uses_clock=spec.uses_clock)
    if not curriculum:  # no curriculum means the whole task from the start, whatever the recipe's curriculum
        from_recipe = {k: v for k, v in from_recipe.items() if not k.startswith("difficulty.")}
    merged = {**from_recipe, **(overrides or {})}
    env_over = {k: v for k, v in merged.items() if not k.startswith("learner.")}
    learner_over = {k[len("learner."):]: v for k, v in merged.items() if k.startswith("learner.")}
    # the robot is chosen when the config is made: its numbers fill the fields the overrides leave unset
    robot = {"robot": env_over.pop("robot")} if "robot" in env_over else {}
    try:
        env_cfg = LocoConfig(num_envs=num_envs, device=device, variant=spec.clock_mode, terrain=task, seed=seed,
                             world=WorldConfig(backend=sim, threads=threads),
                             difficulty=DifficultyConfig(commands=curriculum, randomization=curriculum), **robot)
    except ValueError as e:
        raise ValueError(f"--override: {e}") from e
    if env_over:
        try:
            env_cfg = with_overrides(env_cfg, env_over)
        except (ValueError, TypeError) as e:
            raise ValueError(f"--override: {e}") from e
    learner = LearnerConfig(save_interval=save_interval, run_name=f"{task}_{method}")
    learner.contrast = dataclasses.replace(learner.contrast, variant=spec.contrast_pairing, weight=contrast_weight,
                                           tau=contrast_tau)
    learner.ppo = dataclasses.replace(learner.ppo, num_learning_epochs=epochs, num_mini_batches=mini_batches,
                                      use_mixed_precision=mixed_precision)
    learner.actor = dataclasses.replace(learner.actor, kind=spec.actor_kind)
    if spec.learner:
        learner = with_overrides(learner, dict(spec.learner))
    if learner_over:
        try:
            learner = with_overrides(learner, learner_over)
        except (ValueError, TypeError) as e:
            raise ValueError(f"--override: learner.{e}") from e
    return env_cfg, learner, {"name": recipe, "overrides": from_recipe, "not_used": dropped}


def bind_learner(learner, env) -> None:
    """The learner's slices of the privileged observation (the critic's velocity and actor-observation parts),
    from the built env's layout."""
    learner.privileged_slices = {k: (env.priv_layout[name].start, env.priv_layout[name].stop)
                                 for k, name in (("velocity", "base_lin_vel"), ("observation", "actor"))}
