"""cra-soak on a short run: adversarial actions and poisoned worlds on both backends."""

import pytest

from tools import soak


@pytest.mark.parametrize("sim", ["mujoco", "newton"])
def test_adversarial_actions_and_poisoned_worlds_are_contained(sim):
    r = soak.soak(steps=16 * 40, num_envs=16, sim=sim, seed=0, poison_every=5, terrain="flat")
    assert r["poisoned_worlds"] == 8 and r["nonfinite_resets"] == 8  # each poisoned robot reset alone, counted
    assert r["steps_with_nonfinite_output"] == 0 and r["ok"]
    assert all(v > 0 for v in r["action_modes"].values())
