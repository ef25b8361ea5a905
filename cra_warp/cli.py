"""What every command line of cra_warp shares (train/ and tools/ alike): the one-line error, the argument parser that
keeps to it, and the device and simulator checks. The method and task choices are envs.methods'."""

from __future__ import annotations

import contextlib
import io
import sys
from typing import TypeVar

T = TypeVar("T")


def __getattr__(name: str):
    """``Sim`` (the type of every --sim) and ``SIMS`` are the simulator's backend names, cra_warp.sim.config.Backend
    and BACKENDS, looked up when first asked for: importing cra_warp.sim loads torch, which a command that only
    parses its arguments here (cra-campaign, cra-export's checks) should not pay for."""
    if name in ("Sim", "SIMS"):
        from cra_warp.sim.config import BACKENDS, Backend

        return Backend if name == "Sim" else BACKENDS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    from cra_warp.sim.config import BACKENDS, check_backend_device

    if sim is not None and sim not in BACKENDS:
        raise UsageError(f"--sim must be one of {', '.join(BACKENDS)}, got {sim!r}")

    try:
        if sim is not None:  # None: the run's or the default backend, checked when the world is made
            check_backend_device(sim, device)
    except ValueError as e:
        raise UsageError(f"--sim {e} (use --device cpu or --sim newton)") from None


def check_device(device: str) -> None:
    import warp as wp

    if device != "cpu" and not (device.startswith("cuda:") and device[5:].isdigit()):
        raise UsageError(f"--device must be cpu or cuda:N, got {device!r}")
    if device != "cpu" and device not in [str(d) for d in wp.get_cuda_devices()]:
        raise UsageError(f"--device {device}: no such CUDA device on this machine")


def quiet_stdout():
    """stdout of a block dropped: what a user reads is a command's own lines, not rsl-rl's model dumps or the
    backends' set-up notes; exceptions still propagate."""
    return contextlib.redirect_stdout(io.StringIO())
