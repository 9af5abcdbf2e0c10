"""Root motion for cycles: in place, forward at the keys' speed, or as interpolated."""

import numpy as np
import pytest

from gaitcore import GaitInputError
from gaitcore.animation.root_motion import (
    apply_root_motion,
    horizontal_root_channels,
    key_velocity,
)
from gaitcore.bench.gaits import GAITS, generate_gait
from gaitcore.rig.templates import load_template


@pytest.fixture(scope="module")
def walk():
    horse = load_template("horse")
    return horse, generate_gait(horse, "walk", 100)


def _keys(poses, frames):
    return {f: poses[f] for f in frames}


def test_horizontal_channels_are_found_by_name():
    names = ("root.tx", "root.ty", "root.tz", "root.rz", "neck.rz")
    assert horizontal_root_channels(names).tolist() == [0, 2]
    assert horizontal_root_channels(("a.rz",)).size == 0


@pytest.mark.parametrize("gait", ["walk", "canter"])
def test_forward_speed_from_keys_is_within_two_percent(gait):
    horse = load_template("horse")
    truth = generate_gait(horse, gait, 100)
    spec = GAITS[gait]
    # four keys spread through one cycle, as the key selection spreads them
    frames = [round(spec.period_frames * (i + 0.5) / 4) + 7 for i in range(4)]
    channels = horizontal_root_channels(horse.channel_names)
    speed = key_velocity(_keys(truth, frames), channels)[0]
    assert speed == pytest.approx(spec.stride_m / spec.period_frames, rel=0.02)


def test_forward_is_constant_velocity_and_keeps_the_bounce(walk):
    horse, truth = walk
    curves = truth.copy()
    tx = horse.channel_index("root.tx")
    curves[:, tx] = truth[:, tx] % 1.6  # the periodic (jumping) root an interpolation gives
    out = apply_root_motion(curves, horse.channel_names, "forward",
                            key_poses=_keys(truth, (3, 12, 23, 32)))
    steps = np.diff(out[:, tx])
    assert np.ptp(steps) < 1e-12 and steps[0] > 0
    ty = horse.channel_index("root.ty")
    assert np.array_equal(out[:, ty], curves[:, ty])
    rest = [i for i in range(horse.n_channels)
            if i not in horizontal_root_channels(horse.channel_names)]
    assert np.array_equal(out[:, rest], curves[:, rest])


def test_in_place_has_no_horizontal_motion(walk):
    horse, truth = walk
    out = apply_root_motion(truth, horse.channel_names, "in-place",
                            key_poses=_keys(truth, (3, 12, 23, 32)))
    channels = horizontal_root_channels(horse.channel_names)
    assert np.all(np.diff(out[:, channels], axis=0) == 0.0)


def test_a_loop_moves_on_from_its_clip_frames(walk):
    horse, truth = walk
    keys = _keys(truth, (3, 12, 23, 32))
    whole = apply_root_motion(truth, horse.channel_names, "forward", key_poses=keys)
    loop = apply_root_motion(truth[30:70], horse.channel_names, "forward", key_poses=keys,
                             frames=np.arange(30, 70))
    assert np.allclose(loop, whole[30:70])


def test_as_keys_changes_nothing_and_bad_modes_are_refused(walk):
    horse, truth = walk
    keys = _keys(truth, (3, 12))
    assert np.array_equal(apply_root_motion(truth, horse.channel_names, "as-keys",
                                            key_poses=keys), truth)
    with pytest.raises(GaitInputError, match="unknown root motion"):
        apply_root_motion(truth, horse.channel_names, "sideways", key_poses=keys)
    with pytest.raises(GaitInputError, match="at least two posed frames"):
        apply_root_motion(truth, horse.channel_names, "forward", key_poses=_keys(truth, (3,)))
