"""Ground contact clean-up: planted stance, nothing under the ground, little else changed."""

import numpy as np
import pytest

from gaitcore import GaitInputError
from gaitcore.bench.gaits import GAITS, generate_gait, stance_mask
from gaitcore.progress import Cancelled
from gaitcore.rig.contact import ContactSettings, clean_ground_contact, find_feet
from gaitcore.rig.templates import load_template

FRAMES = 60


@pytest.fixture(scope="module")
def horse():
    return load_template("horse")


def _in_place(horse, gait):
    """True poses held in place, and the travel that puts them back on their way."""
    poses = generate_gait(horse, gait, FRAMES)
    tx = horse.channel_index("root.tx")
    travel = np.zeros((FRAMES, 3))
    travel[:, 0] = poses[:, tx] - poses[0, tx]
    poses[:, tx] = poses[0, tx]
    return poses, travel


def _spoil(horse, poses, seed):
    """What interpolation does to legs: they sink (a lower trunk) and drift (hip and
    shoulder angles off by a slow wobble)."""
    rng = np.random.default_rng(seed)
    out = poses.copy()
    out[:, horse.channel_index("root.ty")] -= 0.05
    t = np.arange(len(poses))
    for name in ("L_hip", "R_hip", "L_shoulder", "R_shoulder"):
        out[:, horse.channel_index(f"{name}.rz")] += 6 * np.sin(t / 3.0 + rng.uniform(0, 6))
    return out


def _slip_and_lowest(horse, poses, travel, gait):
    feet = find_feet(horse)
    pos = horse.joint_positions(poses) + travel[:, None, :]
    stance = stance_mask(gait, len(poses))
    slip = 0.0
    for foot in feet:
        limb = foot[0] + ("F" if "fore" in foot else "H")
        both = stance[limb][1:] & stance[limb][:-1]
        step = np.linalg.norm(np.diff(pos[:, horse.joint_index(foot)][:, [0, 2]], axis=0), axis=1)
        slip = max(slip, step[both].max(initial=0.0))
    heels = [horse.joint_index(horse.joints[horse.joint_index(f)].parent) for f in feet]
    lowest = pos[:, [horse.joint_index(f) for f in feet] + heels, 1].min()
    return slip, lowest


def test_feet_are_the_four_toes(horse):
    assert sorted(find_feet(horse)) == ["L_fore_toe", "L_hind_toe", "R_fore_toe", "R_hind_toe"]


@pytest.mark.parametrize("gait", ["walk", "canter"])
def test_spoiled_legs_are_planted_and_lifted_out_of_the_ground(horse, gait):
    truth, travel = _in_place(horse, gait)
    spoiled = _spoil(horse, truth, seed=2)
    slip0, low0 = _slip_and_lowest(horse, spoiled, travel, gait)
    assert slip0 > 0.02 and low0 < -0.03  # the test can fail: the spoiled legs skate and sink
    result = clean_ground_contact(horse, spoiled, travel_m=travel)
    slip, low = _slip_and_lowest(horse, result.poses, travel, gait)
    assert low > -0.005
    assert slip <= 0.01
    legs = [i for i, n in enumerate(horse.channel_names) if n[:2] in ("L_", "R_")]
    height = horse.channel_index("root.ty")
    others = [i for i in range(horse.n_channels) if i not in legs and i != height]
    assert np.array_equal(result.poses[:, others], spoiled[:, others])
    # where the legs reach, the body's height keeps the lowest foot on the ground: a nudge
    assert result.body_shift_m < 0.01
    truth_stance = stance_mask(gait, FRAMES)
    for i, foot in enumerate(find_feet(horse)):
        limb = foot[0] + ("F" if "fore" in foot else "H")
        assert np.mean(result.stance[:, i] == truth_stance[limb]) > 0.8
        report = result.feet[i]
        assert report.name == foot and report.max_shift_m > 0 and report.lowest_after_m > -0.005
    assert "moved up to" in result.summary()


def test_a_stance_holding_a_posed_frame_is_planted_where_the_pose_put_the_foot(horse):
    truth, travel = _in_place(horse, "canter")
    spoiled = _spoil(horse, truth, seed=5)
    spoiled[:, horse.channel_index("R_shoulder.rz")] += 5.0  # the foot lands off its true spot
    toe = horse.joint_index("R_fore_toe")
    stance = stance_mask("canter", FRAMES)["RF"]
    key = int(np.flatnonzero(stance)[3])
    spoiled[key] = truth[key]  # the interpolation is exact at a key
    result = clean_ground_contact(horse, spoiled, travel_m=travel, anchors=[key])
    planted = horse.joint_positions(result.poses)[:, toe] + travel
    spot = horse.joint_positions(truth[key])[toe] + travel[key]
    run = [t for t in range(key - 2, key + 3) if result.stance[t, 0]]
    np.testing.assert_allclose(planted[run][:, [0, 2]], np.tile(spot[[0, 2]], (len(run), 1)),
                               atol=2e-3)
    free = clean_ground_contact(horse, spoiled, travel_m=travel)
    assert np.abs(horse.joint_positions(free.poses)[key, toe] + travel[key] - spot)[0] > 2e-3


def test_a_body_too_high_is_brought_down_until_a_foot_stands(horse):
    truth, travel = _in_place(horse, "walk")
    high = truth.copy()
    high[:, horse.channel_index("root.ty")] += 0.2  # the legs cannot reach the ground
    result = clean_ground_contact(horse, high, travel_m=travel)
    feet = [horse.joint_index(f) for f in find_feet(horse)]
    lowest = horse.joint_positions(result.poses)[:, feet, 1].min(axis=1)
    ground = horse.joint_positions(horse.rest_pose())[feet, 1].min()
    stance = result.stance.any(axis=1)
    assert stance.mean() > 0.9  # a walk: a foot on the ground at every moment
    np.testing.assert_allclose(lowest[stance], ground, atol=1e-9)
    assert lowest.min() >= ground - 1e-9
    assert 0.0 < result.body_shift_m <= 0.2 + 1e-9  # the straightened legs reach part of it
    assert "body height changed by up to" in result.summary()


def test_true_motion_is_nearly_untouched(horse):
    """The synthetic hooves are planted in the side view only: as the trunk rolls and yaws
    they slide sideways (up to 2.5 cm a frame). Planting them moves them sideways, little else."""
    truth, travel = _in_place(horse, "canter")
    result = clean_ground_contact(horse, truth, travel_m=travel)
    change = np.abs(result.poses - truth)[:, horse.sagittal_angle_indices]
    assert change.mean() < 1.0
    feet = [horse.joint_index(f) for f in find_feet(horse)]
    moved = horse.joint_positions(result.poses)[:, feet] - horse.joint_positions(truth)[:, feet]
    assert np.abs(moved[..., :2]).max() < 0.05  # along the travel and up: within 5 cm


def test_a_cycle_stays_a_cycle(horse):
    period = GAITS["canter"].period_frames
    truth, travel = _in_place(horse, "canter")
    cycle = _spoil(horse, truth[:period], seed=4)
    cycle = np.concatenate([cycle, cycle])[:period]  # exactly periodic input
    result = clean_ground_contact(horse, cycle, travel_m=travel[:period], cyclic=True)
    pos = horse.joint_positions(result.poses)
    wrap = np.linalg.norm(pos[0] - pos[-1], axis=1).max()
    inner = np.linalg.norm(np.diff(pos, axis=0), axis=2).max()
    assert wrap <= 1.1 * inner  # the step from the last frame to the first is an ordinary one
    alone = clean_ground_contact(horse, cycle, travel_m=travel[:period])
    assert not np.allclose(alone.poses, result.poses)  # the ends were cleaned as a loop


def test_settings_are_checked_and_cancel_works(horse):
    with pytest.raises(GaitInputError):
        ContactSettings(height_m=-1.0)
    truth, travel = _in_place(horse, "walk")
    with pytest.raises(Cancelled):
        clean_ground_contact(horse, truth, travel_m=travel, progress=lambda done, total: done < 3)


def test_a_foot_that_floats_is_brought_down_in_stance(horse):
    poses, travel = _in_place(horse, "walk")
    floating = poses.copy()
    floating[:, horse.channel_index("root.ty")] += 0.06  # above the 4 cm a foot counts low
    feet = find_feet(horse)
    index = [horse.joint_index(f) for f in feet]
    ground = horse.joint_positions(horse.rest_pose())[index, 1].min()
    lifted = horse.joint_positions(floating)[:, index, 1] - ground
    assert lifted.min() > 0.05  # every hoof above the ground all along
    result = clean_ground_contact(horse, floating, travel_m=travel)
    pos = horse.joint_positions(result.poses) + travel[:, None, :]
    for i, foot in enumerate(feet):
        stance = result.stance[:, i]
        assert stance.sum() >= 20, foot  # the old rule (4 cm of the ground) found none
        heights = pos[stance, horse.joint_index(foot), 1] - ground
        assert np.median(np.abs(heights)) < 0.001 and heights.min() > -0.005, foot
        # a leg whose body rides high cannot reach down at touch-down: said, not hidden
        assert (np.abs(heights) < 0.01).mean() > 0.75, (foot, np.round(heights, 3))
        assert result.feet[i].worst_miss_m >= np.abs(heights).max() - 1e-6
    assert result.summary().startswith("ground contact: 4 feet planted")


def test_the_summary_says_which_feet_never_touch_down(horse):
    poses, travel = _in_place(horse, "walk")
    lifted = poses.copy()
    for name in ("L_shoulder", "R_shoulder"):  # both forelegs swung up all the time
        lifted[:, horse.channel_index(f"{name}.rz")] = 80.0
    result = clean_ground_contact(horse, lifted, travel_m=travel,
                                  settings=ContactSettings(speed_ratio=0.0, min_speed_m=0.0))
    never = [r.name for r in result.feet if r.stance_frames == 0]
    assert never and all(name in result.summary() for name in never)
    assert f"of {len(result.feet)} feet planted" in result.summary()
