"""Placing the footage behind the skeleton: the automatic fit and the artist's correction."""

from __future__ import annotations

import numpy as np
import pytest

from gaitcore.project.document import FootageFit, Silhouettes
from gaitcore.project.footage_fit import (
    facing_travel,
    reference_image,
    skeleton_extent,
    travel_direction,
)
from gaitcore.rig.templates import load_template
from gaitcore.silhouettes.tracking import crop_rois
from tests.gaitcore.walker import walker_clip, walker_frame


@pytest.fixture(scope="module")
def scene():
    masks = walker_clip(30)
    silhouettes = Silhouettes(crop_rois(masks), "masks")
    frame = masks[5].astype(np.uint8) * 255
    return frame, silhouettes, skeleton_extent(load_template("horse"))


def anchor_and_scale(ref):
    """World position of texel (0, 0) and metres per texel along x and y."""
    return ref.transform[:2, 3], np.diag(ref.transform)[:2]


def test_the_fit_scales_about_the_anchor_shifts_and_mirrors(scene):
    frame, silhouettes, extent = scene
    auto = reference_image(frame, 5, extent, silhouettes)
    fit = FootageFit(scale=2.0, offset_x_m=0.3, offset_y_m=-0.1)
    moved = reference_image(frame, 5, extent, silhouettes, fit=fit)
    (x0, y0), (sx, sy) = anchor_and_scale(auto)
    (x1, y1), (tx, ty) = anchor_and_scale(moved)
    np.testing.assert_allclose([tx, ty], [2 * sx, 2 * sy])
    # the silhouette centre (the anchor) stays on the skeleton centre, then moves by the shift
    cx, cy = extent.center_xy
    np.testing.assert_allclose([x1 - (cx + 0.3), y1 - (cy - 0.1)], [2 * (x0 - cx), 2 * (y0 - cy)])
    mirrored = reference_image(frame, 5, extent, silhouettes, fit=FootageFit(flip=True))
    assert mirrored.transform[0, 0] == pytest.approx(-sx)
    assert mirrored.transform[0, 3] - cx == pytest.approx(-(x0 - cx))


def test_a_bad_fit_is_refused():
    from gaitcore.errors import GaitInputError

    with pytest.raises(GaitInputError, match="positive"):
        FootageFit(scale=0.0)
    with pytest.raises(GaitInputError, match="finite"):
        FootageFit(offset_y_m=float("nan"))


def test_the_footage_turns_to_the_way_the_animal_walks():
    def crossing(step_px: int) -> Silhouettes:
        frames = []
        for t in range(40):
            canvas = np.zeros((120, 400), np.uint8)
            x = 100 + step_px * t
            canvas[:, x : x + 200] = walker_frame(float(t), size=(120, 200))
            frames.append(canvas)
        return Silhouettes(crop_rois(np.stack(frames)), "masks")

    left, right, still = crossing(-2), crossing(2), crossing(0)
    assert (travel_direction(left), travel_direction(right), travel_direction(still)) == (-1, 1, 0)
    assert facing_travel(FootageFit(), left).flip and not facing_travel(FootageFit(), right).flip
    mine = FootageFit(scale=1.2)  # the artist's own fit is kept as it is
    assert facing_travel(mine, left) == mine
