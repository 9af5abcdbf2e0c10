"""Example-based drags: a pose library tells a dragged chain how to fold."""

from __future__ import annotations

import numpy as np
import pytest

from gaitcore.bench.evaluate import angle_error_deg
from gaitcore.bench.gait_library import SHIPPED_GAITS, gait_library, write_gait_library
from gaitcore.bench.gaits import generate_gait
from gaitcore.errors import GaitInputError
from gaitcore.project.document import Project
from gaitcore.project.steps import drag_library
from gaitcore.rig.pose_library import PoseLibrary, _chain_examples, shipped_library
from gaitcore.rig.posing import drag_end, effector_chain
from gaitcore.rig.proportions import RigProportions, proportioned
from gaitcore.rig.templates import load_template


@pytest.fixture(scope="module")
def horse():
    return load_template("horse")


def _channels(skeleton, chain):
    return [i for i, c in enumerate(skeleton.channel_names)
            if skeleton.joint_index(c.rsplit(".", 1)[0]) in chain and not c.startswith("root")]


def test_the_shipped_library_is_the_walk_trot_and_gallop_as_the_builder_writes_them():
    shipped, built = shipped_library(), gait_library(SHIPPED_GAITS)
    assert "canter" not in SHIPPED_GAITS
    assert shipped.channel_names == built.channel_names
    np.testing.assert_allclose(shipped.poses, built.poses, atol=1e-9)


def test_the_builder_regenerates_the_shipped_file_exactly(tmp_path):
    from importlib.resources import files

    written = tmp_path / "horse_gaits.csv"
    write_gait_library(written)
    shipped = files("gaitcore.resources") / "poses" / "horse_gaits.csv"
    assert written.read_text(encoding="utf-8") == shipped.read_text(encoding="utf-8")


def test_a_drag_to_where_an_example_puts_the_hoof_takes_that_examples_fold(horse):
    example = generate_gait(horse, "trot", 30)[15]  # the hoof 65 cm from its rest place
    library = PoseLibrary.of(horse, example[None], "one trot pose")
    end = horse.joint_index("L_hind_toe")
    chain = effector_chain(horse, end)
    target = horse.joint_positions(example)[end]
    leg = _channels(horse, chain)
    start = example.copy()
    start[leg] = 0.0  # the same trunk, the leg at rest
    posed = drag_end(horse, start, end, target, library=library)
    np.testing.assert_allclose(posed[leg], example[leg], atol=1e-6)
    plain = drag_end(horse, start, end, target)
    assert np.abs(plain[leg] - example[leg]).max() > 5  # the template folds otherwise


@pytest.mark.parametrize(("gait", "gain_deg"), [("trot", 1.0), ("canter", 1.0), ("gallop", 1.0),
                                               ("walk", -1.0)])
def test_a_library_of_other_gaits_folds_the_legs_closer_than_plain_ik(horse, gait, gain_deg):
    """Left out of the library, the trot, canter and gallop gain more than a degree on the
    legs; the walk, whose legs fold least, neither gains nor loses more than a degree."""
    library = gait_library([g for g in ("walk", "trot", "canter", "gallop") if g != gait],
                           frames_per_cycle=20)
    truth = generate_gait(horse, gait, 12, period_frames=12)
    idx = horse.sagittal_angle_indices
    legs = [n for n, i in enumerate(idx) if horse.channel_names[i][:2] in ("L_", "R_")]
    errors = {False: [], True: []}
    for pose in truth:
        xyz = horse.joint_positions(pose)
        for use in errors:
            posed = horse.rest_pose()
            posed[:3] = pose[:3]
            for name in ("L_fore_toe", "R_fore_toe", "L_hind_toe", "R_hind_toe"):
                j = horse.joint_index(name)
                target = [*xyz[j, :2], horse.joint_positions(posed)[j, 2]]
                posed = drag_end(horse, posed, j, target, library=library if use else None,
                                 min_gain_m_per_deg=0.0)  # to the closest reach
                # from the template's trunk a galloping hoof may lie a little out of reach
                assert np.linalg.norm(horse.joint_positions(posed)[j, :2] - xyz[j, :2]) < 0.03
            errors[use].append(angle_error_deg(posed[idx], pose[idx])[legs].mean())
    assert np.mean(errors[True]) < np.mean(errors[False]) - gain_deg


def test_a_drag_stays_within_limits_and_moves_only_its_chain(horse):
    library = shipped_library()
    end = horse.joint_index("tail_end")
    base = horse.rest_pose()
    target = horse.joint_positions(base)[end] + [0.25, 0.3, 0.0]
    posed = drag_end(horse, base, end, target, library=library)
    chain = effector_chain(horse, end)
    changed = {horse.joint_index(c.rsplit(".", 1)[0]) for c, a, b in
               zip(horse.channel_names, posed, base) if abs(a - b) > 1e-9}
    assert changed and changed <= set(chain)
    limits = horse.limits_array()
    assert np.all((posed >= limits[:, 0] - 1e-9) & (posed <= limits[:, 1] + 1e-9))


def test_a_proportioned_rig_uses_the_library_in_its_own_lengths(horse):
    rig = proportioned(horse, RigProportions(legs=1.2))
    example = generate_gait(horse, "gallop", 24)[5]
    library = PoseLibrary.of(horse, example[None], "one gallop pose")
    end = rig.joint_index("R_fore_toe")
    leg = _channels(rig, effector_chain(rig, end))
    start = example.copy()
    start[leg] = 0.0  # the same trunk, the leg at rest
    posed = drag_end(rig, start, end, rig.joint_positions(example)[end], library=library)
    np.testing.assert_allclose(posed[leg], example[leg], atol=1e-6)


def test_a_library_without_the_chains_channels_drags_as_plain_ik(horse):
    other = PoseLibrary(("wing.rz",), np.array([[10.0]]), "a bird")
    end = horse.joint_index("head_end")
    target = horse.joint_positions(horse.rest_pose())[end] + [0.1, -0.1, 0.0]
    np.testing.assert_array_equal(drag_end(horse, horse.rest_pose(), end, target, library=other),
                                  drag_end(horse, horse.rest_pose(), end, target))


def test_bad_libraries_are_refused():
    with pytest.raises(GaitInputError, match="one column per channel"):
        PoseLibrary(("a.rz", "b.rz"), np.zeros((3, 1)), "x")
    with pytest.raises(GaitInputError, match="finite"):
        PoseLibrary(("a.rz",), np.array([[np.inf]]), "x")


def test_the_drag_library_adds_the_projects_other_keys_not_the_one_posed(horse):
    a, b = np.full(horse.n_channels, 1.0), np.full(horse.n_channels, 2.0)
    project = Project(key_poses={3: tuple(a), 9: tuple(b), 12: (1.0, 2.0)})  # 12: another rig
    library = drag_library(project, horse, 9)
    shipped = shipped_library()
    assert len(library) == len(shipped) + 1
    row = library.poses[-1]
    np.testing.assert_array_equal(row[[library.channel_names.index(c)
                                       for c in horse.channel_names]], a)
    assert "1 other key" in library.source
    assert drag_library(Project(), horse, 9) is shipped


def test_examples_of_another_rig_are_no_examples_for_its_chains(horse):
    bird = PoseLibrary(("wing.rz",), np.array([[10.0]]), "a bird")
    example = generate_gait(horse, "gallop", 24)[5]
    library = bird.with_poses(horse, example[None], "one gallop pose")
    assert np.isnan(library.poses[0, 1:]).all() and np.isnan(library.poses[1, 0])
    end = horse.joint_index("L_fore_toe")
    leg = _channels(horse, effector_chain(horse, end))
    start = example.copy()
    start[leg] = 0.0
    posed = drag_end(horse, start, end, horse.joint_positions(example)[end], library=library)
    np.testing.assert_allclose(posed[leg], example[leg], atol=1e-6)
    _, angles, _, _ = _chain_examples(library, horse, effector_chain(horse, end), end)
    assert len(angles) == 1  # the bird's row is no example of a horse's leg


def test_a_tail_dragged_just_out_of_reach_keeps_its_curve_and_a_reachable_end_is_reached(horse):
    curved = horse.rest_pose()
    tail = [horse.channel_index(f"tail{i}.rz") for i in range(1, 5)]
    curved[tail] = [-20.0, -10.0, -5.0, -5.0]
    end = horse.joint_index("tail_end")
    xyz = horse.joint_positions(curved)
    top = xyz[horse.joint_index("tail1")]
    out = top + 1.03 * (xyz[end] - top) / np.linalg.norm(xyz[end] - top) * np.linalg.norm(
        np.diff(horse.joint_positions(horse.rest_pose())[[horse.joint_index(f"tail{i}")
                                                          for i in range(1, 5)] + [end]],
                axis=0), axis=1).sum()  # 3% beyond the length of the tail, straight
    kept = drag_end(horse, curved, end, out)
    straight = drag_end(horse, curved, end, out, min_gain_m_per_deg=0.0)
    assert (np.abs(kept[tail] - curved[tail]).sum()
            < 0.5 * np.abs(straight[tail] - curved[tail]).sum())
    near = xyz[end] + [0.08, 0.05, 0.0]
    reached = drag_end(horse, curved, end, near)
    assert np.linalg.norm(horse.joint_positions(reached)[end] - near) < 1e-3


def test_a_small_drag_keeps_the_fold_the_artist_gave_the_leg(horse):
    posed = generate_gait(horse, "walk", 40)[9]  # as the artist left it
    end = horse.joint_index("R_fore_toe")
    leg = _channels(horse, effector_chain(horse, end))
    nudge = horse.joint_positions(posed)[end] + [0.01, 0.005, 0.0]
    far_examples = PoseLibrary.of(horse, np.zeros((1, horse.n_channels)), "the rest pose")
    moved = drag_end(horse, posed, end, nudge, library=far_examples)
    assert np.abs(moved[leg] - posed[leg]).max() < 3.0
    assert np.linalg.norm(horse.joint_positions(moved)[end] - nudge) < 1e-3
