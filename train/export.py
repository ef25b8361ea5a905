"""cra-export: write a checkpoint's actor as TorchScript + ONNX + the deploy JSON.

    cra-export runs/<run>/model_40.pt                  # -> runs/<run>/exported/policy.{pt,onnx,json}
    cra-export runs/<run>/model_40.pt --out deploy/

The JSON carries what a deploy program needs besides the network: observation layout and scales, joint order,
action scale, reference pose, PD gains, gait-clock constants and the control period.
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path

from tyro.conf import Positional

from train.train import UsageError


def deploy_metadata(env) -> dict:
    """What cra_warp.learning.export needs to know about the task (cra_warp does not import envs)."""
    robot, cfg, o = env.robot, env.cfg, env.cfg.obs
    return {
        "obs_layout": env.layout,
        "joint_names": list(robot.joint_names),
        "action_scale": robot.action_scale,
        "default_q": list(robot.default_q),
        "kp": list(robot.kp),
        "kd": list(robot.kd),
        "gait": dataclasses.asdict(cfg.gait) if cfg.uses_clock else None,
        "control_dt": env.dt,
        "obs_scales": {"command": list(o.command_scale), "ang_vel": o.ang_vel_scale, "joint_vel": o.joint_vel_scale,
                       "joint_pos": "q - default_q", "gravity": "unit vector, base frame",
                       "avg_ang_speed": f"yaw rate low-passed with tau {o.yaw_rate_filter_tau} s, x ang_vel scale"},
        "variant": cfg.variant,
        "effort_limit": list(robot.effort_limit),
        "armature": robot.armature,
    }


def export_run(runner, env, out_dir: Path) -> dict:
    from cra_warp.learning.export import export_policy

    return export_policy(runner, out_dir, deploy_metadata(env))


@dataclass
class ExportArgs:
    checkpoint: Positional[Path]       # a cra-train checkpoint (model_<it>.pt)
    out: Path | None = None            # default: <checkpoint dir>/exported


def main(argv: list[str] | None = None) -> int:
    import tyro

    from cra_warp.learning.checkpoint import CheckpointError

    from train.runner import runner_for_checkpoint

    a = tyro.cli(ExportArgs, args=argv, description=__doc__.split("\n\n")[0])
    try:
        runner, env = runner_for_checkpoint(a.checkpoint)
        paths = export_run(runner, env, a.out or a.checkpoint.parent / "exported")
    except (UsageError, CheckpointError) as e:
        print(f"cra-export: {e}", file=sys.stderr)
        return 2
    for kind, path in paths.items():
        print(f"{kind:>12}: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
