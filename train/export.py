"""cra-export: write a checkpoint's actor as TorchScript + ONNX + the deploy JSON.

    cra-export runs/<run>/model_40.pt                  # -> runs/<run>/exported/policy.{pt,onnx,json}
    cra-export runs/<run>/model_40.pt --out deploy/
    cra-export runs/<run>/model_900.pt --out robots/adam_lite/policies/flat_walk --ship   # a policy we ship

--ship also writes checkpoint.pt, the checkpoint without its optimizer state (cra-play, cra-eval and cra-export read
it, `cra-train --init` forks from it, --resume does not), and config.json, the run's resolved configuration. It
keeps the critic and the contrastive heads, so that a fork (--init) goes on from the networks the policy trained
with instead of starting a critic and heads fresh.

The JSON carries what a deploy program needs besides the network: the observation (layout, each term's frame,
scale and update rule), joint order, action clips and scale, reference pose, the PD law with its gains, effort
limits and rate, held joints, gait-clock constants and the control period.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import sys
from dataclasses import dataclass
from pathlib import Path

from tyro.conf import Positional

from cra_warp.cli import UsageError, parse_args


def deploy_metadata(env) -> dict:
    """Everything a deploy program needs besides the network to rebuild the observation, the gait clock and the PD
    loop, without reading our code (cra_warp.learning.export does not import the task, so the task says it here)."""
    from envs.loco_config import SIT_FRACTION

    robot, loco, cfg, o, w = env.robot, env.loco_robot, env.cfg, env.cfg.obs, env.cfg.world
    gait = dataclasses.asdict(cfg.gait) if cfg.uses_clock else None
    observation = {
        "command": (f"the commanded base velocity: [vx, vy] [m/s] and yaw rate [rad/s] in the base (pelvis) frame "
                    f"(what the reward tracks), times {list(o.command_scale)}"),
        "gravity": "unit gravity direction in the base (pelvis) frame: R_base^T (0, 0, -1)",
        "joint_pos": "q - default_q [rad], joint order",
        "joint_vel": f"qd [rad/s] times {o.joint_vel_scale}",
        "prev_action": "the previous action as applied (after the clips below); zeros at episode start",
        "ang_vel": f"base angular velocity [rad/s] in the base (pelvis) frame, times {o.ang_vel_scale}",
        "avg_ang_speed": (f"y times {o.ang_vel_scale}, y = low-passed base-frame yaw rate: after each control step "
                          f"y += a (wz - y), a = control_dt / (tau + control_dt), tau {o.yaw_rate_filter_tau} s; "
                          "y = 0 at episode start"),
        "gait_phase": ("sin, cos of 2 pi phi / cycle_time; phi [s] starts at 0 and before each control step's physics "
                       "phi = (phi + max(1 + alpha d0, 0) control_dt) mod cycle_time, with (d0, d1, d2) = "
                       + ("beta_scale x the clipped gait actions of that step" if cfg.variant == "adaptive" else
                          "0 (this variant ignores its gait actions: the clock runs at cycle_time)")),
        "clip": o.clip,
        "order": "obs_t is built after the physics of step t-1; a_t = policy(obs_t); then the clock advances with a_t, "
                 "the PD targets are set and the physics runs",
    }
    return {
        "obs_layout": env.layout,
        "observation": {k: v for k, v in observation.items() if k in env.layout or k in ("clip", "order")},
        "joint_names": list(robot.joint_names),
        "action_scale": env.action_scale.tolist(),
        "action_clip": {"joints": cfg.clip_joint_actions, **({"gait": 1.0} if cfg.uses_clock else {})},
        "default_q": list(robot.default_q),
        "kp": list(robot.kp),
        "kd": list(robot.kd),
        "effort_limit": list(robot.effort_limit),
        "pd": {
            "law": "tau = clip(kp (q_target - q) - kd qd, -effort_limit, effort_limit), per joint",
            "rate_hz": 1.0 / w.sim_dt,
            "note": ("explicit: evaluated from the measured q, qd at every physics step (trained at this rate, "
                     "q_target held for the control period); a drive running it faster is closer still"),
            "held_joints": {n: 0.0 for n in robot.fixed_joints},
            "held_joints_note": "not driven by the policy: held at these angles [rad] (welded in training)",
            "armature": robot.armature,
            "armature_note": "rotor inertia [kg m^2] added to every driven joint in training (a sim-to-sim model "
                             "should carry it)",
        },
        "gait": gait,
        **({"swing": {"joints": [list(leg) for leg in loco.swing_joints], "profile": list(loco.swing_profile),
                      "feedforward": ("if gait.swing_feedforward > 0: after the clock advances, leg i's joints get "
                                      "swing_feedforward x depth_i x profile added to their q_target, depth_i = "
                                      "clip((gamma - sig_i) / (1 + gamma), 0, 1), sig = (sin 2 pi (phi / cycle_time "
                                      "+ d1), sin 2 pi (phi / cycle_time + d2 + psi)) for (left, right)"),
                      "stride": ("if gait.stride_feedforward > 0: leg i's first joint (hip pitch) also gets profile[0] "
                                 "x stride_feedforward x command vx x cos of sig_i's angle, the command as observed "
                                 "this control step"),
                      "lateral_joints": [list(j) for j in loco.lateral_joints],
                      "turn_joints": [list(j) for j in loco.turn_joints],
                      "sweeps": ("likewise, if gait.lateral_feedforward > 0, leg i's lateral joint gets sign_i x "
                                 "lateral_feedforward x command vy x cos of sig_i's angle, and if "
                                 "gait.turn_feedforward > 0 its turn joint sign_i x turn_feedforward x command yaw "
                                 "rate x that cos ((joint, sign_i) per leg in lateral_joints, turn_joints)")}}
           if cfg.uses_clock and loco.swing_joints else {}),
        "control_dt": env.dt,
        "obs_scales": {"command": list(o.command_scale), "ang_vel": o.ang_vel_scale, "joint_vel": o.joint_vel_scale,
                       "yaw_rate_filter_tau": o.yaw_rate_filter_tau},
        "frames": {"base": "the pelvis link (IMU frame)", "world": "z up", "quaternions": "xyzw in the sim"},
        "bodies": {"base": robot.base_link, "feet": list(robot.foot_links)},
        "base_height": robot.base_height,
        "termination": {"fall_height": cfg.fall_height, "fall_gravity_z": cfg.fall_gravity_z, "ground": cfg.fall_ground,
                        **({"sit_fraction": SIT_FRACTION} if cfg.fall_ground == "lowest" else {}),
                        "note": "training ended an episode when the pelvis was less than fall_height [m] above the "
                                "ground ('lowest': the lowest ground under the pelvis or a sole, or less than "
                                "sit_fraction x fall_height above the ground under the pelvis, seated; 'base': the "
                                "ground under the pelvis) or the base-frame gravity z rose above fall_gravity_z"},
        "variant": cfg.variant,
    }


@contextlib.contextmanager
def third_party_quiet():
    """Python warnings and the ONNX exporter's log records of the block kept off the terminal; yields a list that
    holds one short line per silenced message when the block ends (for a one-line summary). Ours are
    UsageError/CheckpointError, not warnings, so nothing a user must act on is hidden."""
    import logging
    import warnings

    silenced: list[str] = []

    class Count(logging.Handler):
        def emit(self, record):
            silenced.append(f"{record.name.split('.')[0]}: {record.getMessage()[:60]}")

    loggers = [logging.getLogger(n) for n in ("torch.onnx", "torch.export", "onnxscript")]
    saved = [(lg.propagate, lg.handlers[:]) for lg in loggers]
    handler = Count(logging.WARNING)
    for lg in loggers:
        lg.propagate, lg.handlers = False, [handler]
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield silenced
    finally:
        for lg, (propagate, handlers) in zip(loggers, saved):
            lg.propagate, lg.handlers = propagate, handlers
    silenced[:0] = [f"{w.category.__name__}: {str(w.message)[:60]}" for w in caught]


def export_run(runner, env, out_dir: Path) -> dict:
    from cra_warp.learning.export import export_policy

    return export_policy(runner, out_dir, deploy_metadata(env))


def ship_checkpoint(checkpoint: Path, out_dir: Path) -> dict:
    """out_dir/checkpoint.pt (``checkpoint`` without its optimizer state) and out_dir/config.json."""
    import os

    import torch

    from cra_warp.atomic_json import write_json
    from cra_warp.learning.checkpoint import read_checkpoint

    saved = read_checkpoint(checkpoint)
    tmp = out_dir / "checkpoint.pt.tmp"
    keep = ("actor_state_dict", "critic_state_dict", "contrast_state_dict", "iter", "infos")
    torch.save({k: saved[k] for k in keep if k in saved}, tmp)
    os.replace(tmp, out_dir / "checkpoint.pt")
    write_json(out_dir / "config.json", (saved.get("infos") or {}).get("config"), indent=2)
    return {"checkpoint": out_dir / "checkpoint.pt", "config": out_dir / "config.json"}


@dataclass
class ExportArgs:
    checkpoint: Positional[Path]       # a cra-train checkpoint (model_<it>.pt)
    out: Path | None = None            # default: <checkpoint dir>/exported
    ship: bool = False                 # also checkpoint.pt (no optimizer state) and config.json (see above)


def main(argv: list[str] | None = None) -> int:
    from cra_warp.learning.checkpoint import CheckpointError

    from envs.checkpoints import runner_for_checkpoint

    try:
        a = parse_args(ExportArgs, argv, __doc__)
        with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl's model dumps
            runner, env = runner_for_checkpoint(a.checkpoint)
        out = a.out or a.checkpoint.parent / "exported"
        with third_party_quiet() as silenced:
            paths = export_run(runner, env, out)
        if silenced:
            print(f"cra-export: {len(silenced)} third-party warnings silenced ({silenced[0]}, ...)", file=sys.stderr)
        if a.ship:
            paths |= ship_checkpoint(a.checkpoint, out)
    except (UsageError, CheckpointError) as e:
        print(f"cra-export: {e}", file=sys.stderr)
        return 2
    for kind, path in paths.items():
        print(f"{kind:>12}: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
