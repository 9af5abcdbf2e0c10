"""Binary glTF 2.0 (.glb) export of an animated skeleton, with its ellipsoid bones as a skin.

The file holds one node per joint (rest translations, no rest rotation), a skin over those
nodes, one skinned mesh made of the bone ellipsoids (every vertex weighted fully to the joint
that carries its ellipsoid) and one animation: per frame, the root's translation and every
rotating joint's rotation as a quaternion, LINEAR, at times ``frame / fps``.

Axes and units are the skeleton's: metres, Y up (as glTF), the animal facing +X (glTF's
"front" is +Z; importers show the animal side-on from their front view). Written with numpy,
json and struct only; see the glTF 2.0 specification, section 4.4 (GLB file format).
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.io.bone_names import bone_names
from gaitcore.rig.rotations import quaternions_zxy
from gaitcore.rig.skeleton import CHANNEL_ORDER, Skeleton
from gaitcore.schema import dump_json

GLB_MAGIC = 0x46546C67  # b"glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942
FLOAT, UNSIGNED_BYTE, UNSIGNED_SHORT, UNSIGNED_INT = 5126, 5121, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
_TYPES = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}
_DTYPES = {FLOAT: np.float32, UNSIGNED_BYTE: np.uint8, UNSIGNED_SHORT: np.uint16,
           UNSIGNED_INT: np.uint32}
GENERATOR = "Gait Studio (gaitcore.io.gltf)"


def write_glb(path: str | Path, skeleton: Skeleton, poses: np.ndarray, fps: float = 24.0, *,
              subdivisions: int = 2, naming: str = "as-is") -> None:
    """Write an animated, skinned skeleton as a binary glTF file.

    Parameters
    ----------
    path : str or Path
        Output file, conventionally ``.glb``.
    skeleton : Skeleton
    poses : ndarray of shape (n, k)
        One pose per frame, laid out as ``skeleton.channel_names`` (metres, degrees).
    fps : float
        Frame rate: frame f is keyed at ``f / fps`` seconds.
    subdivisions : int
        Icosphere subdivisions per bone ellipsoid (2 = 162 vertices, 320 triangles).
    naming : {"as-is", "rigify"}
        Node names as in the skeleton or Rigify style (:func:`gaitcore.io.bone_names.bone_names`).

    Raises
    ------
    GaitInputError
        No frame, poses of the wrong width or not finite, or a non-positive frame rate.

    Notes
    -----
    Node rotations reproduce :meth:`Skeleton.forward_kinematics` exactly (up to float32):
    ``q = qz * qx * qy`` for ``R = Rz Rx Ry``, and the root translation is offset + (tx, ty,
    tz). Consecutive quaternions are kept on the same hemisphere so that LINEAR (slerp)
    interpolation takes the short way.
    """
    p = np.asarray(poses, dtype=float)
    if p.ndim != 2 or p.shape[0] == 0:
        raise GaitInputError(f"glTF export needs poses of shape (frames, channels) with at "
                             f"least one frame, got shape {p.shape}")
    skeleton.forward_kinematics(p[:1])  # validates width and finiteness with a clear message
    if not np.all(np.isfinite(p)):
        raise GaitInputError("glTF export: the poses contain NaN or infinite values")
    if not (np.isfinite(fps) and fps > 0):
        raise GaitInputError(f"frame rate must be a positive number, got {fps}")
    params = np.zeros((len(p), skeleton.n_joints, 6))  # tx ty tz rz rx ry per joint
    for i, name in enumerate(skeleton.channel_names):
        joint, ch = name.rsplit(".", 1)
        params[:, skeleton.joint_index(joint), CHANNEL_ORDER.index(ch)] = p[:, i]

    gltf = _Document()
    rest_world = skeleton.joint_positions(skeleton.rest_pose())
    nodes: list[dict[str, object]] = []
    for j, (joint, name) in enumerate(zip(skeleton.joints, bone_names(skeleton, naming))):
        node = {"name": name, "translation": [float(v) for v in joint.offset]}
        kids = [int(c) for c in np.flatnonzero(skeleton.parents == j)]
        if kids:
            node["children"] = kids
        nodes.append(node)
    skin = {"name": f"{skeleton.name}_skin", "joints": list(range(skeleton.n_joints)),
            "skeleton": 0}
    inverse_bind = np.tile(np.eye(4), (skeleton.n_joints, 1, 1))
    inverse_bind[:, :3, 3] = -rest_world
    skin["inverseBindMatrices"] = gltf.add(inverse_bind.transpose(0, 2, 1).reshape(-1, 16),
                                          FLOAT)  # column-major
    gltf.doc["skins"] = [skin]
    scene_nodes = [0]
    mesh = _bone_mesh(gltf, skeleton, rest_world, subdivisions)
    if mesh is not None:
        gltf.doc["meshes"] = [mesh]
        gltf.doc["materials"] = [{"name": "bones", "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0,
            "roughnessFactor": 0.8}}]
        nodes.append({"name": f"{skeleton.name}_bones", "mesh": 0, "skin": 0})
        scene_nodes.append(len(nodes) - 1)
    gltf.doc["nodes"] = nodes
    gltf.doc["scenes"] = [{"name": skeleton.name, "nodes": scene_nodes}]
    gltf.doc["scene"] = 0
    gltf.doc["animations"] = [_animation(gltf, skeleton, params, fps)]
    gltf.write(Path(path))


def _animation(gltf: _Document, skeleton: Skeleton, params: np.ndarray, fps: float) -> dict:
    times = gltf.add((np.arange(len(params)) / fps)[:, None], FLOAT, bounds=True)
    samplers, channels = [], []
    for j, joint in enumerate(skeleton.joints):
        paths = []
        if any(c.startswith("t") for c in joint.channels):
            paths.append(("translation", skeleton.offsets[j] + params[:, j, :3]))
        if any(c.startswith("r") for c in joint.channels):
            q = quaternions_zxy(params[:, j, 3:])
            flip = np.cumprod(np.where(np.sum(q[1:] * q[:-1], axis=1) < 0, -1.0, 1.0))
            q[1:] *= flip[:, None]
            paths.append(("rotation", q))
        for target, values in paths:
            samplers.append({"input": times, "output": gltf.add(values, FLOAT),
                             "interpolation": "LINEAR"})
            channels.append({"sampler": len(samplers) - 1,
                             "target": {"node": j, "path": target}})
    return {"name": f"{skeleton.name}_gait", "samplers": samplers, "channels": channels}


def _bone_mesh(gltf: _Document, skeleton: Skeleton, rest_world: np.ndarray,
               subdivisions: int) -> dict | None:
    """One primitive holding every bone ellipsoid at the bind (rest) pose, or None."""
    import trimesh

    ellipsoids = skeleton.bone_ellipsoids()
    if not ellipsoids:
        return None
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    unit_v, unit_n = np.asarray(sphere.vertices), np.asarray(sphere.vertex_normals)
    unit_f = np.asarray(sphere.faces)
    positions, normals, colors, joints, faces = [], [], [], [], []
    for k, e in enumerate(ellipsoids):
        shape = e.axes * e.radii  # columns: semi-axes in the joint frame
        positions.append(unit_v @ shape.T + e.center + rest_world[e.joint])
        n = unit_n @ np.linalg.inv(shape)  # normals transform by the inverse transpose
        normals.append(n / np.linalg.norm(n, axis=1, keepdims=True))
        colors.append(np.tile(e.color, (len(unit_v), 1)))
        joints.append(np.full(len(unit_v), e.joint))
        faces.append(unit_f + k * len(unit_v))
    n_vertices = len(unit_v) * len(ellipsoids)
    joint_type = UNSIGNED_BYTE if skeleton.n_joints <= 256 else UNSIGNED_SHORT
    joints_0 = np.zeros((n_vertices, 4))
    joints_0[:, 0] = np.concatenate(joints)
    weights_0 = np.zeros((n_vertices, 4))
    weights_0[:, 0] = 1.0
    index_type = UNSIGNED_SHORT if n_vertices <= 65535 else UNSIGNED_INT
    attributes = {
        "POSITION": gltf.add(np.concatenate(positions), FLOAT, bounds=True, target=ARRAY_BUFFER),
        "NORMAL": gltf.add(np.concatenate(normals), FLOAT, target=ARRAY_BUFFER),
        "COLOR_0": gltf.add(np.concatenate(colors), FLOAT, target=ARRAY_BUFFER),
        "JOINTS_0": gltf.add(joints_0, joint_type, target=ARRAY_BUFFER),
        "WEIGHTS_0": gltf.add(weights_0, FLOAT, target=ARRAY_BUFFER),
    }
    indices = gltf.add(np.concatenate(faces).reshape(-1, 1), index_type,
                       target=ELEMENT_ARRAY_BUFFER)
    return {"name": f"{skeleton.name}_bones",
            "primitives": [{"attributes": attributes, "indices": indices, "material": 0}]}


class _Document:
    """The JSON document and its single binary buffer, grown one accessor at a time."""

    def __init__(self) -> None:
        self.doc: dict = {"asset": {"version": "2.0", "generator": GENERATOR}}
        self.views: list[dict] = []
        self.accessors: list[dict] = []
        self.blob = bytearray()

    def add(self, values: np.ndarray, component: int, *, bounds: bool = False,
            target: int | None = None) -> int:
        """Append an accessor over ``values`` (rows = elements); return its index."""
        data = np.ascontiguousarray(np.asarray(values).reshape(len(values), -1),
                                    dtype=_DTYPES[component])
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": data.nbytes}
        if target is not None:
            view["target"] = target
        self.blob += data.tobytes()
        self.blob += b"\0" * (-len(self.blob) % 4)  # every view starts 4-byte aligned
        self.views.append(view)
        accessor = {"bufferView": len(self.views) - 1, "componentType": component,
                    "count": len(data), "type": _TYPES[data.shape[1]]}
        if bounds:
            accessor["min"] = [_number(v) for v in data.min(axis=0)]
            accessor["max"] = [_number(v) for v in data.max(axis=0)]
        self.accessors.append(accessor)
        return len(self.accessors) - 1

    def write(self, path: Path) -> None:
        doc = dict(self.doc, accessors=self.accessors, bufferViews=self.views,
                   buffers=[{"byteLength": len(self.blob)}])
        text = dump_json(doc, separators=(",", ":"), what=f"glTF {path}").encode("utf-8")
        text += b" " * (-len(text) % 4)
        total = 12 + 8 + len(text) + 8 + len(self.blob)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("wb") as fh:
            fh.write(struct.pack("<III", GLB_MAGIC, 2, total))
            fh.write(struct.pack("<II", len(text), CHUNK_JSON) + text)
            fh.write(struct.pack("<II", len(self.blob), CHUNK_BIN) + bytes(self.blob))


def _number(v: np.generic) -> float | int:
    """A JSON number that parses back to exactly the stored float32 or integer."""
    return int(v) if np.issubdtype(type(v), np.integer) else float(v)
