"""Learning check on CPU (flat ground, small budget): the policy gets better and the contrast learns something.

Slow (~3-4 min on 2 cores) but part of CI: it is the one test that runs the whole stack as training does.
"""

import statistics

import pytest

from train.train import TrainArgs, run


@pytest.mark.slow
def test_reward_episode_length_and_infonce_improve(tmp_path):
    # the paper recipe (Table I, no feedforward): the learner's check, measured so; walk's feedforward march takes
    # hundreds of iterations before its episodes lengthen (docs/experiments.md)
    _, runner = run(TrainArgs(num_envs=64, max_iterations=30, seed=3, log_dir=tmp_path, export=False, quiet=True,
                              recipe="paper"))
    h = [r for r in runner.history if "reward" in r]
    first, last = h[0], h[-5:]
    reward = statistics.mean(r["reward"] for r in last)
    length = statistics.mean(r["episode_s"] for r in last)
    acc = statistics.mean(r["infonce_acc"] for r in last)
    chance = last[-1]["infonce_chance"]
    print(f"first: reward {first['reward']:.2f}, episode {first['episode_s']:.2f} s; "
          f"last 5: reward {reward:.2f}, episode {length:.2f} s, InfoNCE top-1 {acc:.2f} (chance {chance:.4f})")
    # With effort-scaled actions the first iteration already earns ~130 (the fall comes later than with the vendor's
    # uniform scale); measured at seed 3: 134 -> 164 reward, 1.28 -> 1.42 s. A learner that does not learn stays put.
    assert reward > 1.15 * first["reward"] and reward > first["reward"] + 10.0
    assert length > 1.05 * first["episode_s"]
    assert acc > 10 * chance
