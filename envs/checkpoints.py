"""A run's checkpoint as the task sees it: the runner built for the task (with its mirror maps), the env and
runner a checkpoint was trained with rebuilt from its stored configuration, and the check that today's robot and
observation layouts are still the ones it was trained against. What play, eval, export, figures and probe load a
policy with; cra-train checks --resume and --init with it."""

from __future__ import annotations

import dataclasses

from cra_warp.learning.runner import CraRunner

# LocoConfig fields added after runs were stored, with the value those runs trained with: a stored run rebuilt or
# compared on resume is the task it was (its env config as stored_env gives it)
PREDATED = {"fall_ground": "base"}


def stored_env(stored: dict) -> dict:
    """A run's stored env config (``stored["env"]``), the fields it predates filled in from PREDATED."""
    return {**PREDATED, **stored["env"]}


def predated_overrides(path, given: tuple[str, ...]) -> tuple[str, ...]:
    """--override items that keep a run resumed from checkpoint ``path`` on the task it trained with: the PREDATED
    fields its stored env lacks and the CLI's --override items ``given`` do not set."""
    import json

    from cra_warp.learning.checkpoint import read_checkpoint

    env = ((read_checkpoint(path).get("infos") or {}).get("config") or {}).get("env")
    if env is None:
        return ()
    named = {item.partition("=")[0] for item in given}
    return tuple(f"{k}={json.dumps(v)}" for k, v in PREDATED.items() if k not in env and k not in named)


def make_runner(env, train_cfg: dict, **kw) -> CraRunner:
    """CraRunner for the task ``env``, with the task's mirror maps when the learner uses the symmetry loss and its
    action clip when it uses the action bound loss (``kw``: CraRunner's log_dir, device, quiet, run_info)."""
    alg, task_args = train_cfg.get("algorithm", {}), {}
    if alg.get("symmetry_weight"):
        from envs.observations import action_mirror, actor_mirror

        task_args["mirror"] = {"obs": actor_mirror(env.layout, env.robot, env.cfg.uses_clock),
                               "actions": action_mirror(env.robot, env.cfg.uses_clock)}
    if alg.get("action_bound_weight"):
        task_args["action_bounds"] = env.action_bounds.tolist()
    return CraRunner(env, train_cfg, task_args=task_args, **kw)


def runner_for_checkpoint(path, num_envs: int = 1, device: str = "cpu", sim: str | None = None,
                          whole_course: bool = False, **env_overrides):
    """Rebuild the env and runner a checkpoint was trained with and load it. Returns (runner, env).

    The checkpoint's stored configuration (env, world, learner) is rebuilt as it was, never from today's defaults;
    the caller changes only what an evaluation needs: ``num_envs``, ``device``, the simulator (``sim``), every
    terrain box in every world (``whole_course``, for recording) and LocoConfig fields in ``env_overrides``
    (terrain, seed, course, randomization, episode_length_s). A checkpoint whose observation layout no longer
    matches today's code is refused. Raises CheckpointError (one line) for a missing, foreign or mismatched file.
    """
    from cra_warp.config_io import from_data
    from cra_warp.learning.checkpoint import CheckpointError, load_checkpoint, read_checkpoint
    from cra_warp.learning.config import LearnerConfig, runner_cfg, stored_target_actor_obs
    from cra_warp.sim import check_backend_device
    from envs.loco_config import DifficultyConfig, LocoConfig
    from envs.locomotion import LocoEnv

    info = read_checkpoint(path).get("infos") or {}
    stored = info.get("config")
    if stored is None:  # runs store their configuration since before the first shipped policy
        raise CheckpointError(f"{path}: the checkpoint holds no run configuration (written before runs stored it)")
    try:
        env_cfg = from_data(LocoConfig, stored_env(stored))
        learner = from_data(LearnerConfig, stored["learner"])
        learner.contrast = dataclasses.replace(learner.contrast,
                                               target_actor_obs=stored_target_actor_obs(stored["learner"]))
        world = dataclasses.replace(env_cfg.world, threads=0)  # MuJoCo batch threads: this machine's, not the run's
        if sim is not None:
            world = dataclasses.replace(world, backend=sim)
        if whole_course:
            world = dataclasses.replace(world, terrain_window=None)
        check_backend_device(world.backend, device)  # a run stored on MuJoCo, asked for CUDA: one line, not a build
        # evaluation runs the whole task: a training curriculum's level (a rebuilt env would restart it) is off
        env_cfg = dataclasses.replace(env_cfg, num_envs=num_envs, device=device,
                                      difficulty=DifficultyConfig(commands=False, randomization=False),
                                      world=world, **env_overrides)
    except (KeyError, TypeError, ValueError) as e:
        raise CheckpointError(f"{path}: its stored configuration cannot be rebuilt ({e})") from e
    env = LocoEnv(env_cfg)
    check_against_today(path, stored, env)
    runner = make_runner(env, runner_cfg(learner), log_dir=None, device=device, quiet=True, run_info=info)
    load_checkpoint(path, runner, load_cfg={"actor": True})  # inference: a shipped, actor-only file is enough
    return runner, env


# What a policy was trained against that today's code also defines: the robot's actuation and pose, and the
# observation layouts. A difference means the policy would run on another robot or read shifted inputs.
ROBOT_FIELDS = ("name", "joint_names", "default_q", "kp", "kd", "effort_limit", "velocity_limit", "pos_lower",
                "pos_upper", "action_scale", "armature")


def check_against_today(path, stored: dict, env) -> None:
    """CheckpointError (one line, naming the field) unless the checkpoint's stored robot and observation layouts
    are those of ``env`` as today's code builds it."""
    from cra_warp.config_io import to_data
    from cra_warp.learning.checkpoint import CheckpointError

    try:
        robot, layouts = stored["robot"], stored["layout"]
        layouts = {g: layouts[g] for g in ("actor", "privileged")}
    except (KeyError, TypeError) as e:
        raise CheckpointError(f"{path}: its stored configuration lacks {e}") from e
    today = to_data(env.robot)
    for k in ROBOT_FIELDS:
        if robot.get(k) != today[k]:
            raise CheckpointError(f"{path}: the robot's {k} differs from today's config ({robot.get(k)} in the "
                                  f"checkpoint, {today[k]} now)")
    for group, now in (("actor", env.layout), ("privileged", env.priv_layout)):
        then, now = layouts[group], to_data(now)
        if then != now:
            diff = next(k for k in list(then) + list(now) if then.get(k) != now.get(k))
            raise CheckpointError(f"{path}: the {group} observation layout differs from today's code at "
                                  f"{diff!r} ({then.get(diff)} in the checkpoint, {now.get(diff)} now)")
