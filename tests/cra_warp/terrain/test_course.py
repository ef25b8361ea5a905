"""cra_warp/terrain/course.py: the evaluation course's layout and its targets."""

import numpy as np
import pytest
import torch

from cra_warp.terrain.course import EVAL_KINDS, EvalCourse, EvalCourseConfig
from cra_warp.terrain.sampling import heading_xy


# ---------------------------------------------------------------- evaluation course
def test_eval_course_layout_and_reached():
    course = EvalCourse()
    assert course.kinds == EVAL_KINDS
    k = {name: i for i, name in enumerate(course.kinds)}
    assert course.difficulty[k["stairs_ascend"]].tolist() == pytest.approx([0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.35])
    assert course.difficulty[k["slope_ascend"], [0, -1]].tolist() == pytest.approx([2.0, 34.0])
    base = course.terrain.base_height
    # ascents start on the rim and end on top; descents the other way round; uneven stays on the rim height
    rise = course.targets[k["stairs_ascend"], :, 2] - course.starts[k["stairs_ascend"], :, 2]
    steps = rise / course.difficulty[k["stairs_ascend"]]
    assert np.allclose(steps, np.round(steps)) and (steps >= 5).all()
    assert np.allclose(course.starts[k["stairs_ascend"], :, 2], base)
    assert np.allclose(course.targets[k["stairs_descend"], :, 2], base)
    assert np.allclose(course.starts[k["uneven"], :, 2], base) and np.allclose(course.targets[k["uneven"], :, 2], base)
    dep = course.deploy(robots_per_level=200)
    n = len(course.kinds) * 7 * 200
    assert dep.start.shape == (n, 3) and dep.target.shape == (n, 3) and dep.kind.shape == (n,)
    assert not dep.reached(dep.start).any() and dep.reached(dep.target).all()
    pos, quat = dep.spawn_pose(base_height=0.88)
    assert torch.allclose(pos[:, 2], dep.start[:, 2] + 0.89) and quat.shape == (n, 4)
    facing = heading_xy(quat)
    to_target = torch.nn.functional.normalize(dep.target[:, :2] - dep.start[:, :2], dim=-1)
    assert torch.allclose(facing, to_target, atol=1e-5)
    ok = dep.reached(torch.where((dep.level == 3)[:, None], dep.target, dep.start))
    rate = course.success_rate(dep, ok)
    assert rate.shape == (5, 7) and rate[:, 3].tolist() == [1.0] * 5 and rate.sum() == 5


def test_eval_course_is_fixed_and_checks_kinds():
    a, b = EvalCourse(), EvalCourse()
    assert np.array_equal(a.terrain.field.heights, b.terrain.field.heights)
    with pytest.raises(ValueError, match="kinds"):
        EvalCourseConfig(kinds=("stairs", "slopes"))
