"""cra_warp/terrain/curriculum.py: promotion rules, wrapping, restore and the path meter."""

import math

import pytest
import torch

from cra_warp.terrain.curriculum import PathMeter, TerrainCurriculum


# ---------------------------------------------------------------- curriculum
def test_curriculum_promotes_demotes_and_wraps(terrain):
    n = 12
    cur = TerrainCurriculum(terrain, n, device="cpu", max_init_level=0, seed=0)
    assert cur.levels.tolist() == [0] * n and cur.cols.tolist() == [i % 6 for i in range(n)]
    cur.levels[:] = torch.tensor([3, 3, 3, 3, 0, 0, 9, 9, 9, 9, 5, 5])
    walked = torch.tensor([4.5, 1.0, 3.0, 0.5, 0.1, 5.0, 4.1, 4.1, 4.1, 4.1, 2.0, 2.0])
    commanded = torch.tensor([10., 10., 4., 0.0, 5., 5., 5., 5., 5., 5., 3.9, 4.1])
    ids = torch.arange(n)
    cur.update(ids, walked, torch.zeros(n), commanded)  # the path rule ignores the farthest point
    # >4 m (half a tile): up; < half the commanded distance: down (not below 0); otherwise stay
    assert cur.levels[[0, 1, 2, 3, 4, 5, 10, 11]].tolist() == [4, 2, 3, 3, 0, 1, 5, 4]
    assert ((cur.levels[6:10] >= 0) & (cur.levels[6:10] < 10)).all()     # past the top: a random level
    assert torch.equal(cur.origins, cur.tile_origins[cur.levels, cur.cols])
    assert cur.mean_level() == pytest.approx(cur.levels.float().mean().item())
    before = cur.levels.clone()
    cur.update(torch.tensor([1]), torch.tensor([9.0]), torch.tensor([0.0]), torch.tensor([1.0]))  # env 1 alone
    assert cur.levels[1] == before[1] + 1 and torch.equal(cur.levels[2:], before[2:])


def test_curriculum_reach_rule_judges_the_farthest_point(terrain):
    """Rule "reach": a long path circling near the origin (a pit's floor) is a demotion, not a promotion."""
    cur = TerrainCurriculum(terrain, 6, rule="reach")
    cur.levels[:] = 3
    walked = torch.tensor([9.0, 9.0, 9.0, 1.0, 9.0, 0.1])
    farthest = torch.tensor([4.5, 1.5, 2.5, 1.0, 1.9, 0.1])
    commanded = torch.tensor([10., 10., 10., 1.0, 3.0, 0.0])
    cur.update(torch.arange(6), walked, farthest, commanded)
    # out of the pit: up; stuck at its wall's foot (< 2 m): down however far it walked; halfway out: stays;
    # short commands ask for less (1 m -> 0.5 m, 3 m -> 1.5 m); no command: never down
    assert cur.levels.tolist() == [4, 2, 3, 3, 3, 3]
    with pytest.raises(ValueError, match="rule"):
        TerrainCurriculum(terrain, 2, rule="displacement")


def test_curriculum_reach_upright_rule_also_demotes_a_fall(terrain):
    """Rule "reach_upright": a robot that fell halfway out of a pit is demoted (under "reach" it holds its level);
    one that got out is promoted however its episode ended."""
    farthest = torch.tensor([2.5, 2.5, 4.5, 1.0])
    fell = torch.tensor([True, False, True, False])
    for rule, want in (("reach", [3, 3, 4, 2]), ("reach_upright", [2, 3, 4, 2])):
        cur = TerrainCurriculum(terrain, 4, rule=rule)
        cur.levels[:] = 3
        cur.update(torch.arange(4), torch.full((4,), 9.0), farthest, torch.full((4,), 10.0), fell)
        assert cur.levels.tolist() == want, rule


def test_curriculum_wrap_spreads_over_levels(terrain):
    cur = TerrainCurriculum(terrain, 600, max_init_level=9, seed=1)
    cur.levels[:] = 9
    cur.update(torch.arange(600), torch.full((600,), 6.0), torch.full((600,), 6.0), torch.zeros(600))
    counts = torch.bincount(cur.levels, minlength=10)
    assert (counts > 20).all(), counts.tolist()


def test_curriculum_rejects_bad_init_level(terrain):
    with pytest.raises(ValueError, match="max_init_level"):
        TerrainCurriculum(terrain, 4, max_init_level=10)


def test_path_meter_counts_a_walked_circle_and_not_the_sway_and_the_farthest_point():
    """50 Hz for 20 s: robot 0 walks a 0.5 m/s circle of radius 1 m with a 2 cm, 2 Hz sideways sway (it ends near
    its start: legged_gym's displacement would give it nothing); robot 1 only sways on the spot."""
    dt, steps = 0.02, 1000
    meter = PathMeter(2, window=50)
    meter.reset(torch.arange(2), torch.tensor([[1.0, 0.0], [0.0, 0.0]]))
    for k in range(1, steps + 1):
        t = k * dt
        sway = 0.02 * math.sin(2 * math.pi * 2 * t)
        a = 0.5 * t  # rad: 0.5 m/s on a 1 m radius
        circle = [(1 + sway) * math.cos(a), (1 + sway) * math.sin(a)]
        xy = torch.tensor([circle, [0.0, sway]])
        meter.update(xy)
    walked = meter.walked(torch.arange(2), xy)
    assert walked[0] == pytest.approx(0.5 * steps * dt, rel=0.03)  # 10 m along the circle
    assert walked[1] < 0.1
    # the farthest from the start: across the circle (2 m, plus the sway), not where it ended (1.9 m)
    farthest = meter.farthest(torch.arange(2), xy)
    assert farthest[0] == pytest.approx(2.0, abs=0.03) and (xy[0] - torch.tensor([1.0, 0.0])).norm() < 1.95
    assert farthest[1] == pytest.approx(0.02, abs=1e-3)
    meter.reset(torch.tensor([0]), xy[:1])
    assert meter.farthest(torch.tensor([0]), xy[:1]) == 0.0
    with pytest.raises(ValueError, match="window"):
        PathMeter(2, window=0)


def test_curriculum_restore_puts_robots_on_their_levels_tiles(terrain):
    cur = TerrainCurriculum(terrain, 4, max_init_level=0, seed=0)
    cur.restore([2, 0, 9, 4])
    assert cur.levels.tolist() == [2, 0, 9, 4]
    assert torch.equal(cur.origins, cur.tile_origins[torch.tensor([2, 0, 9, 4]), cur.cols])
    with pytest.raises(ValueError, match="for \\(3,\\) envs"):
        cur.restore([1, 2, 3])
    with pytest.raises(ValueError, match="must be in \\[0, 9\\]"):
        cur.restore([0, 0, 10, 0])


def test_levels_by_type_follows_the_curriculums_columns(terrain):
    from cra_warp.terrain.curriculum import levels_by_type

    cur = TerrainCurriculum(terrain, 13, seed=3, max_init_level=terrain.num_levels - 1)
    by_type = levels_by_type(cur.levels, terrain.column_types)
    for name, level in by_type.items():
        on = torch.tensor([terrain.column_types[c] == name for c in cur.cols.tolist()])
        assert level == pytest.approx(float(cur.levels[on].float().mean()))
    assert set(by_type) == set(terrain.column_types[:13])
    assert {k: float(v) for k, v in levels_by_type([4.0, 0.0], ("a", "b", "c")).items()} == {"a": 4.0, "b": 0.0}
