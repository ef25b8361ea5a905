"""The trained run the command tests share (train, export, play, eval), built once for the package."""

import pytest

from train import train as train_cli


@pytest.fixture(scope="package")
def trained(tmp_path_factory):
    """A 2-iteration run with checkpoints every iteration, then a 1-iteration resume of it on the MuJoCo backend."""
    logs = tmp_path_factory.mktemp("runs")
    common = ["--num-envs", "4", "--save-interval", "1", "--log-dir", str(logs), "--quiet"]
    assert train_cli.main(["--max-iterations", "2", *common]) == 0
    first = next(logs.iterdir())
    assert train_cli.main(["--max-iterations", "1", "--resume", str(first / "model_1.pt"), "--no-export",
                           "--sim", "mujoco", *common]) == 0
    second = next(d for d in logs.iterdir() if d != first)
    return first, second
