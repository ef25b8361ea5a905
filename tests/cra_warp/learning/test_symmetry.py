"""The mirror loss of a recurrent actor (cra_warp/learning/symmetry.py)."""

import pytest
import torch
from tensordict import TensorDict

from cra_warp.learning.models import CRAActor
from cra_warp.learning.symmetry import Mirror, mirror_loss


def _actor(obs_dim=6, act_dim=4):
    obs = TensorDict({"policy": torch.zeros(2, obs_dim)}, batch_size=[2])
    torch.manual_seed(0)
    return CRAActor(obs, {"actor": ["policy"]}, "actor", act_dim, hidden_dims=(32,), rnn_hidden_dim=16,
                    distribution_cfg={"class_name": "GaussianDistribution", "init_std": 1.0})


def _window(T=8, B=5, D=6):
    g = torch.Generator().manual_seed(1)
    obs = TensorDict({"policy": torch.randn(T, B, D, generator=g)}, batch_size=[T, B])
    starts = torch.zeros(T, B, dtype=torch.bool)
    starts[3, 1] = True   # an episode restarts mid-window for one env
    return obs, starts


# obs: entries 0 <-> 1 swap, entry 2 flips; actions: 0 <-> 1 swap, 2 flips
OBS_M = Mirror([1, 0, 2, 3, 4, 5], [1, 1, -1, 1, 1, 1])
ACT_M = Mirror([1, 0, 2, 3], [1, 1, -1, 1])


def test_a_map_that_is_not_its_own_inverse_is_refused():
    with pytest.raises(ValueError, match="own inverse"):
        Mirror([1, 2, 0], [1, 1, 1])


def test_identity_maps_cost_nothing_and_real_ones_do():
    actor = _actor()
    obs, starts = _window()
    same = Mirror(range(6), [1] * 6), Mirror(range(4), [1] * 4)
    assert mirror_loss(actor, obs, starts, *same).item() == 0.0   # both passes see the same window
    assert mirror_loss(actor, obs, starts, OBS_M, ACT_M).item() > 1e-3


def test_training_on_the_mirror_loss_makes_the_actor_equivariant():
    actor = _actor()
    obs, starts = _window()
    opt = torch.optim.Adam(actor.parameters(), lr=3e-3)
    first = mirror_loss(actor, obs, starts, OBS_M, ACT_M).item()
    for _ in range(300):
        loss = mirror_loss(actor, obs, starts, OBS_M, ACT_M)
        opt.zero_grad()
        loss.backward()
        opt.step()
    assert loss.item() < 0.1 * first
    # equivariant on a window it never saw
    fresh, starts = _window(T=6, B=3)
    fresh["policy"] = fresh["policy"].flip(0) * 0.5
    assert mirror_loss(actor, fresh, starts, OBS_M, ACT_M).item() < 0.3 * first
