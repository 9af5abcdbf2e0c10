"""BVH import: round trips with our writer, exact conversion of foreign channel orders,
and a one-line error with its line number for every kind of broken file."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from gaitcore.bench.gaits import generate_gait
from gaitcore.errors import GaitInputError
from gaitcore.io.bvh.reader import read_bvh
from gaitcore.io.bvh.writer import write_bvh
from gaitcore.io.pose_table import PoseTable
from gaitcore.rig.rotations import euler_zxy_matrix, zxy_from_matrix
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template

HORSE = load_template("horse")


def _end_key(skel: Skeleton, i: int) -> tuple:
    """End Sites lose their names in BVH: identify them by parent and offset."""
    j = skel.joints[i]
    return (j.parent, tuple(np.round(j.offset, 6)))


def _match_joints(ours: Skeleton, read: Skeleton) -> list[int]:
    """Index in ``read`` of every joint of ``ours`` (by name, end sites by parent and offset)."""
    ends = {_end_key(read, i): i for i, j in enumerate(read.joints) if not j.channels}
    return [read.joint_index(j.name) if j.channels else ends[_end_key(ours, i)]
            for i, j in enumerate(ours.joints)]


def test_our_writer_round_trips_through_our_reader(tmp_path):
    poses = generate_gait(HORSE, "gallop", 12, noise_deg=3.0, seed=1)
    write_bvh(tmp_path / "g.bvh", HORSE, PoseTable(np.arange(12), HORSE.channel_names, poses),
              fps=30.0)
    skel, table, fps = read_bvh(tmp_path / "g.bvh")
    assert fps == 30.0
    assert skel.n_joints == HORSE.n_joints
    assert set(table.columns) == set(HORSE.channel_names) == set(skel.channel_names)
    assert np.array_equal(table.frames, np.arange(12))
    for j in HORSE.joints:
        if j.channels:  # End Sites come back as '<parent>_end', matched by place below
            got = skel.joints[skel.joint_index(j.name)]
            assert (got.parent, got.channels, got.side, got.mirror) == \
                (j.parent, j.channels, j.side, j.mirror)
            np.testing.assert_allclose(got.offset, j.offset, atol=1e-9)
    match = _match_joints(HORSE, skel)
    col = [table.columns.index(c) for c in HORSE.channel_names]
    got = table.values[:, col]
    rot = [i for i, c in enumerate(HORSE.channel_names) if c.split(".")[1].startswith("r")]
    assert np.abs(got[:, rot] - poses[:, rot]).max() <= 1e-6  # degrees
    np.testing.assert_allclose(got[:, :3], poses[:, :3], atol=1e-6)  # root rest offset kept
    np.testing.assert_allclose(skel.joint_positions(table.values)[:, match],
                               HORSE.joint_positions(poses), atol=1e-6)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(1.0, 120.0))
def test_write_then_read_random_poses(tmp_path_factory, seed, fps):
    rng = np.random.default_rng(seed)
    poses = rng.uniform(-180.0, 180.0, (3, HORSE.n_channels))
    poses[:, :3] = rng.uniform(-5.0, 5.0, (3, 3))  # root.tx ty tz, metres
    path = tmp_path_factory.mktemp("rt") / "r.bvh"
    write_bvh(path, HORSE, PoseTable(np.arange(3), HORSE.channel_names, poses), fps=fps)
    skel, table, fps_read = read_bvh(path)
    assert fps_read == pytest.approx(fps, rel=1e-6)
    got = table.values[:, [table.columns.index(c) for c in HORSE.channel_names]]
    np.testing.assert_allclose(got[:, 3:], poses[:, 3:], atol=1e-6)
    np.testing.assert_allclose(got[:, :3], poses[:, :3], atol=1e-6)
    np.testing.assert_allclose(skel.offsets[0], HORSE.offsets[0], atol=1e-9)


# ---------------------------------------------------------------- foreign channel orders
def _chain_bvh(orders: list[str], angles: np.ndarray, *, newline: str = "\n") -> str:
    """A chain root -> j1 -> ... with rotation order ``orders[k]`` per joint and an End Site.

    The root has 6 channels, positions listed Z X Y; ``angles`` is (frames, joints, 3) in the
    listed order of each joint.
    """
    lines = ["HIERARCHY"]
    offsets = [(0.5, 1.0, 0.0)] + [(0.3 + 0.1 * k, -0.2, 0.05 * k) for k in range(1, len(orders))]
    for k, order in enumerate(orders):
        pad = "\t" * k
        lines.append(f"{pad}{'ROOT' if k == 0 else 'JOINT'} j{k}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}\tOFFSET {' '.join(map(str, offsets[k]))}")
        chans = " ".join(f"{a.upper()}rotation" for a in order)
        if k == 0:
            lines.append(f"{pad}\tCHANNELS {3 + len(order)} Zposition Xposition Yposition {chans}")
        else:
            lines.append(f"{pad}\tCHANNELS {len(order)} {chans}")
    pad = "\t" * len(orders)
    lines += [f"{pad}End Site", f"{pad}{{", f"{pad}\tOFFSET 0.0 -0.4 0.1", f"{pad}}}"]
    lines += ["\t" * k + "}" for k in reversed(range(len(orders)))]
    lines += ["MOTION", f"Frames: {len(angles)}", "Frame Time: 0.041667"]
    for f, a in enumerate(angles):
        pos = [0.1 * f, 0.5, 1.0 + 0.01 * f]  # z x y
        lines.append(" ".join(repr(float(v)) for v in [*pos, *a.ravel()]))
    return newline.join(lines) + newline


def _chain_world(orders: list[str], angles: np.ndarray, text: str) -> np.ndarray:
    """Joint positions (frames, joints + end, 3) by BVH semantics, with scipy's rotations."""
    offsets = [np.array([float(v) for v in line.split()[1:]])
               for line in text.splitlines() if line.strip().startswith("OFFSET")]
    out = np.zeros((len(angles), len(orders) + 1, 3))
    for f, a in enumerate(angles):
        world = np.eye(4)
        for k, order in enumerate(orders):
            local = np.eye(4)
            local[:3, :3] = Rotation.from_euler(order.upper(), a[k], degrees=True).as_matrix()
            local[:3, 3] = [0.5, 1.0 + 0.01 * f, 0.1 * f] if k == 0 else offsets[k]
            world = world @ local
            out[f, k] = world[:3, 3]
        out[f, -1] = (world @ np.append(offsets[-1], 1.0))[:3]
    return out


def test_xyz_channel_order_gives_the_same_world_positions(tmp_path):
    orders = ["xyz", "xyz", "yzx", "zxy"]
    angles = np.random.default_rng(3).uniform(-170, 170, (5, 4, 3))
    text = _chain_bvh(orders, angles, newline="\r\n")  # CRLF and tabs, as Windows tools write
    (tmp_path / "x.bvh").write_bytes(text.encode())
    skel, table, fps = read_bvh(tmp_path / "x.bvh")
    assert fps == 24.0
    assert skel.joint_names == ("j0", "j1", "j2", "j3", "j3_end")
    assert skel.joints[0].channels == ("tx", "ty", "tz", "rz", "rx", "ry")
    assert skel.joints[3].channels == ("rz", "rx", "ry")  # ZXY already: angles kept as is
    np.testing.assert_array_equal(table.values[:, -3:], angles[:, 3])
    np.testing.assert_allclose(skel.joint_positions(table.values),
                               _chain_world(orders, angles, text), atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.sampled_from(["xyz", "xzy", "yxz", "yzx", "zxy", "zyx", "zx", "y", "xz"]),
                min_size=1, max_size=4),
       st.integers(0, 2**32 - 1))
def test_any_rotation_order_converts_exactly(tmp_path_factory, orders, seed):
    angles = np.random.default_rng(seed).uniform(-180, 180, (4, len(orders), 3))
    lists = [angles[:, k, :len(o)] for k, o in enumerate(orders)]
    text = _chain_bvh(orders, np.concatenate(lists, axis=1)[:, None, :])
    path = tmp_path_factory.mktemp("ord") / "o.bvh"
    path.write_text(text)
    skel, table, _ = read_bvh(path)
    world = _chain_world(orders, [[lst[f] for lst in lists] for f in range(4)], text)
    np.testing.assert_allclose(skel.joint_positions(table.values), world, atol=1e-9)


def test_converted_curves_have_no_360_degree_jumps(tmp_path):
    """A joint listed X Y Z turning steadily about X through 400 degrees, with a small Y."""
    t = np.linspace(0.0, 400.0, 81)
    angles = np.stack([t, np.full_like(t, 10.0), np.zeros_like(t)], axis=1)[:, None, :]
    (tmp_path / "spin.bvh").write_text(_chain_bvh(["xyz"], angles))
    _, table, _ = read_bvh(tmp_path / "spin.bvh")
    rot = table.values[:, 3:]
    assert np.abs(np.diff(rot, axis=0)).max() == pytest.approx(5.0)  # through x = 90 too
    np.testing.assert_allclose(rot[:, 1], t, atol=1e-9)  # rx runs on past 180 and 360
    np.testing.assert_allclose(euler_zxy_matrix(rot), Rotation.from_euler(
        "XYZ", angles[:, 0], degrees=True).as_matrix(), atol=1e-12)


def test_zxy_from_matrix_inverts_euler_zxy_matrix_including_gimbal_lock():
    angles = np.random.default_rng(0).uniform([-180, -90, -180], [180, 90, 180], (200, 3))
    angles[:3, 1] = [90.0, -90.0, 90.0]
    m = euler_zxy_matrix(angles)
    np.testing.assert_allclose(euler_zxy_matrix(zxy_from_matrix(m)), m, atol=1e-12)


def test_blender_style_file(tmp_path):
    """Blender: 6 channels on unconnected bones, dotted side names, cm units, End Site names."""
    text = """HIERARCHY
ROOT pelvis
{
  OFFSET 0 100 0
  CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
  JOINT thigh.L
  {
    OFFSET 0 -10 -15
    CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
    End Site knee
    {
      OFFSET 0 -45 0
    }
  }
  JOINT thigh.R
  {
    OFFSET 0 -10 15
    CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
    End Site
    {
      OFFSET 0 -45 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.033333
0 100 0 0 0 0  0 -10 -15 10 0 0  0 -10 15 -10 0 0
5 101 0 0 0 5  0 -10 -15 20 0 0  0 -10 15 -20 0 0
"""
    (tmp_path / "b.bvh").write_text(text)
    skel, table, fps = read_bvh(tmp_path / "b.bvh", scale=0.01)
    assert fps == 30.0
    assert skel.joint_names == ("pelvis", "thigh_L", "thigh_L_end", "thigh_R", "thigh_R_end")
    assert skel.joints[1].channels == ("rz", "rx", "ry")  # constant positions -> offset
    np.testing.assert_allclose(skel.joints[1].offset, (0.0, -0.1, -0.15))
    assert (skel.joints[1].side, skel.joints[1].mirror) == ("L", "thigh_R")
    np.testing.assert_allclose(table.values[1, :3], (0.05, 0.01, 0.0))  # minus the root OFFSET
    mirrored = skel.mirror_pose(table.values)
    assert np.allclose(mirrored[:, skel.channel_index("thigh_L.rx")],
                       -table.values[:, skel.channel_index("thigh_R.rx")])
    assert len(skel.bone_ellipsoids()) == 4  # default shapes so that it can be drawn


def test_partial_rotation_channels_in_our_order_stay_partial(tmp_path):
    text = ("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\nJOINT k\n{\n"
            "OFFSET 1 0 0\nCHANNELS 2 Xrotation Yrotation\n}\n}\nMOTION\nFrames: 1\n"
            "Frame Time: 0.04\n30 10 20\n")
    (tmp_path / "p.bvh").write_text(text)
    skel, table, fps = read_bvh(tmp_path / "p.bvh")
    assert skel.channel_names == ("r.rz", "k.rx", "k.ry") and fps == 25.0
    np.testing.assert_array_equal(table.values, [[30.0, 10.0, 20.0]])


def test_braces_on_name_lines_spaces_in_names_and_unequal_partners(tmp_path):
    """'{' after the name, a name with spaces, and would-be mirror partners whose rotation
    orders differ enough that their channels differ: read, but not paired."""
    text = ("HIERARCHY\nROOT Body Root {\n OFFSET 0 0 0\n CHANNELS 0\n"
            " JOINT LeftLeg {\n  OFFSET 0 0 -1\n  CHANNELS 2 Zrotation Xrotation\n }\n"
            " JOINT RightLeg {\n  OFFSET 0 0 1\n  CHANNELS 2 Xrotation Zrotation\n }\n"
            "}\nMOTION\nFrames: 1\nFrame Time: 0.1\n10 20 20 10\n")
    (tmp_path / "s.bvh").write_text(text)
    skel, table, _ = read_bvh(tmp_path / "s.bvh")
    assert skel.joint_names == ("Body_Root", "LeftLeg", "RightLeg")
    assert skel.joints[1].channels == ("rz", "rx") and skel.joints[2].channels == ("rz", "rx", "ry")
    assert {j.side for j in skel.joints} == {"C"}
    world = skel.forward_kinematics(table.values[0])
    expected = Rotation.from_euler("XZ", [20, 10], degrees=True).as_matrix()
    np.testing.assert_allclose(world[2, :3, :3], expected, atol=1e-12)


# ---------------------------------------------------------------- malformed files
GOOD = """HIERARCHY
ROOT hips
{
  OFFSET 0 1 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT knee
  {
    OFFSET 0 -0.5 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 -0.5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
0 1 0 0 0 0 10 0 0
0 1 0 0 0 0 20 0 0
"""


def _broken(old: str, new: str) -> str:
    assert old in GOOD
    return GOOD.replace(old, new, 1)


BROKEN = {
    "unknown channel": (_broken("3 Zrotation Xrotation", "3 Zrotation Wrotation"),
                        r"line 9: unknown channel 'Wrotation'"),
    "scale channel": (_broken("3 Zrotation Xrotation", "3 Zrotation Xscale"),
                      r"line 9: unknown channel 'Xscale'"),
    "repeated channel": (_broken("Xrotation Yrotation\n    End", "Xrotation Xrotation\n    End"),
                         r"line 9: channel 'Xrotation' is listed twice"),
    "channel count": (_broken("CHANNELS 3", "CHANNELS 4"), r"line 9: CHANNELS says 4 but lists 3"),
    "unclosed brace": (_broken("    }\n  }\n}\n", "    }\n  }\n"), r"never closed"),
    "extra brace": (_broken("  }\n}\n", "  }\n}\n}\n"), r"line 16: .*one '}' too many"),
    "missing OFFSET": (_broken("    OFFSET 0 -0.5 0\n    CHANNELS", "    CHANNELS"),
                       r"line 9: joint 'knee' \(line 6\) has no OFFSET"),
    "missing CHANNELS": (_broken("    CHANNELS 3 Zrotation Xrotation Yrotation\n", ""),
                         r"line 9: joint 'knee' \(line 6\) has no CHANNELS"),
    "JOINT outside ROOT": (_broken("ROOT hips", "JOINT hips"), r"line 2: JOINT outside a ROOT"),
    "JOINT after ROOT": (_broken("}\nMOTION", "}\nJOINT x\n{\n}\nMOTION"),
                         r"line 16: JOINT outside the ROOT"),
    "second ROOT": (_broken("}\nMOTION", "}\nROOT x\n{\n}\nMOTION"), r"line 16: a second ROOT"),
    "bad OFFSET": (_broken("OFFSET 0 1 0", "OFFSET 0 one 0"), r"line 4: OFFSET needs 3 numbers"),
    "no HIERARCHY": (GOOD.replace("HIERARCHY\n", ""), r"line 1: a BVH file starts with HIERARCHY"),
    "no MOTION": (GOOD.split("MOTION")[0], r"no MOTION section"),
    "no Frames line": (_broken("Frames: 2\n", ""),
                       r"line 17: expected 'Frames: N', found 'Frame Time: 0.04'"),
    "frame count": (_broken("Frames: 2", "Frames: 3"), r"'Frames: 3' but the file has 2 motion"),
    "zero frame time": (_broken("Frame Time: 0.04", "Frame Time: 0"), r"seconds from 0.0001"),
    "non-numeric": (_broken("0 1 0 0 0 0 20", "0 1 0 0 abc 0 20"),
                    r"line 20: 'abc' is not a number"),
    "NaN value": (_broken("0 1 0 0 0 0 20", "0 1 0 0 nan 0 20"), r"line 20: NaN"),
    "too few values": (_broken("0 1 0 0 0 0 20 0 0", "0 1 0 0 0 0 20 0"),
                       r"line 20: too few values \(8; the CHANNELS of the hierarchy add up to 9\)"),
    "too many values": (_broken("0 1 0 0 0 0 20 0 0", "0 1 0 0 0 0 20 0 0 7"),
                        r"line 20: too many values"),
    "moving joint": (_broken("CHANNELS 3 Zrotation Xrotation Yrotation",
                             "CHANNELS 4 Yposition Zrotation Xrotation Yrotation")
                     .replace("0 1 0 0 0 0 10 0 0", "0 1 0 0 0 0 -0.5 10 0 0")
                     .replace("0 1 0 0 0 0 20 0 0", "0 1 0 0 0 0 -0.4 20 0 0"),
                     r"line 6: joint 'knee' moves"),
}


def test_the_good_file_reads(tmp_path):
    (tmp_path / "good.bvh").write_text(GOOD)
    skel, table, fps = read_bvh(tmp_path / "good.bvh")
    assert fps == 25.0
    assert skel.joint_names == ("hips", "knee", "knee_end") and table.values.shape == (2, 9)


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_malformed_files_raise_one_line_errors(tmp_path, case):
    text, message = BROKEN[case]
    path = tmp_path / "bad.bvh"
    path.write_text(text)
    with pytest.raises(GaitInputError, match=message) as info:
        read_bvh(path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(GaitInputError, match="not found"):
        read_bvh(tmp_path / "nope.bvh")
