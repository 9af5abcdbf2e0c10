"""The export step: loop, root motion and ground contact together, as every exporter gets them."""

import numpy as np
import pytest

from gaitcore import GaitInputError
from gaitcore.bench.gaits import GAITS, generate_gait
from gaitcore.io.motion import export_motion
from gaitcore.rig.templates import load_template

FRAMES = 40


@pytest.fixture(scope="module")
def canter():
    """True canter poses with the root.tx an interpolation gives: periodic, jumping back."""
    horse = load_template("horse")
    truth = generate_gait(horse, "canter", FRAMES)
    curves = truth.copy()
    tx = horse.channel_index("root.tx")
    curves[:, tx] = truth[:, tx] % GAITS["canter"].stride_m
    keys = {f: truth[f] for f in (3, 10, 17, 24)}
    return horse, curves, keys


def test_whole_clip_goes_forward_with_feet_planted(canter):
    horse, curves, keys = canter
    motion = export_motion(curves, horse.channel_names, key_poses=keys, skeleton=horse)
    tx = motion.poses[:, horse.channel_index("root.tx")]
    assert motion.root_motion == "forward" and motion.cycle_start is None
    assert np.ptp(np.diff(tx)) < 1e-12 and np.diff(tx).min() > 0
    assert motion.contact is not None and len(motion.contact.feet) == 4
    toes = [horse.joint_index(f.name) for f in motion.contact.feet]
    assert horse.joint_positions(motion.poses)[:, toes, 1].min() > -0.005
    assert "root forward" in motion.summary() and "moved up to" in motion.summary()


def test_a_loop_is_in_place_and_closes_on_its_first_frame(canter):
    horse, curves, keys = canter
    motion = export_motion(curves, horse.channel_names, key_poses=keys, skeleton=horse,
                           loop=True, period_frames=28.0)
    assert motion.root_motion == "in-place" and len(motion.frames) == 29
    np.testing.assert_array_equal(motion.poses[-1], motion.poses[0])
    assert np.array_equal(motion.frames, np.arange(29))


def test_a_forward_loop_closes_one_stride_ahead(canter):
    horse, curves, keys = canter
    motion = export_motion(curves, horse.channel_names, key_poses=keys, skeleton=horse,
                           loop=True, period_frames=28.0, root_motion="forward",
                           ground_contact=False)
    tx = horse.channel_index("root.tx")
    steps = np.diff(motion.poses[:, tx])
    assert np.ptp(steps) < 1e-12  # the closing frame is one more ordinary step
    rest = [i for i in range(horse.n_channels) if i not in (tx, horse.channel_index("root.tz"))]
    np.testing.assert_array_equal(motion.poses[-1, rest], motion.poses[0, rest])


def test_the_root_follows_the_footage_where_the_animal_crosses_the_view(canter):
    horse, curves, keys = canter
    truth_tx = generate_gait(horse, "canter", FRAMES)[:, horse.channel_index("root.tx")]
    surge = 0.02 * np.sin(np.arange(FRAMES) / 3.0)  # the track is not a straight line
    travel = truth_tx - truth_tx[0] + surge
    rooted = {f: np.where(np.arange(horse.n_channels) == horse.channel_index("root.tx"), 0.0, p)
              for f, p in keys.items()}  # hoof drags never set the root
    motion = export_motion(curves, horse.channel_names, key_poses=rooted, skeleton=horse,
                           travel_m=travel)
    tx = motion.poses[:, horse.channel_index("root.tx")]
    assert motion.root_motion == "footage" and motion.speed_source == "footage"
    np.testing.assert_allclose(np.diff(tx), np.diff(travel), atol=1e-9)
    assert "from the footage" in motion.summary() and motion.warning is None
    toes = [horse.joint_index(f.name) for f in motion.contact.feet]
    assert horse.joint_positions(motion.poses)[:, toes, 1].min() > -0.005
    loop = export_motion(curves, horse.channel_names, key_poses=rooted, skeleton=horse,
                         loop=True, period_frames=28.0, root_motion="footage", travel_m=travel)
    steps = np.diff(loop.poses[:, horse.channel_index("root.tx")])
    assert np.ptp(steps) < 1e-12 and steps[0] == pytest.approx(np.polyfit(
        np.arange(FRAMES), travel, 1)[0])  # a loop goes at the footage's mean speed


def test_a_speed_given_wins_and_a_root_that_cannot_travel_is_said(canter):
    horse, curves, keys = canter
    rooted = {f: np.where(np.arange(horse.n_channels) == horse.channel_index("root.tx"), 0.0, p)
              for f, p in keys.items()}
    still = export_motion(curves, horse.channel_names, key_poses=rooted, skeleton=horse)
    assert still.root_motion == "forward" and "the footage shows none" in still.warning
    given = export_motion(curves, horse.channel_names, key_poses=rooted, skeleton=horse,
                          speed_m=0.1, travel_m=np.zeros(FRAMES), root_motion="forward")
    assert np.diff(given.poses[:, horse.channel_index("root.tx")]) == pytest.approx(0.1)
    assert given.speed_source == "given" and given.warning is None
    with pytest.raises(GaitInputError, match="no travel"):
        export_motion(curves, horse.channel_names, key_poses=keys, root_motion="footage")


def test_as_keys_without_contact_is_the_interpolation(canter):
    horse, curves, keys = canter
    motion = export_motion(curves, horse.channel_names, key_poses=keys, skeleton=horse,
                           root_motion="as-keys", ground_contact=False)
    np.testing.assert_array_equal(motion.poses, curves)
    assert motion.contact is None


def test_columns_in_another_order_and_without_a_skeleton(canter):
    horse, curves, keys = canter
    order = np.random.default_rng(0).permutation(horse.n_channels)
    names = [horse.channel_names[i] for i in order]
    shuffled = export_motion(curves[:, order], names, skeleton=horse,
                             key_poses={f: p[order] for f, p in keys.items()})
    plain = export_motion(curves, horse.channel_names, key_poses=keys, skeleton=horse)
    np.testing.assert_allclose(shuffled.poses, plain.poses[:, order], atol=1e-9)
    bare = export_motion(curves, horse.channel_names, key_poses=keys)
    assert bare.contact is None and bare.root_motion == "forward"


def test_bad_requests_are_refused(canter):
    horse, curves, keys = canter
    with pytest.raises(GaitInputError, match="root motion"):
        export_motion(curves, horse.channel_names, key_poses=keys, root_motion="up")
    with pytest.raises(GaitInputError, match="period"):
        export_motion(curves, horse.channel_names, key_poses=keys, loop=True)
    with pytest.raises(GaitInputError, match="lack"):
        export_motion(curves[:, 1:], horse.channel_names[1:], key_poses=keys, skeleton=horse)
