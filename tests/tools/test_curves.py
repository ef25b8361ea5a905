"""cra-curves on small synthetic TensorBoard logs: arms, seed spread, the figure, bad input."""

import json

from tests.conftest import one_line_error
from tools import curves


def _run(path, rewards):
    from torch.utils.tensorboard import SummaryWriter

    w = SummaryWriter(str(path))
    for i, r in enumerate(rewards):
        w.add_scalar("Train/mean_reward", r, i)
        w.add_scalar("Train/mean_episode_length", 10 * r, i)
    w.close()
    return path


def test_arms_within_and_outside_the_seed_spread(tmp_path):
    a1 = _run(tmp_path / "a1", [1, 2, 3, 4])
    a2 = _run(tmp_path / "a2", [1, 2, 3, 6])
    b1 = _run(tmp_path / "b1", [1, 2, 3, 5])
    b2 = _run(tmp_path / "b2", [1, 2, 3, 5.5])
    c1 = _run(tmp_path / "c1", [1, 2, 3, 20])
    out, js = tmp_path / "fig.png", tmp_path / "s.json"
    assert curves.main([f"a={a1},{a2}", f"b={b1},{b2}", "--last", "1", "--out", str(out), "--json", str(js)]) == 0
    s = json.loads(js.read_text())["summary"]["Train/mean_reward"]
    assert s["arms"]["a"]["spread"] == 2.0 and s["arms"]["b"]["mean"] == 5.25 and s["within_spread"]
    assert out.stat().st_size > 10_000
    assert curves.main([f"a={a1},{a2}", f"c={c1}", "--last", "1", "--out", str(out), "--json", str(js)]) == 0
    assert not json.loads(js.read_text())["summary"]["Train/mean_reward"]["within_spread"]
    # --upto: only the first iterations of each run (c1 is a's equal up to iteration 2)
    assert curves.main([f"a={a1},{a2}", f"c={c1}", "--last", "1", "--upto", "2", "--out", str(out), "--json",
                        str(js)]) == 0
    s = json.loads(js.read_text())["summary"]["Train/mean_reward"]
    assert s["arms"]["c"]["mean"] == 3.0 and s["difference"] == 0.0


def test_an_arm_read_back_from_a_stored_json_gives_the_same_summary(tmp_path):
    a = [_run(tmp_path / "a1", [1, 2, 3, 4]), _run(tmp_path / "a2", [1, 2, 3, 6])]
    b = _run(tmp_path / "b1", [1, 2, 3, 5])
    first, again = tmp_path / "first.json", tmp_path / "again.json"
    dirs = ",".join(map(str, a))
    assert curves.main([f"a={dirs}", f"b={b}", "--last", "1", "--out", str(tmp_path / "f.png"), "--json",
                        str(first)]) == 0
    assert curves.main([f"a={first}#a", f"b={b}", "--last", "1", "--out", str(tmp_path / "g.png"), "--json",
                        str(again)]) == 0
    s1, s2 = (json.loads(f.read_text())["summary"]["Train/mean_reward"] for f in (first, again))
    assert s2["arms"]["a"]["seed_means"] == [4.0, 6.0] and s2 == s1
    # --upto cuts a stored arm like a run directory
    assert curves.main([f"a={first}#a", f"b={b}", "--last", "1", "--upto", "2", "--out", str(tmp_path / "g.png"),
                        "--json", str(again)]) == 0
    assert json.loads(again.read_text())["summary"]["Train/mean_reward"]["arms"]["a"]["mean"] == 3.0


def test_bad_arms_are_one_line_errors(tmp_path, capsys):
    one_line_error(capsys, curves.main(["nodir", "--out", str(tmp_path / "f.png")]), "NAME=DIR")
    one_line_error(capsys, curves.main([f"a={tmp_path / 'missing'}", "--out", str(tmp_path / "f.png")]),
                   "no such directory")
    stored = tmp_path / "s.json"
    stored.write_text(json.dumps({"arms": {"a": [{"Train/mean_reward": [[0, 1.0]]}]}}))
    one_line_error(capsys, curves.main([f"a={stored}#zz", "--out", str(tmp_path / "f.png")]), "no arm 'zz'")
    one_line_error(capsys, curves.main([f"a={stored}#a", "--out", str(tmp_path / "f.png")]),
                   "no values for Train/mean_episode_length")
    (tmp_path / "empty").mkdir()
    one_line_error(capsys, curves.main([f"a={tmp_path / 'empty'}", "--out", str(tmp_path / "f.png")]),
                   "no TensorBoard event files")
