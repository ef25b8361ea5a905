"""cra-terrain (tools/terrain_png.py): the picture, and bad arguments as one line."""

import subprocess
import sys

import pytest


# ---------------------------------------------------------------- picture
def test_terrain_png_cli(tmp_path):
    from tools.terrain_png import main

    out = tmp_path / "t.png"
    assert main(["--png", str(out), "--levels", "2", "--cols", "3", "--seed", "1"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args, needle", [
    (["--levels", "2"], "--png"),
    (["--png", "x.png", "--levels", "0"], "num_levels"),
    (["--png", "/no/such/dir/x.png"], "does not exist"),
    (["--png", "x.png", "--tile-size", "8.03"], "tile_size"),
])
def test_terrain_png_bad_args_one_line_exit_2(args, needle, tmp_path):
    r = subprocess.run([sys.executable, "-m", "tools.terrain_png", *args], capture_output=True, text=True,
                       cwd=tmp_path.parent, env={"PYTHONPATH": str(__import__("pathlib").Path(__file__).parents[2]),
                                                 "PATH": ""})
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr
