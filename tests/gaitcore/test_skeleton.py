"""Skeleton templates: JSON format, validation, forward kinematics, mirroring, bone shapes."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from gaitcore.errors import GaitInputError
from gaitcore.rig.rotations import euler_zxy_matrix
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template


@pytest.fixture(scope="module")
def horse() -> Skeleton:
    return load_template("horse")


def _tiny() -> dict:
    """A 3-joint chain: root -> a -> b, plus a left/right pair under the root."""
    return {
        "format": "gaitstudio-skeleton", "version": 1, "name": "tiny",
        "joints": [
            {"name": "root", "parent": None, "offset": [0, 1, 0],
             "channels": ["tx", "ty", "tz", "rz", "rx", "ry"]},
            {"name": "a", "parent": "root", "offset": [1, 0, 0], "channels": ["rz", "rx", "ry"],
             "bone": {"radii": [0.1, 0.2]}},
            {"name": "b", "parent": "a", "offset": [0, -1, 0], "channels": []},
            {"name": "L_x", "parent": "root", "offset": [0, 0, -0.5], "channels": ["rz"],
             "side": "L", "mirror": "R_x"},
            {"name": "R_x", "parent": "root", "offset": [0, 0, 0.5], "channels": ["rz"],
             "side": "R", "mirror": "L_x"},
        ],
    }


def _rot(axis: str, deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return {"x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
            "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def test_horse_template_layout(horse):
    assert horse.n_joints >= 30
    assert horse.channel_names[:6] == ("root.tx", "root.ty", "root.tz",
                                       "root.rz", "root.rx", "root.ry")
    names = set(horse.joint_names)
    for side in "LR":
        for j in ("scapula", "elbow", "carpus", "fore_fetlock", "fore_hoof", "hip", "stifle",
                  "hock", "hind_fetlock", "hind_hoof"):
            assert f"{side}_{j}" in names
    rz = horse.sagittal_angle_indices
    assert len(rz) >= 30
    assert all(horse.channel_names[i].endswith(".rz") for i in rz)
    assert horse.limits_array().shape == (horse.n_channels, 2)


def test_rest_pose_stands_on_the_ground_symmetrically(horse):
    pos = horse.joint_positions(horse.rest_pose())
    for toe in ("L_fore_toe", "R_fore_toe", "L_hind_toe", "R_hind_toe"):
        assert pos[horse.joint_index(toe), 1] == pytest.approx(0.0, abs=1e-9)
    assert pos[:, 1].min() >= -1e-9
    for j in horse.joints:
        if j.side == "R":
            mirrored = pos[horse.joint_index(j.mirror)] * [1, 1, -1]
            np.testing.assert_allclose(pos[horse.joint_index(j.name)], mirrored, atol=1e-12)
            assert pos[horse.joint_index(j.name), 2] > 0  # right side faces the camera (+Z)


def test_euler_order_is_z_then_x_then_y():
    angles = np.array([30.0, -50.0, 70.0])
    expected = _rot("z", 30) @ _rot("x", -50) @ _rot("y", 70)
    np.testing.assert_allclose(euler_zxy_matrix(angles), expected, atol=1e-12)


def test_forward_kinematics_composes_offsets_and_rotations():
    sk = Skeleton.from_json(_tiny())
    pose = np.zeros(sk.n_channels)
    pose[sk.channel_index("root.tx")] = 2.0
    pose[sk.channel_index("root.rz")] = 90.0
    pose[sk.channel_index("a.rz")] = 90.0
    pos = sk.joint_positions(pose)
    np.testing.assert_allclose(pos[0], [2, 1, 0], atol=1e-12)  # offset + translation
    np.testing.assert_allclose(pos[1], [2, 2, 0], atol=1e-12)  # (1,0,0) turned to +Y
    np.testing.assert_allclose(pos[2], [2, 3, 0], atol=1e-12)  # (0,-1,0) turned by 180
    world = sk.forward_kinematics(pose)
    np.testing.assert_allclose(world[2, :3, :3], _rot("z", 180), atol=1e-12)


def test_forward_kinematics_is_vectorised(horse):
    rng = np.random.default_rng(1)
    poses = rng.normal(0, 20, size=(4, horse.n_channels))
    batch = horse.forward_kinematics(poses)
    assert batch.shape == (4, horse.n_joints, 4, 4)
    for i in range(4):
        np.testing.assert_allclose(batch[i], horse.forward_kinematics(poses[i]), atol=1e-12)


def test_a_joint_moves_only_its_descendants(horse):
    pose = horse.rest_pose()
    pose[horse.channel_index("R_elbow.rz")] = 40.0
    moved = np.linalg.norm(horse.joint_positions(pose) - horse.joint_positions(horse.rest_pose()),
                           axis=1) > 1e-9
    below = {"R_carpus", "R_fore_fetlock", "R_fore_pastern", "R_fore_hoof", "R_fore_toe"}
    assert {horse.joint_names[i] for i in np.flatnonzero(moved)} == below


def test_mirror_pose_reflects_the_body_about_the_sagittal_plane(horse):
    rng = np.random.default_rng(2)
    poses = rng.normal(0, 15, size=(3, horse.n_channels))
    mirrored = horse.mirror_pose(poses)
    np.testing.assert_allclose(horse.mirror_pose(mirrored), poses)
    partner = [horse.joint_index(j.mirror or j.name) for j in horse.joints]
    pos, pos_m = horse.joint_positions(poses), horse.joint_positions(mirrored)
    np.testing.assert_allclose(pos_m[:, partner] * [1, 1, -1], pos, atol=1e-12)
    # rz is kept, rx and ry change sign, left and right swap
    i, j = horse.channel_index("L_hock.rz"), horse.channel_index("R_hock.rz")
    assert mirrored[0, j] == poses[0, i]
    i, j = horse.channel_index("L_hock.rx"), horse.channel_index("R_hock.rx")
    assert mirrored[0, j] == -poses[0, i]
    k = horse.channel_index("root.tz")
    assert mirrored[0, k] == -poses[0, k]


def test_json_round_trip(horse, tmp_path):
    path = tmp_path / "horse.json"
    text = horse.to_json(path)
    again = Skeleton.from_json(path)
    assert json.loads(text)["format"] == "gaitstudio-skeleton"
    assert again.channel_names == horse.channel_names
    assert again.joints == horse.joints
    again2 = Skeleton.from_json(horse.to_dict())
    np.testing.assert_array_equal(again2.offsets, horse.offsets)


def test_bone_ellipsoids_follow_the_bones(horse):
    ells = horse.bone_ellipsoids()
    assert len(ells) >= 30
    for e in ells:
        off = horse.offsets[e.child]
        np.testing.assert_allclose(e.center, off / 2)
        np.testing.assert_allclose(e.axes[:, 0], off / np.linalg.norm(off))
        np.testing.assert_allclose(e.axes.T @ e.axes, np.eye(3), atol=1e-12)
        assert np.all(e.radii > 0) and e.radii[0] > np.linalg.norm(off) / 2
        assert horse.parents[e.child] == e.joint


def _with(mutate) -> dict:
    doc = copy.deepcopy(_tiny())
    mutate(doc)
    return doc


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d["joints"][2].update(parent="nope"), "unknown parent"),
        (lambda d: d["joints"][1].update(parent="b"), "cycle"),
        (lambda d: d["joints"][2].update(name="a"), "duplicate"),
        (lambda d: d["joints"][1].update(channels=["rq"]), "channels"),
        (lambda d: d["joints"][1].update(channels=["rx", "rz"]), "order"),
        (lambda d: d["joints"][1].update(channels=["tx", "rz"]), "translation"),
        (lambda d: d["joints"][1].update(offset=[1, 2]), "offset"),
        (lambda d: d["joints"][1].update(limits={"tx": [0, 1]}), "limits"),
        (lambda d: d["joints"][1].update(limits={"rz": [10, -10]}), "limits"),
        (lambda d: d["joints"][3].update(mirror="a"), "mirror"),
        (lambda d: d["joints"][4].pop("mirror"), "mirror"),
        (lambda d: d["joints"][3].update(side="X"), "side"),
        (lambda d: d["joints"][1].update(bone={"radii": [0.1, -1]}), "radii"),
        (lambda d: d["joints"].insert(0, d["joints"].pop(1)), "root"),
        (lambda d: d["joints"].append({"name": "c", "parent": None, "offset": [0, 0, 0]}),
         "root"),
        (lambda d: d.update(format="bvh"), "format"),
        (lambda d: d.update(version=2), "version"),
        (lambda d: d.update(joints=[]), "joints"),
        (lambda d: d.update(up_axis="Z"), "up_axis"),
    ],
)
def test_malformed_json_is_rejected_with_a_reason(mutate, message):
    with pytest.raises(GaitInputError, match=message):
        Skeleton.from_json(_with(mutate))


def test_parents_listed_after_children_are_rejected():
    doc = _tiny()
    doc["joints"][1], doc["joints"][2] = doc["joints"][2], doc["joints"][1]
    with pytest.raises(GaitInputError, match="parents first"):
        Skeleton.from_json(doc)


def test_missing_file_and_template(tmp_path):
    with pytest.raises(GaitInputError, match="not found"):
        Skeleton.from_json(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(GaitInputError, match="bad.json is not valid JSON"):
        Skeleton.from_json(tmp_path / "bad.json")
    with pytest.raises(GaitInputError, match="horse"):
        load_template("unicorn")


def test_bad_pose_shapes_are_rejected(horse):
    with pytest.raises(GaitInputError, match="channels"):
        horse.forward_kinematics(np.zeros(5))
    with pytest.raises(GaitInputError, match="NaN"):
        horse.forward_kinematics(np.full(horse.n_channels, np.nan))
    with pytest.raises(GaitInputError, match="no channel"):
        horse.channel_index("tail9.rz")
