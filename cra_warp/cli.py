"""What every command line of cra_warp shares: the choices (typed, so --help lists them), the one-line error, the
argument parser that keeps to it, and the device and simulator checks."""

from __future__ import annotations

import contextlib
import io
import sys
from typing import Literal, TypeVar, get_args

Task = Literal["flat", "rough"]
Sim = Literal["newton", "mujoco"]
Variant = Literal["ours", "sequential", "no_contrast", "fixed_cycle", "clock_free", "dreamwaq", "dwl"]
TASKS, SIMS = get_args(Task), get_args(Sim)
VARIANTS = {  # the experiment registry (paper IV-A): variant -> (env variant, contrast variant, actor kind)
    "ours": ("adaptive", "same_step", "gru"),
    "sequential": ("adaptive", "sequential", "gru"),
    "no_contrast": ("adaptive", "none", "gru"),
    "fixed_cycle": ("fixed_cycle", "same_step", "gru"),
    "clock_free": ("clock_free", "same_step", "gru"),
    # the baselines keep our clock, rewards and critic; their actors are cra_warp/learning/baselines.py's
    "dreamwaq": ("adaptive", "none", "dreamwaq"),
    "dwl": ("adaptive", "none", "dwl"),
}
assert tuple(VARIANTS) == get_args(Variant)

T = TypeVar("T")


class UsageError(Exception):
    """A bad argument or input file: reported as one line, exit code 2."""


def parse_args(cls: type[T], argv: list[str] | None, doc: str | None) -> T:
    """tyro's parse of ``argv`` into ``cls``; its multi-line error box becomes a UsageError of one line."""
    import tyro

    description = (doc or "").split("\n\n")[0]
    if any(a in ("-h", "--help") for a in (sys.argv[1:] if argv is None else argv)):
        return tyro.cli(cls, args=argv, description=description)
    out = io.StringIO()
    try:
        # Redirected, tyro writes its box as plain text: a title, a rule, the message, a rule, help hints.
        with contextlib.redirect_stderr(out), contextlib.redirect_stdout(out):
            return tyro.cli(cls, args=argv, description=description)
    except SystemExit as e:
        if not e.code:
            raise
        lines = [line.strip() for line in out.getvalue().splitlines()]
        rules = [i for i, line in enumerate(lines) if line and set(line) <= set("-─")]
        body = lines[rules[0] + 1:rules[1]] if len(rules) >= 2 else lines
        message = " ".join(line for line in body if line).replace(" .", ".")
        raise UsageError(message or "could not parse the arguments (see --help)") from None


def check_sim(sim: str | None, device: str) -> None:
    if sim is not None and sim not in SIMS:
        raise UsageError(f"--sim must be one of {', '.join(SIMS)}, got {sim!r}")
    if sim == "mujoco" and device != "cpu":
        raise UsageError(f"--sim mujoco runs on the CPU only (use --device cpu or --sim newton), got --device {device}")


def check_device(device: str) -> None:
    import warp as wp

    if device != "cpu" and not (device.startswith("cuda:") and device[5:].isdigit()):
        raise UsageError(f"--device must be cpu or cuda:N, got {device!r}")
    if device != "cpu" and device not in [str(d) for d in wp.get_cuda_devices()]:
        raise UsageError(f"--device {device}: no such CUDA device on this machine")


def world_config(sim: str, **kw):
    """The WorldConfig of a --sim choice."""
    from cra_warp.sim import WorldConfig

    return WorldConfig(backend=sim, **kw)
