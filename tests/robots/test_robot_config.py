"""RobotConfig (robots/robot_config.py) on the Adam Lite: gains by joint name, the left-right mirror."""

import pytest

from robots.adam_lite import ADAM_LITE


def test_with_gains_sets_both_sides_and_names_unknown_joints():
    stiff = ADAM_LITE.with_gains({"ankleRoll": (40.0, 1.0), "kneePitch_Left": (400.0, 8.0)})
    for side in ("Left", "Right"):
        i = ADAM_LITE.joint_names.index(f"ankleRoll_{side}")
        assert (stiff.kp[i], stiff.kd[i]) == (40.0, 1.0) != (ADAM_LITE.kp[i], ADAM_LITE.kd[i])
    left, right = (ADAM_LITE.joint_names.index(f"kneePitch_{s}") for s in ("Left", "Right"))
    assert (stiff.kp[left], stiff.kp[right]) == (400.0, ADAM_LITE.kp[right])
    with pytest.raises(ValueError, match="'ankle' names no driven joint"):
        ADAM_LITE.with_gains({"ankle": (1.0, 1.0)})


def test_mirror_map_is_the_robots_left_right_symmetry():
    """Joint angles mirrored by RobotConfig.mirror_joints put every link where the mirror image (y -> -y) of the
    original pose has it, position and orientation, for random poses: the map is the robot's own symmetry."""
    import torch

    from cra_warp.kinematics import Kinematics

    kin = Kinematics(ADAM_LITE)
    index, sign = ADAM_LITE.mirror_joints()
    links = kin.chain.get_frame_names()
    other = [links.index(n.replace("Left", "#").replace("Right", "Left").replace("#", "Right")) for n in links]
    g = torch.Generator().manual_seed(0)
    q = 0.6 * (2 * torch.rand(16, ADAM_LITE.num_joints, generator=g) - 1)
    q_mirror = q[:, index] * torch.tensor(sign)
    base, quat = torch.zeros(16, 3), torch.tensor([[0.0, 0.0, 0.0, 1.0]]).expand(16, 4)
    pos, rot = kin.link_frames(base, quat, q, links)
    pos_m, rot_m = kin.link_frames(base, quat, q_mirror, links)
    M = torch.diag(torch.tensor([1.0, -1.0, 1.0]))
    assert torch.allclose(pos_m[:, other], pos @ M, atol=2e-3)
    assert torch.allclose(rot_m[:, other], M @ rot @ M, atol=1e-3)
    # and a wrong sign is caught: ankle roll kept instead of negated
    bad = list(sign)
    bad[ADAM_LITE.joint_names.index("ankleRoll_Left")] = 1.0
    _, rot_bad = kin.link_frames(base, quat, q[:, index] * torch.tensor(bad), links)
    assert not torch.allclose(rot_bad[:, other], M @ rot @ M, atol=1e-3)
