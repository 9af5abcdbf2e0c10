"""BVH export, checked with an independent reader (bvhio)."""

import numpy as np
import pytest

from gaitcore import GaitInputError
from gaitcore.bench.gaits import generate_gait
from gaitcore.io.bvh.writer import write_bvh
from gaitcore.io.pose_table import PoseTable
from gaitcore.rig.rotations import euler_zxy_matrix
from gaitcore.rig.templates import load_template

bvhio = pytest.importorskip("bvhio")


def _quat_matrix(q) -> np.ndarray:
    w, x, y, z = q.w, q.x, q.y, q.z
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _walk(joint, parent=None):
    yield joint, parent
    for child in joint.Children:
        yield from _walk(child, joint.Name)


def test_round_trip_through_an_independent_reader(tmp_path):
    skel = load_template("horse")
    poses = generate_gait(skel, "gallop", 12, noise_deg=3.0, seed=1)
    table = PoseTable(np.arange(12), skel.channel_names, poses)
    write_bvh(tmp_path / "g.bvh", skel, table, fps=30.0)
    bvh = bvhio.readAsBvh(str(tmp_path / "g.bvh"))
    assert bvh.FrameCount == 12
    assert bvh.FrameTime == pytest.approx(1 / 30.0, abs=1e-8)
    read = {j.Name: (j, parent) for j, parent in _walk(bvh.Root)}
    rotating = [j for j in skel.joints if "rz" in j.channels]
    # Every joint with channels is there, under the same parent, at the same offset.
    for j in rotating:
        joint, parent = read[j.name]
        assert parent == j.parent
        if j.parent is not None:
            np.testing.assert_allclose(list(joint.Offset), j.offset, atol=1e-6)
    worst_deg = 0.0
    for j in rotating:
        joint, _ = read[j.name]
        angles = poses[:, [skel.channel_index(f"{j.name}.{c}") for c in ("rz", "rx", "ry")]]
        ours = euler_zxy_matrix(angles)
        for f in range(12):
            theirs = _quat_matrix(joint.Keyframes[f].Rotation)
            # For small rotations |R1 - R2|_F = sqrt(2) * angle; arccos of the trace would
            # drown the comparison in the rounding of bvhio's single-precision quaternions.
            angle = np.linalg.norm(ours[f] - theirs) / np.sqrt(2)
            worst_deg = max(worst_deg, np.degrees(angle))
    assert worst_deg <= 1e-4
    root, _ = read["root"]
    expected = poses[:, :3] + np.asarray(skel.joints[0].offset)
    got = np.array([list(root.Keyframes[f].Position) for f in range(12)])
    np.testing.assert_allclose(got, expected, atol=1e-5)


def test_missing_channels_are_refused(tmp_path):
    skel = load_template("horse")
    table = PoseTable(np.arange(2), ("root.tx",), np.zeros((2, 1)))
    with pytest.raises(GaitInputError, match="lack"):
        write_bvh(tmp_path / "x.bvh", skel, table)


def _hierarchy(path):
    text = path.read_text()
    return text[:text.index("MOTION")], text


def test_one_end_site_per_joint_the_farthest(tmp_path):
    skel = load_template("horse")
    table = PoseTable(np.arange(2), skel.channel_names, np.zeros((2, skel.n_channels)))
    write_bvh(tmp_path / "h.bvh", skel, table)
    hierarchy, _ = _hierarchy(tmp_path / "h.bvh")
    start = hierarchy.index("JOINT head\n")
    depth, end = 0, hierarchy.index("{", start)
    for end in range(end, len(hierarchy)):  # the head's block, to its closing brace
        depth += {"{": 1, "}": -1}.get(hierarchy[end], 0)
        if depth == 0:
            break
    head = hierarchy[start:end]
    assert head.count("End Site") == 1
    muzzle = " ".join(f"{v:.6f}" for v in skel.joints[skel.joint_index("head_end")].offset)
    assert f"End Site\n{' ' * 16}{{\n{' ' * 18}OFFSET {muzzle}" in head
    assert "JOINT ears" in head and "CHANNELS 0" in head
    leaves = [j for j in skel.joints if not j.channels]
    assert hierarchy.count("End Site") == len(leaves) - 1  # the ears became a joint


def test_frame_time_has_twelve_decimals(tmp_path):
    skel = load_template("horse")
    table = PoseTable(np.arange(2), skel.channel_names, np.zeros((2, skel.n_channels)))
    write_bvh(tmp_path / "h.bvh", skel, table, fps=24.0)
    _, text = _hierarchy(tmp_path / "h.bvh")
    assert "Frame Time: 0.041666666667\n" in text
    assert abs(1 / float("0.041666666667") - 24.0) < 1e-8  # Blender's fps_base stays 1.0
    write_bvh(tmp_path / "slow.bvh", skel, table, fps=1.25)  # 0.8 s: "0.8" read as 1.2 fps
    assert "Frame Time: 0.800000000000\n" in _hierarchy(tmp_path / "slow.bvh")[1]


def test_rigify_names(tmp_path):
    skel = load_template("horse")
    table = PoseTable(np.arange(2), skel.channel_names, np.zeros((2, skel.n_channels)))
    write_bvh(tmp_path / "h.bvh", skel, table, naming="rigify")
    hierarchy, _ = _hierarchy(tmp_path / "h.bvh")
    assert "JOINT hip.L" in hierarchy and "JOINT fore_fetlock.R" in hierarchy
    assert "L_hip" not in hierarchy and "JOINT spine1" in hierarchy
    with pytest.raises(GaitInputError, match="naming"):
        write_bvh(tmp_path / "x.bvh", skel, table, naming="maya")
