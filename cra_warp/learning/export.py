"""Export the trained actor for deployment: TorchScript, ONNX and a JSON with everything else a deploy program needs.

    <name>.pt    TorchScript (the vendor's stack loads it with libtorch): actions [1, A] = m(obs [1, D]); the GRU
                 state lives in the module (buffer hidden_state [L, 1, 256]); call m.reset() at episode start.
    <name>.onnx  ONNX (opset 18): inputs obs [1, D], h_in [L, 1, 256]; outputs actions [1, A], h_out [L, 1, 256];
                 feed h_out back as h_in, zeros at episode start.
    <name>.json  the observation layout, joint order, action scale, reference pose, PD gains, gait-clock constants,
                 control dt and observation scales (from the caller's metadata) plus the network's interface.
A DreamWaQ policy has the same interface; its state is its window of past observations (network.history), not a
GRU's: [1, 1, (history - 1) D].

Both graphs are the models' own export wrappers (``as_jit`` / ``as_onnx``, the ones
``OnPolicyRunner.export_policy_to_*`` use: rsl-rl's, or baselines.py's for DreamWaQ) and contain the observation
normaliser, so the deploy program feeds the observation as the env builds it (scaled, clipped, not normalised) and
applies the deterministic (mean) action.
cra_warp does not import the task: the caller passes the task metadata (see :data:`REQUIRED_METADATA`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import torch

from cra_warp.atomic_json import write_json
from cra_warp.config_io import to_data

# key -> what it is. "gait" may be None for a clock-free policy (no gait actions).
REQUIRED_METADATA: dict[str, str] = {
    "obs_layout": "actor observation: name -> slice (or [start, stop]) of the D-dim input, in order",
    "joint_names": "joint order of the first J actions and of joint_pos / joint_vel in the observation",
    "action_scale": "q_target = default_q + action_scale * actions[:J] (one scale per joint, joint order)",
    "default_q": "reference pose q_ref [rad], joint order",
    "kp": "PD stiffness [N m / rad], joint order",
    "kd": "PD damping [N m s / rad], joint order",
    "gait": "gait clock constants {cycle_time, alpha, psi, gamma, beta_scale}; actions[J:J+3] = (d0, d1, d2) raw",
    "control_dt": "policy period [s]",
    "obs_scales": "scales applied to the observation terms before they enter the policy",
    "action_clip": "actions are clipped to +-these before use: {joints, gait}",
    "effort_limit": "drive torque limits [N m], joint order",
    "pd": "the PD law the drives run, its rate, held joints and the simulated rotor inertia",
}
GAIT_KEYS = ("cycle_time", "alpha", "psi", "gamma", "beta_scale")


def _check_metadata(meta: dict, obs_dim: int, action_dim: int) -> None:
    missing = [k for k in REQUIRED_METADATA if k not in meta]
    if missing:
        raise ValueError(f"export metadata lacks {missing} (needed: {list(REQUIRED_METADATA)})")
    layout = meta["obs_layout"]
    size = max(stop for _, stop in layout.values())
    if size != obs_dim:
        raise ValueError(f"export metadata: obs_layout covers {size} entries but the policy takes {obs_dim}")
    j = len(meta["joint_names"])
    for k in ("default_q", "kp", "kd", "effort_limit"):
        if len(meta[k]) != j:
            raise ValueError(f"export metadata: {k} has {len(meta[k])} entries for {j} joints")
    if action_dim not in (j, j + 3):
        raise ValueError(f"export metadata: {j} joints do not fit a {action_dim}-dim action (J or J + 3)")
    if action_dim == j + 3:
        gait = meta["gait"] or {}
        lacking = [k for k in GAIT_KEYS if k not in gait]
        if lacking:
            raise ValueError(f"export metadata: the policy has gait actions but gait lacks {lacking}")


def export_policy(policy, out_dir: str | Path, metadata: Mapping, name: str = "policy",
                  onnx: bool = True) -> dict[str, Path]:
    """Write ``<name>.pt`` (TorchScript), ``<name>.onnx`` and ``<name>.json`` into ``out_dir``; returns the paths.

    ``policy``: an rsl-rl OnPolicyRunner (its ``export_policy_to_jit`` / ``export_policy_to_onnx`` are used) or a
    trained actor model (rsl-rl RNNModel / MLPModel). ``metadata``: the task's deploy constants, keys in
    :data:`REQUIRED_METADATA` (extra keys are copied too). Example from the caller's side::

        env = LocoEnv(cfg)
        meta = dict(obs_layout=env.layout, joint_names=env.robot.joint_names, action_scale=env.action_scale,
                    default_q=env.robot.default_q, kp=env.robot.kp, kd=env.robot.kd,
                    gait=cfg.gait if cfg.uses_clock else None, control_dt=env.dt, obs_scales=cfg.obs)
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    actor = policy.alg.get_policy() if hasattr(policy, "alg") else policy
    meta = to_data(dict(metadata))
    obs_dim = actor.obs_dim
    action_dim = actor.distribution.output_dim if actor.distribution is not None else actor.mlp[-1].out_features
    _check_metadata(meta, obs_dim, action_dim)

    was_training = actor.training
    actor.eval()
    paths = {"torchscript": out / f"{name}.pt", "json": out / f"{name}.json"}
    if hasattr(policy, "export_policy_to_jit"):
        policy.export_policy_to_jit(str(out), paths["torchscript"].name)
    else:  # the same three steps as OnPolicyRunner.export_policy_to_jit
        jit_model = actor.as_jit()
        jit_model.to("cpu")
        torch.jit.script(jit_model).save(str(paths["torchscript"]))
    if onnx:
        paths["onnx"] = out / f"{name}.onnx"
        if hasattr(policy, "export_policy_to_onnx"):
            policy.export_policy_to_onnx(str(out), paths["onnx"].name)
        else:  # as OnPolicyRunner.export_policy_to_onnx
            m = actor.as_onnx(verbose=False).to("cpu").eval()
            torch.onnx.export(m, m.get_dummy_inputs(), str(paths["onnx"]), export_params=True, opset_version=18,
                              input_names=m.input_names, output_names=m.output_names)
    actor.train(was_training)
    if onnx:  # large ONNX graphs keep their weights in a side file the .onnx names: ship it with the graph
        data = out / f"{paths['onnx'].name}.data"
        if data.is_file():
            paths["onnx_data"] = data

    recurrent = bool(getattr(actor, "is_recurrent", False))
    net = {"obs_dim": obs_dim, "action_dim": action_dim, "recurrent": recurrent,
           "obs_normalization": "inside the exported graphs (feed the un-normalised observation)",
           "output": "deterministic action (Gaussian mean); clip as the env does before use"}
    if recurrent and hasattr(actor, "memory"):  # DreamWaQ: the state is its window of past observations
        net.update(history=actor.memory.length, hidden_state_shape=actor.state_shape,
                   hidden_state="the previous history - 1 observations after the graph's normaliser, oldest first")
    elif recurrent:
        rnn = actor.rnn.rnn
        net.update(rnn_type=type(rnn).__name__.lower(), rnn_hidden_dim=rnn.hidden_size,
                   rnn_num_layers=rnn.num_layers, hidden_state_shape=[rnn.num_layers, 1, rnn.hidden_size])
    doc = {
        "format": "cra_warp-policy/1",
        "files": {k: p.name for k, p in paths.items() if k != "json"},
        "network": net,
        "torchscript": {"call": "actions[1, A] = module(obs[1, D])", "reset": "module.reset() at episode start"},
        **({"onnx": {"inputs": {"obs": [1, obs_dim], **({"h_in": net["hidden_state_shape"]} if recurrent else {})},
                     "outputs": {"actions": [1, action_dim],
                                 **({"h_out": net["hidden_state_shape"]} if recurrent else {})},
                     "state": "feed h_out back as h_in; zeros at episode start"}} if onnx else {}),
        "actions": {"joints": [0, len(meta["joint_names"])],
                    **({"gait": [len(meta["joint_names"]), action_dim]} if action_dim > len(meta["joint_names"])
                       else {}),
                    "joint_target": "q_target = default_q + action_scale * actions[joints]"},
        "metadata_fields": REQUIRED_METADATA,
        **meta,
    }
    write_json(paths["json"], doc, indent=2)
    return paths
