"""Rig proportions: per-part scales, the proportioned skeleton, and the fit from a silhouette."""

from __future__ import annotations

import numpy as np
import pytest

from gaitcore.errors import GaitInputError
from gaitcore.rig.proportions import RigProportions, body_parts, proportioned
from gaitcore.rig.templates import load_template


@pytest.fixture(scope="module")
def horse():
    return load_template("horse")


def test_identity_proportions_give_the_same_rig_and_others_a_cached_new_one(horse):
    assert proportioned(horse, RigProportions()) is horse
    props = RigProportions(legs=1.2, neck=0.8)
    tall = proportioned(horse, props)
    assert tall is proportioned(horse, RigProportions(legs=1.2, neck=0.8))  # same object
    assert tall.channel_names == horse.channel_names
    assert tall.limits_array().tolist() == horse.limits_array().tolist()


def test_each_part_scales_its_own_bones_and_the_feet_stay_on_the_ground(horse):
    parts = np.array(body_parts(horse))
    assert set(parts) == {"legs", "neck", "body", "head", "tail"}
    assert parts[horse.joint_index("L_carpus")] == "legs"
    assert parts[horse.joint_index("L_scapula")] == "body"  # attaches the leg to the trunk
    assert (parts[horse.joint_index("tail3")] == "tail"
            and parts[horse.joint_index("ears")] == "head")
    props = RigProportions(legs=1.15, neck=0.85, body=1.05, head=1.1, tail=0.9)
    rig = proportioned(horse, props)
    lengths = (np.linalg.norm(rig.offsets, axis=1)
               / np.maximum(np.linalg.norm(horse.offsets, axis=1), 1e-12))
    for j in range(1, horse.n_joints):
        attachment = parts[j] == "body" and horse.joints[j].side != "C"  # levelled in Y
        if np.linalg.norm(horse.offsets[j]) > 0 and not attachment:
            assert lengths[j] == pytest.approx(props.scale_of(parts[j])), horse.joint_names[j]
    rest, tall = (s.joint_positions(s.rest_pose()) for s in (horse, rig))
    assert tall[:, 1].min() == pytest.approx(rest[:, 1].min(), abs=1e-12)  # standing on the ground
    from gaitcore.rig.contact import find_feet

    for short in (rig, proportioned(horse, RigProportions(legs=0.75, body=1.1))):
        toes = [short.joint_index(f) for f in find_feet(horse)]  # all four, not the hind only
        np.testing.assert_allclose(short.joint_positions(short.rest_pose())[toes, 1],
                                   rest[toes, 1], atol=1e-9)
    assert tall[horse.joint_index("root"), 1] > rest[horse.joint_index("root"), 1]  # longer legs


@pytest.mark.parametrize("bad", [0.0, -1.0, 10.0, float("nan"), "big"])
def test_a_scale_out_of_range_says_so(bad):
    with pytest.raises(GaitInputError, match="legs scale"):
        RigProportions(legs=bad)


@pytest.mark.parametrize("gait, frame, truth", [
    ("canter", 7, RigProportions(legs=1.15, neck=0.85, head=1.1, tail=0.9)),
    ("walk", 12, RigProportions(legs=0.9, neck=1.12, head=0.92, tail=1.1)),
])
def test_the_fit_recovers_each_part_scale_from_a_rendered_silhouette(horse, gait, frame, truth):
    """Render a rig scaled per part, fit the template to one silhouette: within 5% per part."""
    from gaitcore.bench.gaits import generate_gait
    from gaitcore.project.document import Silhouettes
    from gaitcore.project.footage_fit import fit_rig, reference_image, skeleton_extent
    from gaitcore.rig.render import render_clip
    from gaitcore.rig.silhouette_fit import rig_measures
    from gaitcore.silhouettes.tracking import crop_rois

    rig = proportioned(horse, truth)
    poses = generate_gait(rig, gait, frame + 1)
    _, masks = render_clip(rig, poses, width=320, height=240)
    silhouettes = Silhouettes(crop_rois(masks), "masks")
    fit = fit_rig(horse, poses[frame], silhouettes, frame)  # the artist's pose of that key
    for part in ("legs", "neck", "head", "tail"):
        assert fit.proportions.scale_of(part) == pytest.approx(truth.scale_of(part), rel=0.05), part
    assert fit.measures.overlap > 0.85
    body, withers, leg = rig_measures(horse, truth)  # what the artist checks by eye
    assert fit.measures.body_length_m == pytest.approx(body, rel=1e-9)  # the reference part
    assert fit.measures.withers_height_m == pytest.approx(withers, rel=0.05)
    assert fit.measures.leg_length_m == pytest.approx(leg, rel=0.05)
    # The footage fit puts the silhouette on the fitted rig: its joints land on the animal.
    fitted = proportioned(horse, fit.proportions)
    ref = reference_image(masks[frame], frame, skeleton_extent(fitted), silhouettes,
                          fit=fit.footage_fit)
    pos = fitted.joint_positions(poses[frame])
    follow = pos[0, 0] - fitted.offsets[0, 0]
    a, b = ref.pixel_to_world[:2, :2], ref.pixel_to_world[:2, 2]
    uv = np.linalg.solve(a, (pos[:, :2] - [follow, 0.0] - b).T).T
    rows, cols = masks[frame].shape
    inside = masks[frame][np.clip(np.round(uv[:, 1]).astype(int), 0, rows - 1),
                          np.clip(np.round(uv[:, 0]).astype(int), 0, cols - 1)]
    assert inside.mean() > 0.9


def test_fitting_an_empty_silhouette_says_what_to_do(horse):
    from gaitcore.rig.silhouette_fit import fit_proportions

    with pytest.raises(GaitInputError, match="segment or sketch"):
        fit_proportions(np.zeros((40, 60), bool), horse, horse.rest_pose())


@pytest.mark.parametrize("clip", ["davis-bear", "davis-dog"])
def test_a_real_animal_in_another_pose_never_stretches_a_part_and_is_refused(horse, shared_data,
                                                                            clip):
    """The artist has not posed the key yet (rest pose), the animal is not a horse (the dog
    runs towards the camera): the fit must not run to the bounds, and Fit rig refuses it,
    saying why, rather than put a rig far off the footage."""
    from gaitcore.project.footage_fit import fit_rig
    from gaitcore.project.steps import silhouettes_from_masks
    from gaitcore.rig.silhouette_fit import FIT_RANGE, fit_proportions

    silhouettes = silhouettes_from_masks(shared_data / clip / "Annotations")
    fit = fit_proportions(silhouettes.roi.crops[20], horse, horse.rest_pose())
    for part in ("legs", "neck", "head", "tail"):
        scale = fit.proportions.scale_of(part)
        assert FIT_RANGE[0] * 1.05 < scale < FIT_RANGE[1] / 1.05, (part, scale)
    assert fit.problems()
    with pytest.raises(GaitInputError, match="does not fit frame 20 .*silhouette's length"):
        fit_rig(horse, horse.rest_pose(), silhouettes, 20)
