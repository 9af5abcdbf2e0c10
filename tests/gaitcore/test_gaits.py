"""Synthetic gaits: periodicity, footfall order, ground contact, determinism, realism checks."""

from __future__ import annotations

import numpy as np
import pytest

from gaitcore.bench import GAITS, generate_gait
from gaitcore.errors import GaitInputError
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template

TOES = {"LH": "L_hind_toe", "LF": "L_fore_toe", "RH": "R_hind_toe", "RF": "R_fore_toe"}
FINE = 100  # frames per cycle for timing measurements


@pytest.fixture(scope="module")
def horse() -> Skeleton:
    return load_template("horse")


def _contacts(horse, gait, period=FINE, cycles=2):
    """Per limb: bool array, hoof planted (toe low and not sliding)."""
    poses = generate_gait(horse, gait, cycles * period + 1, period_frames=period)
    pos = horse.joint_positions(poses)
    out, heights = {}, {}
    for limb, toe in TOES.items():
        x, y = pos[:, horse.joint_index(toe), 0], pos[:, horse.joint_index(toe), 1]
        out[limb] = (y < 0.015) & (np.abs(np.gradient(x)) < 0.002 * GAITS[gait].stride_m)
        heights[limb] = y
    return out, heights


def _touchdown_phases(contacts, period=FINE):
    phases = {}
    for limb, on in contacts.items():
        downs = np.flatnonzero(on[1:] & ~on[:-1]) + 1
        phases[limb] = (downs[0] / period) % 1.0
    return phases


@pytest.mark.parametrize("gait", list(GAITS))
def test_gait_is_periodic_and_travels(horse, gait):
    period = GAITS[gait].period_frames
    assert 20 <= period <= 40
    poses = generate_gait(horse, gait, 2 * period)
    assert poses.shape == (2 * period, horse.n_channels)
    assert np.all(np.isfinite(poses))
    tx = horse.channel_index("root.tx")
    rest = np.delete(np.arange(horse.n_channels), tx)
    np.testing.assert_allclose(poses[period:, rest], poses[:period, rest], atol=1e-8)
    np.testing.assert_allclose(poses[period:, tx] - poses[:period, tx], GAITS[gait].stride_m)
    assert np.ptp(poses[:, horse.channel_index("root.ty")]) > 0.02  # the body bobs
    for ch in ("root.rz", "root.rx", "root.ry", "root.tz", "neck1.rz", "tail1.rx"):
        assert np.ptp(poses[:, horse.channel_index(ch)]) > 0.01, ch


@pytest.mark.parametrize(
    ("gait", "order"),
    [
        ("walk", ["LH", "LF", "RH", "RF"]),  # lateral sequence
        ("canter", ["RH", "LH", "RF", "LF"]),  # left lead: RH, then LH with RF, then LF
        ("gallop", ["RH", "LH", "RF", "LF"]),  # transverse, left lead
    ],
)
def test_footfall_order(horse, gait, order):
    phases = _touchdown_phases(_contacts(horse, gait)[0])
    start = phases[order[0]]
    rel = [((phases[limb] - start) % 1.0) for limb in order]
    assert rel == sorted(rel), (phases, order)
    for limb in order:  # measured touchdown within 0.05 cycle of the gait diagram
        want = GAITS[gait].footfalls[limb]
        assert abs((phases[limb] - want + 0.5) % 1.0 - 0.5) < 0.05, (limb, phases[limb], want)


def test_walk_beats_are_a_quarter_cycle_apart(horse):
    phases = _touchdown_phases(_contacts(horse, "walk")[0])
    seq = [phases[k] for k in ("LH", "LF", "RH", "RF")]
    gaps = np.diff(np.unwrap(np.array(seq) * 2 * np.pi)) / (2 * np.pi) % 1.0
    np.testing.assert_allclose(gaps, 0.25, atol=0.03)


def test_trot_moves_diagonal_pairs_together(horse):
    phases = _touchdown_phases(_contacts(horse, "trot")[0])
    assert abs(phases["LH"] - phases["RF"]) < 0.02
    assert abs(phases["RH"] - phases["LF"]) < 0.02
    assert abs((phases["RH"] - phases["LH"]) % 1.0 - 0.5) < 0.03


@pytest.mark.parametrize("gait", list(GAITS))
def test_hooves_touch_the_ground_in_stance_and_lift_in_swing(horse, gait):
    contacts, heights = _contacts(horse, gait)
    spec = GAITS[gait]
    for limb, on in contacts.items():
        y = heights[limb]
        assert y.min() > -0.005  # never through the ground
        assert abs(on[:FINE].mean() - spec.duty_factor) < 0.08  # duty factor
        assert np.median(y[on]) < 0.01  # planted
        assert y.max() > 0.08  # and lifted in swing
    any_down = np.any(np.stack(list(contacts.values())), axis=0)
    if gait == "walk":
        assert any_down.all()  # no suspension
    else:
        assert (~any_down).sum() >= 2  # a flight phase


def test_walk_half_cycles_are_mirror_images(horse):
    """The paper's ambiguity: half a walk cycle later the pose is the left/right mirror."""
    p = GAITS["walk"].period_frames
    poses = generate_gait(horse, "walk", p + p // 2)
    rz = horse.sagittal_angle_indices
    later, now = poses[p // 2: p // 2 + p][:, rz], poses[:p][:, rz]
    assert np.mean(np.abs(horse.mirror_pose(poses[:p])[:, rz] - later)) < 2.0
    assert np.mean(np.abs(now - later)) > 8.0


def test_limb_curves_are_not_pure_sinusoids(horse):
    poses = generate_gait(horse, "trot", FINE, period_frames=FINE)
    for joint in ("R_carpus", "R_hock", "R_fore_fetlock"):
        c = poses[:, horse.channel_index(f"{joint}.rz")]
        power = np.abs(np.fft.rfft(c - c.mean())) ** 2
        assert power[2:].sum() / power[1:].sum() > 0.1, joint


@pytest.mark.parametrize("gait", list(GAITS))
def test_gaits_stay_within_joint_limits(horse, gait):
    poses = generate_gait(horse, gait, 3 * FINE // 2, period_frames=FINE, phase=0.3)
    lim = horse.limits_array()
    assert np.all(poses >= lim[:, 0] - 1e-9) and np.all(poses <= lim[:, 1] + 1e-9)


def test_noise_is_seeded(horse):
    a = generate_gait(horse, "walk", 12, noise_deg=1.0, seed=7)
    b = generate_gait(horse, "walk", 12, noise_deg=1.0, seed=7)
    c = generate_gait(horse, "walk", 12, noise_deg=1.0, seed=8)
    clean = generate_gait(horse, "walk", 12)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    rz = horse.sagittal_angle_indices
    assert 0.7 < np.std(a[:, rz] - clean[:, rz]) < 1.3
    tx = horse.channel_index("root.tx")
    np.testing.assert_array_equal(a[:, tx], clean[:, tx])  # translations stay exact
    np.testing.assert_array_equal(generate_gait(horse, "walk", 12), clean)


def test_period_phase_and_lead(horse):
    p = generate_gait(horse, "gallop", 60, period_frames=30)
    np.testing.assert_allclose(p[30:, 6:], p[:30, 6:], atol=1e-8)
    shifted = generate_gait(horse, "gallop", 10, period_frames=30, phase=5 / 30)
    np.testing.assert_allclose(shifted[:, 6:], p[5:15, 6:], atol=1e-8)
    right = generate_gait(horse, "canter", 10, lead="right")
    np.testing.assert_allclose(right, horse.mirror_pose(generate_gait(horse, "canter", 10)))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"gait": "amble"}, "unknown gait"),
        ({"n_frames": 0}, "n_frames"),
        ({"period_frames": 3}, "period"),
        ({"noise_deg": -1.0}, "noise"),
        ({"lead": "middle"}, "lead"),
    ],
)
def test_bad_arguments_are_rejected(horse, kwargs, message):
    args = {"gait": "walk", "n_frames": 10} | kwargs
    gait, n = args.pop("gait"), args.pop("n_frames")
    with pytest.raises(GaitInputError, match=message):
        generate_gait(horse, gait, n, **args)


def test_a_skeleton_without_horse_legs_is_rejected():
    tiny = Skeleton.from_json({
        "format": "gaitstudio-skeleton", "version": 1, "name": "stick",
        "joints": [{"name": "root", "parent": None, "offset": [0, 1, 0],
                    "channels": ["tx", "ty", "tz", "rz", "rx", "ry"]}],
    })
    with pytest.raises(GaitInputError, match="horse"):
        generate_gait(tiny, "walk", 5)
