"""Loading an rsl-rl checkpoint into a runner, with one-line errors that name the file and the problem.

rsl-rl's ``OnPolicyRunner.load`` surfaces a truncated file as an unpickling traceback and a network of another size
as a multi-line ``load_state_dict`` report; a CLI wants "<file>: <what is wrong>". We check the file and the tensor
shapes against the runner's models first, then let rsl-rl load it.
"""

from __future__ import annotations

from pathlib import Path

import torch


class CheckpointError(ValueError):
    """A checkpoint that cannot be loaded into this runner; str() is one line: "<path>: <problem>"."""


def _one_line(e: BaseException) -> str:
    text = " ".join(str(e).split())
    return f"{type(e).__name__}: {text[:300]}"


def _shape_problem(name: str, model: torch.nn.Module, saved: dict) -> str | None:
    """The first meaningful difference between a model's state dict and a saved one, or None."""
    own = model.state_dict()
    missing = [k for k in own if k not in saved]
    unexpected = [k for k in saved if k not in own]
    if missing or unexpected:
        return (f"{name} architecture differs (missing {missing[:3]}{'...' if len(missing) > 3 else ''}, "
                f"unexpected {unexpected[:3]}{'...' if len(unexpected) > 3 else ''})")
    bad = {k: (tuple(saved[k].shape), tuple(v.shape)) for k, v in own.items()
           if tuple(saved[k].shape) != tuple(v.shape)}
    if not bad:
        return None
    # The RNN's input weights [3H, D] tell the observation size; the std parameter [A] the action size.
    for k, (s, m) in bad.items():
        if k.endswith("rnn.rnn.weight_ih_l0") and s[0] == m[0]:
            return f"{name} observation dim is {s[1]} in the checkpoint but {m[1]} in this model"
    for k, (s, m) in bad.items():
        if k.startswith("distribution.") and len(s) == 1:
            return f"{name} action dim is {s[0]} in the checkpoint but {m[0]} in this model"
    k, (s, m) = next(iter(bad.items()))
    return f"{name} parameter '{k}' has shape {s} in the checkpoint but {m} in this model"


def read_checkpoint(path: str | Path, map_location: str | None = "cpu") -> dict:
    """The saved dict of an rsl-rl checkpoint; :class:`CheckpointError` (one line) if it is missing or foreign."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: no such checkpoint file")
    try:
        saved = torch.load(path, weights_only=False, map_location=map_location)
    except Exception as e:  # truncated / not a torch file / pickle of unknown classes
        raise CheckpointError(f"{path}: not a readable torch checkpoint ({_one_line(e)})") from e
    if not isinstance(saved, dict) or "actor_state_dict" not in saved:
        raise CheckpointError(f"{path}: not an rsl-rl checkpoint (no 'actor_state_dict')")
    return saved


def load_checkpoint(path: str | Path, runner, load_cfg: dict | None = None, strict: bool = True,
                    map_location: str | None = "cpu"):
    """``runner.load(path, ...)`` with checks; returns the checkpoint's ``infos``. Raises :class:`CheckpointError`
    (a ValueError, one line) for a missing, unreadable, foreign or mismatched file."""
    path = Path(path)
    saved = read_checkpoint(path, map_location)
    alg = runner.alg
    want = load_cfg or {"actor": True, "critic": True}
    checks = [("actor", alg._raw_actor, "actor_state_dict")] if want.get("actor") else []
    if want.get("critic"):
        checks.append(("critic", alg._raw_critic, "critic_state_dict"))
    if strict:
        for name, model, key in checks:
            if key not in saved:
                raise CheckpointError(f"{path}: the checkpoint has no '{key}'")
            problem = _shape_problem(name, model, saved[key])
            if problem:
                raise CheckpointError(f"{path}: {problem}")
    if load_cfg is None or load_cfg.get("optimizer") or load_cfg.get("contrast"):
        has_heads = getattr(alg, "heads", None) is not None
        saved_heads = "contrast_state_dict" in saved
        if has_heads != saved_heads:
            mine = getattr(getattr(alg, "contrast_cfg", None), "variant", "none")
            raise CheckpointError(f"{path}: the checkpoint {'has' if saved_heads else 'has no'} contrastive heads but "
                                  f"this runner's contrast variant is '{mine}' (load the actor only, or match it)")
    try:
        return runner.load(str(path), load_cfg=load_cfg, strict=strict, map_location=map_location)
    except Exception as e:  # optimizer groups of another variant, missing heads, ...
        raise CheckpointError(f"{path}: cannot be loaded into this runner ({_one_line(e)})") from e
