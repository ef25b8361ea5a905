"""Checkpoints (cra_warp/learning/checkpoint.py): a round trip acts the same, and every bad file is a one-line error."""

from __future__ import annotations

import pytest
import torch

from cra_warp.learning import CheckpointError, load_checkpoint
from cra_warp.learning.bench import collect
from tests.cra_warp.learning.helpers import STEPS, make_runner, rollout_actions


def test_checkpoint_round_trip(tmp_path):
    a, env = make_runner(seed=1)
    collect(a.alg, env, STEPS)
    a.alg.update()
    a.current_learning_iteration = 7
    path = tmp_path / "model_7.pt"
    a.save(str(path))
    b, _ = make_runner(seed=2)
    obs_seq = torch.randn(6, 1, 84)
    assert not torch.allclose(rollout_actions(a.alg.actor, obs_seq), rollout_actions(b.alg.actor, obs_seq))
    load_checkpoint(path, b)
    assert b.current_learning_iteration == 7
    torch.testing.assert_close(rollout_actions(b.alg.actor, obs_seq), rollout_actions(a.alg.actor, obs_seq),
                               atol=0, rtol=0)
    for n, v in a.alg.heads.state_dict().items():
        assert torch.equal(v, b.alg.heads.state_dict()[n])
    c, _ = make_runner(seed=3)
    c.load(str(path))  # rsl-rl's own load works on the same file
    torch.testing.assert_close(rollout_actions(c.alg.actor, obs_seq), rollout_actions(a.alg.actor, obs_seq))


def test_checkpoint_errors(tmp_path):
    runner, _ = make_runner()

    def error(path):
        with pytest.raises(CheckpointError) as e:
            load_checkpoint(path, runner)
        msg = str(e.value)
        assert msg.startswith(str(path)) and "\n" not in msg
        return msg

    assert "no such checkpoint" in error(tmp_path / "missing.pt")
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"\x00not a checkpoint" * 10)
    assert "not a readable torch checkpoint" in error(junk)
    good = tmp_path / "good.pt"
    runner.save(str(good))
    cut = tmp_path / "cut.pt"
    cut.write_bytes(good.read_bytes()[:2000])
    assert "not a readable torch checkpoint" in error(cut)
    other = tmp_path / "other.pt"
    torch.save({"weights": 1}, other)
    assert "not an rsl-rl checkpoint" in error(other)
    clock_free, _ = make_runner(num_obs=79, num_actions=23)
    small = tmp_path / "clock_free.pt"
    clock_free.save(str(small))
    assert "actor observation dim is 79 in the checkpoint but 84 in this model" in error(small)
    none_runner, _ = make_runner("none")
    none_ckpt = tmp_path / "none.pt"
    none_runner.save(str(none_ckpt))
    assert "has no contrastive heads but this runner's contrast variant is 'same_step'" in error(none_ckpt)
    load_checkpoint(none_ckpt, runner, load_cfg={"actor": True})  # the actor alone loads fine
