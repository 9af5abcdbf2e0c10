"""Imported rigs stand up: Y-up or Z-up, metres or centimetres, facing any way, anywhere."""

from __future__ import annotations

import numpy as np
import pytest

from gaitcore.errors import GaitInputError
from gaitcore.io.bvh.writer import write_bvh
from gaitcore.io.pose_table import PoseTable
from gaitcore.project.steps import read_rig
from gaitcore.rig.orient import axis_vector, guess_axes, reoriented
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template


def written_as(skeleton: Skeleton, path, *, up: str, forward: str, unit_m: float,
               root_at=(0.0, 0.0, 0.0)) -> None:
    """Write ``skeleton`` as a BVH whose file axes have ``up`` and ``forward`` (file units of
    ``unit_m`` metres), its root moved by ``root_at`` (file units)."""
    f, u = axis_vector(forward), axis_vector(up)
    turn = np.stack([f, u, np.cross(f, u)])  # rows: our X, Y, Z in the file's frame
    offsets = skeleton.offsets @ turn / unit_m
    offsets[0] += root_at
    doc = skeleton.to_dict()
    for joint, offset in zip(doc["joints"], offsets):
        joint["offset"] = offset.tolist()
    rig = Skeleton.from_json(doc)
    write_bvh(path, rig, PoseTable(np.arange(1), rig.channel_names, np.zeros((1, rig.n_channels))))


def standing(rig: Skeleton) -> np.ndarray:
    return rig.joint_positions(rig.rest_pose())


@pytest.mark.parametrize("up, forward, unit_m, units", [
    ("+Z", "-Y", 0.01, "centimetres"), ("+Y", "-X", 1.0, ""), ("+Z", "+X", 1.0, ""),
    ("-Y", "+Z", 0.01, "centimetres"),
])
def test_a_quadruped_rig_stands_on_the_ground_facing_forward(tmp_path, up, forward, unit_m, units):
    horse = load_template("horse")
    path = tmp_path / "quadruped.bvh"
    written_as(horse, path, up=up, forward=forward, unit_m=unit_m, root_at=(470.0, -35.0, 12.0))
    rig, note = read_rig(path)
    got = dict(zip(rig.joint_names, standing(rig)))  # the writer orders joints its own way
    for joint, want in zip(horse.joints, standing(horse)):
        if not joint.channels:  # end sites get the reader's names
            continue
        name = joint.name
        np.testing.assert_allclose(got[name], want, atol=1e-4, err_msg=name)  # place and size
    assert units in note
    if (up, forward) != ("+Y", "+X"):
        assert f"turned from {up} up, facing {forward}" in note
    assert "ambiguous" not in note


def test_ambiguous_axes_say_so_and_can_be_fixed():
    cube = Skeleton.from_json({"format": "gaitstudio-skeleton", "version": 1, "joints": [
        {"name": "root", "parent": None, "offset": [0, 0, 0], "channels": ["rz", "rx", "ry"]},
        {"name": "a", "parent": "root", "offset": [0.5, 0, 0], "channels": []},
        {"name": "b", "parent": "root", "offset": [0, 0.5, 0], "channels": []},
        {"name": "c", "parent": "root", "offset": [0, 0, 0.5], "channels": []},
    ]})
    axes = guess_axes(cube)
    assert axes.ambiguous and axes.reason
    turned = reoriented(cube, up="+Z", forward="+X")  # the artist's choice
    pos = standing(turned)
    assert pos[cube.joint_index("c"), 1] == pytest.approx(pos[:, 1].max())  # c is now on top
    assert pos[:, 1].min() == pytest.approx(0.0)
    with pytest.raises(GaitInputError, match="different axes"):
        reoriented(cube, up="+Z", forward="-Z")
