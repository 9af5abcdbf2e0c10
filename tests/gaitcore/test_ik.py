"""Inverse kinematics: reachable targets are reached, limits hold, unreachable gives closest."""

import numpy as np
import pytest

from gaitcore import GaitInputError
from gaitcore.rig.ik import leg_joints, solve_chain, solve_leg
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template


def _arm(knee_limits=None) -> Skeleton:
    """A planar two-bone arm along -Y: hip at the origin, bones of 1 m, a 1 m foot."""
    knee = {"name": "knee", "parent": "hip", "offset": [0, -1, 0], "channels": ["rz", "rx", "ry"]}
    if knee_limits:
        knee["limits"] = {"rz": knee_limits}
    return Skeleton.from_json({"format": "gaitstudio-skeleton", "version": 1, "joints": [
        {"name": "hip", "parent": None, "offset": [0, 0, 0], "channels": ["rz", "rx", "ry"]},
        knee,
        {"name": "ankle", "parent": "knee", "offset": [0, -1, 0], "channels": ["rz"]},
        {"name": "toe", "parent": "ankle", "offset": [0.3, 0, 0], "channels": []},
    ]})


def _random_poses(skeleton: Skeleton, n: int, seed: int) -> np.ndarray:
    lim = np.clip(skeleton.limits_array(), -60, 60)
    rng = np.random.default_rng(seed)
    poses = rng.uniform(lim[:, 0], lim[:, 1], size=(n, skeleton.n_channels))
    poses[:, [skeleton.channel_index(f"root.t{a}") for a in "xyz"]] = 0.0
    return poses


def test_two_bone_reaches_exact_bend():
    arm = _arm()
    target = np.array([1.0, -1.0, 0.0])  # needs a right angle at the knee
    result = solve_leg(arm, arm.rest_pose(), "ankle", target, upper_joint="hip", knee_joint="knee")
    assert result.reached
    bend = result.pose[arm.channel_index("knee.rz")]
    assert abs(abs(bend) - 90.0) < 1e-6
    assert np.allclose(arm.joint_positions(result.pose)[2], target, atol=1e-6)


def test_foot_keeps_its_world_orientation():
    arm = _arm()
    target = np.array([0.6, -1.5, 0.0])
    result = solve_leg(arm, arm.rest_pose(), "toe", target, upper_joint="hip",
                       knee_joint="knee", foot_joint="ankle")
    world = arm.forward_kinematics(result.pose)
    assert result.reached
    assert np.allclose(world[2, :3, :3], np.eye(3), atol=1e-6)  # ankle as level as at rest


@pytest.mark.parametrize("end", ["L_fore_toe", "R_hind_toe"])
def test_reachable_targets_are_reached_on_the_horse(end):
    horse = load_template("horse")
    upper, knee = leg_joints(horse, end)
    leg = [j for j in range(horse.n_joints) if j >= upper and j <= horse.joint_index(end)
           and horse.joints[j].side == horse.joints[horse.joint_index(end)].side]
    chans = [i for i, n in enumerate(horse.channel_names)
             if horse.joint_index(n.rsplit(".", 1)[0]) in leg]
    bends = [horse.channel_index(f"{horse.joints[j].name}.rz") for j in (upper, knee)]
    start, lim = horse.rest_pose(), horse.limits_array()
    rng = np.random.default_rng(1)
    for pose in _random_poses(horse, 6, seed=1):
        whole_leg, two_bones = start.copy(), start.copy()
        whole_leg[chans] = pose[chans]  # any pose of this leg within its limits
        two_bones[bends] = rng.uniform(lim[bends, 0], lim[bends, 1]) / 2
        for wanted, solve in ((whole_leg, lambda t: solve_chain(
                horse, start, end, t, root_joint=horse.joints[upper].name, iterations=60)),
                              (two_bones, lambda t: solve_leg(horse, start, end, t))):
            target = horse.joint_positions(wanted)[horse.joint_index(end)]
            result = solve(target)
            reached = horse.joint_positions(result.pose)[horse.joint_index(end)]
            assert result.error_m == pytest.approx(np.linalg.norm(reached - target))
            assert result.reached


def test_limits_hold_whatever_the_target():
    horse = load_template("horse")
    lim = horse.limits_array()
    rng = np.random.default_rng(3)
    toe = horse.joint_positions(horse.rest_pose())[horse.joint_index("L_hind_toe")]
    for offset in rng.normal(0.0, 0.6, size=(8, 3)):
        for result in (solve_leg(horse, horse.rest_pose(), "L_hind_toe", toe + offset,
                                 foot_joint="L_hind_hoof"),
                       solve_chain(horse, horse.rest_pose(), "L_hind_toe", toe + offset,
                                   root_joint="L_hip", foot_joint="L_hind_hoof")):
            assert np.all(result.pose >= lim[:, 0] - 1e-9)
            assert np.all(result.pose <= lim[:, 1] + 1e-9)


def test_unreachable_target_gives_the_closest_pose():
    arm = _arm()
    far = np.array([3.0, 0.0, 0.0])  # 3 m away, the arm reaches 2 m
    for result in (solve_leg(arm, arm.rest_pose(), "ankle", far, upper_joint="hip",
                             knee_joint="knee"),
                   solve_chain(arm, arm.rest_pose(), "ankle", far, root_joint="hip")):
        assert not result.reached
        assert result.error_m == pytest.approx(1.0, abs=5e-3)  # stretched straight at it


def test_knee_limit_stops_the_bend_short():
    arm = _arm(knee_limits=[0.0, 45.0])
    near = np.array([0.0, -0.5, 0.0])  # would need the knee folded far past 45 deg
    result = solve_leg(arm, arm.rest_pose(), "ankle", near, upper_joint="hip", knee_joint="knee")
    assert not result.reached
    assert result.pose[arm.channel_index("knee.rz")] in (0.0, 45.0)
    bent = arm.rest_pose()
    bent[arm.channel_index("knee.rz")] = 45.0
    best = np.linalg.norm(arm.joint_positions(bent)[2]) - 0.5  # closest the limit allows
    assert result.error_m == pytest.approx(best, abs=1e-3)


def test_chain_solver_bends_a_tail():
    horse = load_template("horse")
    rest = horse.joint_positions(horse.rest_pose())
    target = rest[horse.joint_index("tail_end")] + [0.1, 0.15, 0.1]
    result = solve_chain(horse, horse.rest_pose(), "tail_end", target, root_joint="tail1")
    assert result.reached
    changed = [n for n, a, b in zip(horse.channel_names, result.pose, horse.rest_pose()) if a != b]
    assert changed and all(n.startswith("tail") for n in changed)


def test_bad_arguments_say_what_is_wrong():
    arm = _arm()
    with pytest.raises(GaitInputError, match="three finite numbers"):
        solve_leg(arm, arm.rest_pose(), "ankle", [0, np.nan, 0], upper_joint="hip",
                  knee_joint="knee")
    with pytest.raises(GaitInputError, match="between"):
        solve_leg(arm, arm.rest_pose(), "ankle", [0, -1, 0], upper_joint="knee",
                  knee_joint="hip")
    with pytest.raises(GaitInputError, match="not above"):
        solve_chain(arm, arm.rest_pose(), "knee", [0, -1, 0], root_joint="toe")
