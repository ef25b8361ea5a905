"""Run an exported policy as a robot program would: numpy and onnxruntime only, everything from the export's JSON.

    policy = DeployPolicy("runs/<run>/exported")          # policy.json + policy.onnx (+ policy.onnx.data)
    policy.reset()                                         # at the start of every episode
    every control period (the JSON's control_dt):
        q_target = policy.step(command, gravity, q, qd, ang_vel)
        every physics / drive tick until the next control step:
            tau = policy.torque(q, qd, q_target)

Readings, all in the base (pelvis / IMU) frame as the JSON's "observation" section names them: ``command``
(vx, vy [m/s], yaw rate [rad/s]), ``gravity`` (unit gravity direction, R_base^T (0, 0, -1)), ``q`` and ``qd``
(joint angles [rad] and rates [rad/s] in the JSON's joint order), ``ang_vel`` (base angular velocity [rad/s]).

Nothing here imports torch, the simulator, rsl-rl or the task: this module is also the proof that the export is
complete. ``observe`` / ``act`` / ``apply`` are the three parts of ``step`` for callers that supply their own actions
(the parity tests).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np


class DeployError(ValueError):
    """The export directory or its JSON cannot drive a policy (one line, names the problem)."""


def load_export(path: str | Path) -> tuple[dict, Path]:
    """(the export's JSON, its directory) from a directory holding one ``*.json`` export or the JSON's path."""
    path = Path(path)
    if path.is_dir():
        found = sorted(p for p in path.glob("*.json") if _is_export(p))
        if len(found) != 1:
            raise DeployError(f"{path}: expected one exported policy JSON (format cra_warp-policy/1), "
                              f"found {len(found)}")
        path = found[0]
    if not path.is_file():
        raise DeployError(f"{path}: no such export (a directory written by cra-export or its JSON)")
    try:
        spec = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DeployError(f"{path}: not a readable JSON ({e})") from None
    if not isinstance(spec, dict) or not str(spec.get("format", "")).startswith("cra_warp-policy/"):
        raise DeployError(f"{path}: not a cra_warp policy export (no 'format: cra_warp-policy/1')")
    return spec, path.parent


def _is_export(p: Path) -> bool:
    try:
        return str(json.loads(p.read_text()).get("format", "")).startswith("cra_warp-policy/")
    except Exception:  # noqa: BLE001 - any unreadable JSON is simply not an export
        return False


class DeployPolicy:
    """One robot's policy state: the recurrent state, the gait clock, the previous action and the yaw-rate filter."""

    def __init__(self, export: str | Path, spec: dict | None = None):
        if spec is None:
            spec, folder = load_export(export)
        else:
            folder = Path(export)
        self.spec = spec
        try:
            self.joint_names = list(spec["joint_names"])
            J = self.num_joints = len(self.joint_names)
            self.layout = {k: slice(int(a), int(b)) for k, (a, b) in spec["obs_layout"].items()}
            net = spec["network"]
            self.obs_dim, self.action_dim = int(net["obs_dim"]), int(net["action_dim"])
            self.hidden_shape = tuple(net["hidden_state_shape"]) if net["recurrent"] else None
            self.default_q = np.asarray(spec["default_q"], dtype=np.float64)
            self.kp = np.asarray(spec["kp"], dtype=np.float64)
            self.kd = np.asarray(spec["kd"], dtype=np.float64)
            self.effort_limit = np.asarray(spec["effort_limit"], dtype=np.float64)
            self.action_scale = np.asarray(spec["action_scale"], dtype=np.float64)  # per joint (or one for all)
            self.clip_joints = float(spec["action_clip"]["joints"])
            self.clip_gait = float(spec["action_clip"].get("gait", 1.0))
            self.gait = spec["gait"] if self.action_dim == J + 3 else None
            self.clock_runs = spec.get("variant", "adaptive") == "adaptive"  # fixed_cycle ignores its gait actions
            self.feedforward = float(self.gait.get("swing_feedforward", 0.0)) if self.gait else 0.0
            self.sweeps = []                               # (joint per leg, signed gain per leg, command index)
            gains = [float(self.gait.get(f"{k}_feedforward", 0.0)) if self.gait else 0.0
                     for k in ("stride", "lateral", "turn")]
            if self.feedforward or any(gains):
                swing = spec["swing"]
                self.swing_ids = np.array([[self.joint_names.index(n) for n in leg] for leg in swing["joints"]])
                self.swing_profile = np.asarray(swing["profile"], dtype=np.float64)
                legs = {0: (self.swing_ids[:, 0], [self.swing_profile[0]] * len(self.swing_ids))}  # stride: hip pitch
                for c, key in ((1, "lateral_joints"), (2, "turn_joints")):
                    if gains[c]:
                        legs[c] = ([self.joint_names.index(j) for j, _ in swing[key]], [sign for _, sign in swing[key]])
                self.sweeps = [(np.asarray(legs[c][0]), gains[c] * np.asarray(legs[c][1], dtype=np.float64), c)
                               for c in range(3) if gains[c]]
            self.control_dt = float(spec["control_dt"])
            scales = spec["obs_scales"]
            self.command_scale = np.asarray(scales["command"], dtype=np.float64)
            self.ang_vel_scale = float(scales["ang_vel"])
            self.joint_vel_scale = float(scales["joint_vel"])
            self.yaw_filter = self.control_dt / (float(scales["yaw_rate_filter_tau"]) + self.control_dt)
            self.obs_clip = float(spec["observation"]["clip"])
            onnx_file = folder / spec["files"]["onnx"]
        except (KeyError, TypeError, ValueError) as e:
            raise DeployError(f"the export's JSON lacks or mangles {e} (re-export with cra-export)") from None
        if max(s.stop for s in self.layout.values()) != self.obs_dim:
            raise DeployError(f"the export's obs_layout does not cover its {self.obs_dim}-dim observation")
        if not onnx_file.is_file():
            raise DeployError(f"{onnx_file}: the export's ONNX file is missing")
        import onnxruntime as ort  # imported here: the JSON checks above run without it

        try:
            self.session = ort.InferenceSession(str(onnx_file), providers=["CPUExecutionProvider"])
        except Exception as e:  # noqa: BLE001 - onnxruntime raises its own types; a missing .data lands here
            raise DeployError(f"{onnx_file}: onnxruntime cannot load it ({str(e).splitlines()[0]}); "
                              f"is {onnx_file.name}.data beside it?") from None
        self.reset()

    # ---------------------------------------------------------------- the control step
    def reset(self) -> None:
        """Episode start: zero recurrent state, clock phase, previous action and yaw-rate filter."""
        self.h = np.zeros(self.hidden_shape, dtype=np.float32) if self.hidden_shape else None
        self.phase = 0.0                                   # phi [s]
        self.prev_action = np.zeros(self.action_dim)
        self.avg_yaw_rate = 0.0
        self.command = np.zeros(3)                         # the last observed command (the sweeps follow it)
        self._stepped = False                              # an action was applied since the last observation

    def observe(self, command, gravity, q, qd, ang_vel) -> np.ndarray:
        """The [D] float32 observation of this control step (advances the yaw-rate filter once per step)."""
        ang_vel = np.asarray(ang_vel, dtype=np.float64)
        if self._stepped:  # the filter runs after every control step's physics, on the new reading
            self.avg_yaw_rate += self.yaw_filter * (ang_vel[2] - self.avg_yaw_rate)
            self._stepped = False
        self.command = np.asarray(command, dtype=np.float64)
        parts = {
            "command": self.command * self.command_scale,
            "gravity": np.asarray(gravity, dtype=np.float64),
            "joint_pos": np.asarray(q, dtype=np.float64) - self.default_q,
            "joint_vel": np.asarray(qd, dtype=np.float64) * self.joint_vel_scale,
            "prev_action": self.prev_action,
            "ang_vel": ang_vel * self.ang_vel_scale,
            "avg_ang_speed": np.array([self.avg_yaw_rate * self.ang_vel_scale]),
        }
        if self.gait is not None:
            angle = 2.0 * math.pi * self.phase / self.gait["cycle_time"]
            parts["gait_phase"] = np.array([math.sin(angle), math.cos(angle)])
        obs = np.zeros(self.obs_dim)
        for name, where in self.layout.items():
            obs[where] = parts[name]
        return np.clip(obs, -self.obs_clip, self.obs_clip).astype(np.float32)

    def act(self, obs: np.ndarray) -> np.ndarray:
        """The network's deterministic action [A] for ``obs`` (keeps the recurrent state), clipped as in training."""
        feed = {"obs": np.asarray(obs, dtype=np.float32).reshape(1, -1)}
        if self.h is not None:
            feed["h_in"] = self.h
            actions, self.h = self.session.run(None, feed)
        else:
            actions = self.session.run(None, feed)[0]
        return self.clip(actions.reshape(-1).astype(np.float64))

    def clip(self, actions: np.ndarray) -> np.ndarray:
        a = np.asarray(actions, dtype=np.float64).copy()
        a = np.where(np.isfinite(a), a, 0.0)  # as the env: a non-finite action never reaches the drives
        J = self.num_joints
        a[:J] = np.clip(a[:J], -self.clip_joints, self.clip_joints)
        a[J:] = np.clip(a[J:], -self.clip_gait, self.clip_gait)
        return a

    def apply(self, actions: np.ndarray) -> np.ndarray:
        """Use ``actions`` [A] (clipped here): the clock advances, they become the previous action; returns the
        joint targets [J]."""
        a = self.clip(actions)
        self.prev_action = a
        J = self.num_joints
        if self.gait is not None:
            g = self.gait
            d0 = g["beta_scale"] * a[J] if self.clock_runs else 0.0
            rate = max(1.0 + g["alpha"] * d0, 0.0)
            self.phase = math.fmod(self.phase + rate * self.control_dt, g["cycle_time"])
        self._stepped = True
        q_target = self.default_q + self.action_scale * a[:J]
        if self.feedforward or self.sweeps:
            g = self.gait
            d1, d2 = (g["beta_scale"] * a[J + 1], g["beta_scale"] * a[J + 2]) if self.clock_runs else (0.0, 0.0)
            angle = 2.0 * math.pi * (self.phase / g["cycle_time"] + np.array([d1, d2 + g["psi"]]))
            depth = np.clip((g["gamma"] - np.sin(angle)) / (1.0 + g["gamma"]), 0.0, 1.0)  # as gait.swing_depth
            q_target[self.swing_ids] += self.feedforward * depth[:, None] * self.swing_profile
            for ids, gain, c in self.sweeps:
                q_target[ids] += gain * self.command[c] * np.cos(angle)
        return q_target

    def step(self, command, gravity, q, qd, ang_vel) -> np.ndarray:
        """One control step: observation, network, clock; returns the joint targets [J] to hold until the next."""
        return self.apply(self.act(self.observe(command, gravity, q, qd, ang_vel)))

    def torque(self, q, qd, q_target) -> np.ndarray:
        """The drives' PD law with the export's gains, to run at its pd.rate_hz (see :func:`pd_torque`)."""
        return pd_torque(q, qd, q_target, self.kp, self.kd, self.effort_limit)


def pd_torque(q, qd, q_target, kp, kd, effort_limit) -> np.ndarray:
    """The JSON's pd.law: clip(kp (q* - q) - kd qd, -effort_limit, effort_limit), per joint."""
    tau = np.asarray(kp) * (np.asarray(q_target) - np.asarray(q)) - np.asarray(kd) * np.asarray(qd)
    return np.clip(tau, -np.asarray(effort_limit), np.asarray(effort_limit))
