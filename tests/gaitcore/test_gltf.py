"""glTF export: the binary layout, the skin, and an animation that replays our kinematics."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from gaitcore.bench.gaits import generate_gait
from gaitcore.errors import GaitInputError
from gaitcore.io.gltf import write_glb
from gaitcore.rig.rotations import euler_zxy_matrix, quaternions_zxy
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template

HORSE = load_template("horse")
N_FRAMES, FPS = 30, 25.0
_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
_DTYPES = {5126: "<f4", 5121: "u1", 5123: "<u2", 5125: "<u4"}


def _parse_glb(path) -> tuple[dict, bytes]:
    """The JSON document and BIN chunk, checking the GLB container on the way."""
    raw = path.read_bytes()
    magic, version, length = struct.unpack_from("<III", raw, 0)
    assert (magic, version, length) == (0x46546C67, 2, len(raw))
    json_len, json_type = struct.unpack_from("<II", raw, 12)
    assert json_type == 0x4E4F534A and json_len % 4 == 0
    text = raw[20:20 + json_len]
    assert text == text.rstrip(b" ") + b" " * (len(text) - len(text.rstrip(b" ")))
    doc = json.loads(text)
    bin_len, bin_type = struct.unpack_from("<II", raw, 20 + json_len)
    assert bin_type == 0x004E4942 and bin_len % 4 == 0
    blob = raw[28 + json_len:28 + json_len + bin_len]
    assert 28 + json_len + bin_len == len(raw)
    assert doc["buffers"] == [{"byteLength": len(blob)}]
    return doc, blob


def _read(doc: dict, blob: bytes, index: int) -> np.ndarray:
    acc = doc["accessors"][index]
    view = doc["bufferViews"][acc["bufferView"]]
    width = _COMPONENTS[acc["type"]]
    dtype = np.dtype(_DTYPES[acc["componentType"]])
    start = view["byteOffset"] + acc.get("byteOffset", 0)
    assert start % dtype.itemsize == 0
    assert acc.get("byteOffset", 0) + acc["count"] * width * dtype.itemsize <= view["byteLength"]
    return np.frombuffer(blob, dtype, acc["count"] * width, start).reshape(acc["count"], width)


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    return Rotation.from_quat(q).as_matrix()  # scipy's quaternions are (x, y, z, w) too


def _world_from_gltf(doc: dict, blob: bytes, frame: int) -> np.ndarray:
    """Joint world positions at a frame, from node TRS and animation samplers alone."""
    nodes = doc["nodes"]
    local = {}
    for i, node in enumerate(nodes):
        local[i] = {"translation": np.array(node.get("translation", [0, 0, 0]), float),
                    "rotation": np.array(node.get("rotation", [0, 0, 0, 1]), float)}
    anim = doc["animations"][0]
    for ch in anim["channels"]:
        out = _read(doc, blob, anim["samplers"][ch["sampler"]]["output"])
        local[ch["target"]["node"]][ch["target"]["path"]] = out[frame].astype(float)
    world = {}

    def visit(i: int, parent: np.ndarray) -> None:
        m = np.eye(4)
        m[:3, :3] = _quat_matrix(local[i]["rotation"])
        m[:3, 3] = local[i]["translation"]
        world[i] = parent @ m
        for c in nodes[i].get("children", []):
            visit(c, world[i])

    for root in doc["scenes"][doc["scene"]]["nodes"]:
        visit(root, np.eye(4))
    joints = doc["skins"][0]["joints"]
    return np.array([world[j] for j in joints])


@pytest.fixture(scope="module")
def canter(tmp_path_factory):
    poses = generate_gait(HORSE, "canter", N_FRAMES, noise_deg=2.0, seed=4)
    path = tmp_path_factory.mktemp("glb") / "canter.glb"
    write_glb(path, HORSE, poses, FPS)
    doc, blob = _parse_glb(path)
    return path, poses, doc, blob


def test_loads_in_trimesh_as_one_skinned_mesh(canter):
    path, _, doc, _ = canter
    scene = trimesh.load(path)
    assert isinstance(scene, trimesh.Scene)
    (mesh,) = scene.geometry.values()
    n_bones = len(HORSE.bone_ellipsoids())
    assert n_bones == 40 and len(mesh.vertices) == 162 * n_bones
    assert len(doc["meshes"]) == 1 and len(doc["meshes"][0]["primitives"]) == 1
    mesh_node = next(n for n in doc["nodes"] if "mesh" in n)
    assert mesh_node["skin"] == 0 and doc["asset"]["version"] == "2.0"


def test_skin_covers_every_joint_with_inverse_bind_matrices(canter):
    _, _, doc, blob = canter
    (skin,) = doc["skins"]
    assert skin["joints"] == list(range(HORSE.n_joints)) and HORSE.n_joints == 45
    assert [doc["nodes"][j]["name"] for j in skin["joints"]] == list(HORSE.joint_names)
    ibm = _read(doc, blob, skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    rest = HORSE.forward_kinematics(HORSE.rest_pose())
    np.testing.assert_allclose(ibm @ rest, np.tile(np.eye(4), (45, 1, 1)), atol=1e-6)
    prim = doc["meshes"][0]["primitives"][0]
    joints = _read(doc, blob, prim["attributes"]["JOINTS_0"])
    weights = _read(doc, blob, prim["attributes"]["WEIGHTS_0"])
    assert joints.max() < HORSE.n_joints and np.all(weights.sum(axis=1) == 1.0)
    carriers = {e.joint for e in HORSE.bone_ellipsoids()}
    assert set(np.unique(joints[:, 0])) == carriers


def test_animation_has_a_key_per_frame_for_each_channel(canter):
    _, _, doc, blob = canter
    (anim,) = doc["animations"]
    rotating = [i for i, j in enumerate(HORSE.joints) if "rz" in j.channels]
    targets = sorted((c["target"]["node"], c["target"]["path"]) for c in anim["channels"])
    assert targets == sorted([(0, "translation")] + [(j, "rotation") for j in rotating])
    for sampler in anim["samplers"]:
        assert sampler["interpolation"] == "LINEAR"
        times = _read(doc, blob, sampler["input"])[:, 0]
        np.testing.assert_allclose(times, np.arange(N_FRAMES) / FPS, rtol=1e-7)
        assert doc["accessors"][sampler["output"]]["count"] == N_FRAMES
        out = _read(doc, blob, sampler["output"])
        if out.shape[1] == 4:  # unit quaternions, consecutive ones on the same hemisphere
            np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0, atol=1e-6)
            assert np.all(np.sum(out[1:] * out[:-1], axis=1) > 0)


@pytest.mark.parametrize("frame", [0, 7, 18, N_FRAMES - 1])
def test_node_transforms_reproduce_forward_kinematics(canter, frame):
    _, poses, doc, blob = canter
    world = _world_from_gltf(doc, blob, frame)
    np.testing.assert_allclose(world[:, :3, 3], HORSE.joint_positions(poses[frame]), atol=1e-5)


def test_skinned_vertices_follow_their_bones(canter):
    """Linear blend skinning at a frame puts each ellipsoid where the renderer draws it."""
    _, poses, doc, blob = canter
    frame = 11
    joint_world = _world_from_gltf(doc, blob, frame)
    ibm = _read(doc, blob, doc["skins"][0]["inverseBindMatrices"]).reshape(-1, 4, 4)
    skin = joint_world @ ibm.transpose(0, 2, 1)
    prim = doc["meshes"][0]["primitives"][0]
    bind = _read(doc, blob, prim["attributes"]["POSITION"]).astype(float)
    joint = _read(doc, blob, prim["attributes"]["JOINTS_0"])[:, 0]
    posed = np.einsum("vij,vj->vi", skin[joint], np.c_[bind, np.ones(len(bind))])[:, :3]
    fk = HORSE.forward_kinematics(poses[frame])
    for k, e in enumerate(HORSE.bone_ellipsoids()):
        centre = posed[162 * k:162 * (k + 1)].mean(axis=0)
        np.testing.assert_allclose(centre, (fk[e.joint] @ np.append(e.center, 1))[:3], atol=1e-5)


def test_accessor_bounds_are_valid(canter):
    _, _, doc, blob = canter
    prim = doc["meshes"][0]["primitives"][0]
    must = {prim["attributes"]["POSITION"]} | {s["input"] for s in doc["animations"][0]["samplers"]}
    for i, acc in enumerate(doc["accessors"]):
        data = _read(doc, blob, i)
        view = doc["bufferViews"][acc["bufferView"]]
        assert view["byteOffset"] % 4 == 0 and view["byteOffset"] + view["byteLength"] <= len(blob)
        if i in must:
            assert "min" in acc and "max" in acc
        if "min" in acc:
            lo, hi = np.array(acc["min"]), np.array(acc["max"])
            assert lo.shape == hi.shape == (data.shape[1],) and np.all(lo <= hi)
            np.testing.assert_array_equal(data.min(axis=0), lo)  # exact, not just enclosing
            np.testing.assert_array_equal(data.max(axis=0), hi)
    indices = _read(doc, blob, prim["indices"])
    assert indices.max() < doc["accessors"][prim["attributes"]["POSITION"]]["count"]


def test_quaternions_match_the_euler_matrices():
    angles = np.random.default_rng(1).uniform(-360, 360, (500, 3))
    np.testing.assert_allclose(_quat_matrix(quaternions_zxy(angles)), euler_zxy_matrix(angles),
                               atol=1e-12)


def test_skeleton_without_bones_has_no_mesh(tmp_path):
    skel = Skeleton.from_json({"format": "gaitstudio-skeleton", "version": 1, "joints": [
        {"name": "r", "parent": None, "offset": [0, 1, 0], "channels": ["ty", "rz"]},
        {"name": "a", "parent": "r", "offset": [1, 0, 0], "channels": []}]})
    write_glb(tmp_path / "s.glb", skel, np.array([[0.0, 0.0], [0.5, 90.0]]), 10.0)
    doc, blob = _parse_glb(tmp_path / "s.glb")
    assert "meshes" not in doc and len(doc["skins"][0]["joints"]) == 2
    world = _world_from_gltf(doc, blob, 1)
    np.testing.assert_allclose(world[:, :3, 3], skel.joint_positions([0.5, 90.0]), atol=1e-6)


@pytest.mark.parametrize("poses, fps, message", [
    (np.zeros((0, 117)), 24.0, "at least one frame"),
    (np.zeros((2, 5)), 24.0, "k = 117 channels"),
    (np.full((2, 117), np.nan), 24.0, "NaN"),
    (np.zeros((2, 117)), 0.0, "frame rate"),
])
def test_bad_input(tmp_path, poses, fps, message):
    with pytest.raises(GaitInputError, match=message):
        write_glb(tmp_path / "x.glb", HORSE, poses, fps)
