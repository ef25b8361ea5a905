"""cra-urdf2usd (tools/urdf2usd.py): it converts, and bad input is one stderr line with exit code 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import OUR_URDF
from tools.urdf2usd import main


def _run_main(capsys, *argv) -> tuple[int, str, str]:
    try:
        code = main([str(a) for a in argv])
    except SystemExit as e:
        code = e.code
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_converts(tmp_path, capsys):
    code, out, err = _run_main(capsys, OUR_URDF, tmp_path / "a.usda")
    assert code == 0 and err == ""
    assert out.count("\n") == 1 and "26 links, 25 joints, 23 drives, 14 shapes" in out
    code, out, _ = _run_main(capsys, OUR_URDF, tmp_path / "b.usda", "--robot", "none")
    assert code == 0 and "0 drives" in out


BAD = {
    "malformed.urdf": ("<robot name='x'><link name='a'>", "line"),
    "no_links.urdf": ("<robot name='x'/>", "no <link>"),
    "missing_parent.urdf": ("<robot name='x'><link name='a'/><joint name='j' type='revolute'>"
                            "<parent link='ghost'/><child link='a'/></joint></robot>", "ghost"),
    "planar.urdf": ("<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='planar'>"
                    "<parent link='a'/><child link='b'/></joint></robot>", "planar"),
}


@pytest.mark.parametrize("case", [*BAD, "nonexistent.urdf"])
def test_cli_bad_input(tmp_path, capsys, case):
    urdf = tmp_path / case
    if case in BAD:
        urdf.write_text(BAD[case][0])
    code, out, err = _run_main(capsys, urdf, tmp_path / "out.usda")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and str(urdf) in err and "Traceback" not in err
    assert (BAD[case][1] if case in BAD else "No such file") in err
    assert not (tmp_path / "out.usda").exists()


def test_cli_subprocess_missing_parent(tmp_path):
    """The installed console script: one stderr line, exit code 2, no traceback."""
    if not CLI.exists():
        pytest.skip(f"{CLI} not installed (pip install -e .)")
    urdf = tmp_path / "missing_parent.urdf"
    urdf.write_text(BAD["missing_parent.urdf"][0])
    r = subprocess.run([str(CLI), str(urdf), str(tmp_path / "o.usda")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.count("\n") == 1 and "ghost" in r.stderr and str(urdf) in r.stderr


CLI = Path(sys.executable).with_name("cra-urdf2usd")
