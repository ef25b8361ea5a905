"""The world's config (cra_warp/sim/config.py): errors name the field, backend names are written once."""

import pytest

from cra_warp.sim import WorldConfig, check_backend_device, make_world
from robots.adam_lite import ADAM_LITE


def test_config_errors_name_the_field():
    with pytest.raises(ValueError, match="substeps"):
        WorldConfig(substeps=3)
    # the size and device are make_world's, checked there before anything is built
    for n in (0, 2.0, True):
        with pytest.raises(ValueError, match="make_world: num_envs must be an integer >= 1"):
            make_world(ADAM_LITE, num_envs=n)
    with pytest.raises(ValueError, match="CPU only"):
        make_world(ADAM_LITE, WorldConfig(backend="mujoco"), num_envs=1, device="cuda:0")
    check_backend_device("mujoco", "cpu")
    check_backend_device("newton", "cuda:0")
    with pytest.raises(ValueError, match="mujoco runs on the CPU only, got device 'cuda:0'"):
        check_backend_device("mujoco", "cuda:0")


def test_backend_names_are_written_once(capsys):
    """WorldConfig.backend's names are the source; every --sim takes them (tyro's type, check_sim, the argparse
    tools), and a name that is not a backend gets the same one-line errors as before."""
    import subprocess
    import sys
    import typing

    from cra_warp import cli
    from cra_warp.sim.config import BACKENDS
    from tools import figures, soak

    assert BACKENDS == ("newton", "mujoco")
    assert typing.get_args(typing.get_type_hints(WorldConfig)["backend"]) == BACKENDS
    assert typing.get_args(cli.Sim) == cli.SIMS == BACKENDS
    for name in BACKENDS:
        assert WorldConfig(backend=name).backend == name
        cli.check_sim(name, "cpu")
    with pytest.raises(ValueError, match="^WorldConfig.backend must be newton or mujoco, got 'physx'$"):
        WorldConfig(backend="physx")
    with pytest.raises(cli.UsageError, match="^--sim must be one of newton, mujoco, got 'physx'$"):
        cli.check_sim("physx", "cpu")
    for tool in (soak, figures):  # argparse: the usage line lists the choices, exit code 2
        with pytest.raises(SystemExit) as e:
            tool.main(["--sim", "physx", "--out", "x"])
        assert e.value.code == 2 and "--sim {newton,mujoco}" in capsys.readouterr().err
    # the names live with the simulator, but a command that only parses its arguments does not load it (or torch)
    code = "import sys, cra_warp.cli; assert 'torch' not in sys.modules and 'cra_warp.sim' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)
