"""cra-play: run a policy (or a zero / random agent) in the locomotion task and report how it walks.

    cra-play runs/<run>/model_40.pt                 # the trained policy, deterministic actions
    cra-play --agent stand --num-envs 16            # no policy: the scripted stand at the reference pose
    cra-play runs/<run>/model_40.pt --usd rollout.usda   # also write an animated USD (any USD viewer plays it)
    cra-play runs/<run>/model_40.pt --video walk.gif     # and/or a GIF of robot 0 (MuJoCo's offscreen renderer)
    cra-play runs/<run>/model_40.pt --command 0.5 0      # every robot told to walk forward, not to turn

Reports the velocity tracking error, falls per robot-minute and the distance walked.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import tyro
from tyro.conf import Positional

from cra_warp.cli import Sim, UsageError, check_device, check_sim, parse_args
from cra_warp.video import RolloutVideo, check_gif_path, frame_every
from envs.methods import METHODS, Method, Task


@dataclass
class PlayArgs:
    checkpoint: Positional[Path | None] = None  # a cra-train checkpoint (model_<it>.pt); for --agent policy
    agent: Literal["policy", "stand", "zero", "random"] = "policy"
    task: Task | None = None           # default: the checkpoint's task (flat for stand/zero/random)
    # the method, for its clock mode (--method or --variant): stand/zero/random agents only; a policy brings its own
    variant: Annotated[Method, tyro.conf.arg(aliases=("--method",))] = "ours"
    num_envs: int = 16
    steps: int = 500                   # env steps (0.02 s each)
    device: str = "cpu"
    sim: Sim | None = None             # default: the checkpoint's (newton for stand/zero/random)
    usd: Path | None = None            # write the rollout as an animated USD stage here
    video: Path | None = None          # write robot 0's rollout as a GIF here (16.7 frames/s, a camera following it)
    seed: int = 0
    command: tuple[float, float] | None = None  # hold (v_x, v_y) [m/s], heading 0 (yaw rate 0 without heading mode)
    # nominal robots: no randomised physics, pushes or shoves (as in cra-eval's trials); default: the training's
    nominal: bool = False


def make_agent(a: PlayArgs, env):
    import torch

    if a.agent == "stand":
        return lambda obs: env.stand_actions()
    if a.agent == "zero":
        return lambda obs: torch.zeros(env.num_envs, env.num_actions, device=env.device)
    if a.agent == "random":
        return lambda obs: 0.3 * torch.randn(env.num_envs, env.num_actions, device=env.device)
    raise AssertionError("policies are loaded with their env in run()")


def run(a: PlayArgs) -> dict:
    import torch

    from cra_warp.host_memory import keep_freed_memory
    from cra_warp.sim import WorldConfig
    from envs.evaluation import FALL_GROUND
    from envs.loco_config import DomainRandConfig, LocoConfig
    from envs.locomotion import LocoEnv

    keep_freed_memory()
    # falls are counted by the evaluators' rule, whatever the policy trained with
    overrides = {"fall_ground": FALL_GROUND, **({"terrain": a.task} if a.task else {})}
    if a.nominal:
        overrides["randomization"] = DomainRandConfig(enabled=False)
    # the viewer draws static shapes once: every world holds the whole course, not a window
    whole_course = a.usd is not None
    if a.agent == "policy":  # the env the checkpoint was trained in (method, task from its stored config)
        from envs.checkpoints import runner_for_checkpoint

        sim = "newton" if whole_course else a.sim  # USD recording draws Newton's state
        runner, env = runner_for_checkpoint(a.checkpoint, num_envs=a.num_envs, device=a.device, sim=sim,
                                            whole_course=whole_course, seed=a.seed, **overrides)
        policy = runner.get_inference_policy(a.device)

        def agent(obs):
            return policy(obs)  # deterministic (mean) actions; the GRU state is kept inside the model

        agent.reset = policy.reset
    else:
        overrides.setdefault("terrain", "flat")
        # no --sim: WorldConfig's default backend (the one place it is named)
        world = WorldConfig(**({"backend": a.sim} if a.sim else {}),
                            **({"terrain_window": None} if whole_course else {}))
        env = LocoEnv(LocoConfig(num_envs=a.num_envs, device=a.device, variant=METHODS[a.variant].clock_mode,
                                 seed=a.seed, world=world, **overrides))
        agent = make_agent(a, env)
    viewer = None
    if a.usd is not None:
        viewer = env.world.usd_recorder(str(a.usd), fps=round(1 / env.dt), num_frames=a.steps)
    gif, falls_0, every = None, 0, frame_every(env.dt)
    if a.video is not None:
        gif = RolloutVideo(env.world, env.ground.boxes, a.video, fps=1 / (every * env.dt))
    held = None
    if a.command is not None:
        held = torch.tensor(a.command, device=env.device, dtype=torch.float32).expand(env.num_envs, 2)
        env.hold_commands(held, torch.zeros(env.num_envs, device=env.device))
    obs = env.get_observations()
    falls, sq_err, dist = 0, torch.zeros(env.num_envs, device=env.device), torch.zeros(env.num_envs, device=env.device)
    with torch.inference_mode():
        for k in range(a.steps):
            prev_xy = env.root_pos[:, :2].clone()
            if held is not None:  # again each step: a robot reset after a fall would draw a random command
                env.hold_commands(held, torch.zeros(env.num_envs, device=env.device), refresh=False)
            cmd = env.commands.clone()
            obs, _, dones, extras = env.step(agent(obs))
            if hasattr(agent, "reset"):
                agent.reset(dones)  # a reset robot starts with a fresh recurrent state
            sq_err += ((cmd[:, :2] - env.base_lin_vel[:, :2]) ** 2).sum(-1)
            moved = (env.root_pos[:, :2] - prev_xy).norm(dim=-1)
            dist += torch.where(dones.bool(), 0.0, moved)  # a reset teleports the robot: not walked
            fell = dones.bool() & ~extras["time_outs"]
            falls += int(fell.sum())
            falls_0 += int(fell[0])
            if viewer is not None:
                viewer.frame(k * env.dt)
            if gif is not None and k % every == 0:
                vx, vy, wz = env.commands[0].tolist()
                gif.frame([(f"cmd {vx:+.2f} {vy:+.2f} m/s {wz:+.2f} rad/s   t {(k + 1) * env.dt:5.2f} s",
                            (255, 255, 255)), (f"falls {falls_0}", (255, 60, 60) if falls_0 else (255, 255, 255))])
    if viewer is not None:
        viewer.close()
    if gif is not None:
        gif.close()
    minutes = a.steps * env.dt / 60 * env.num_envs
    return {"agent": a.agent, "num_envs": env.num_envs, "seconds": a.steps * env.dt,
            "vel_tracking_rmse": float((sq_err / a.steps).sqrt().mean()), "falls_per_robot_minute": falls / minutes,
            "mean_distance_m": float(dist.mean())}


def main(argv: list[str] | None = None) -> int:
    from cra_warp.learning.checkpoint import CheckpointError

    try:
        a = parse_args(PlayArgs, argv, __doc__)
        if a.agent == "policy" and (a.checkpoint is None or not a.checkpoint.is_file()):
            raise UsageError(f"a policy needs a checkpoint file, got {a.checkpoint}")
        if a.command is not None and not all(math.isfinite(v) for v in a.command):
            raise UsageError(f"--command must be finite, got {a.command}")
        if a.num_envs < 1 or a.steps < 1:
            raise UsageError(f"--num-envs and --steps must be >= 1, got {a.num_envs}, {a.steps}")
        check_sim(a.sim, a.device)
        if a.usd is not None and a.sim == "mujoco":
            raise UsageError("--usd records Newton's state: use --sim newton")
        if a.video is not None and (why := check_gif_path(a.video)):
            raise UsageError(why)
        check_device(a.device)
        report = run(a)
    except (UsageError, CheckpointError) as e:
        print(f"cra-play: {e}", file=sys.stderr)
        return 2
    for k, v in report.items():
        print(f"{k:>24}: {v:.3f}" if isinstance(v, float) else f"{k:>24}: {v}")
    for name in ("usd", "video"):
        if getattr(a, name) is not None:
            print(f"{name:>24}: {getattr(a, name)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
