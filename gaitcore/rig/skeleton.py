"""Joint hierarchies: loading, forward kinematics, mirroring and bone shapes.

Conventions, fixed for the whole package:

- lengths in metres; Y up, X the direction of travel, Z lateral. The side camera sits on +Z
  and looks along -Z, so the image plane is XY and Z is perpendicular to it. An animal facing
  +X has its right side on +Z ("R" joints), facing the camera.
- every joint has a local frame: ``world(j) = world(parent) @ T(offset) @ R`` with
  ``R = Rz(rz) @ Rx(rx) @ Ry(ry)`` (BVH "Zrotation Xrotation Yrotation"), angles in degrees.
  The root also translates: its position is ``offset + (tx, ty, tz)``, so the all-zero pose is
  the rest pose of the template.
- a pose is a flat float vector laid out as :attr:`Skeleton.channel_names`, e.g.
  ``["root.tx", "root.ty", "root.tz", "root.rz", "root.rx", "root.ry", "spine1.rz", ...]``.

The JSON file format (``"format": "gaitstudio-skeleton"``, ``"version": 1``) is documented in
:meth:`Skeleton.from_json`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.rig.rotations import euler_zxy_matrix
from gaitcore.schema import JsonValue, describe, dump_json, read_json

FORMAT = "gaitstudio-skeleton"
VERSION = 1
CHANNEL_ORDER = ("tx", "ty", "tz", "rz", "rx", "ry")
"""Allowed channels in the order they must appear; rotations compose as Rz @ Rx @ Ry."""
ROTATION_CHANNELS = ("rz", "rx", "ry")
BONE_LENGTH_SCALE = 1.1
BONE_END_ROUNDING = 0.6
"""A bone ellipsoid's half-length along the bone is BONE_LENGTH_SCALE * length / 2 plus
BONE_END_ROUNDING * its smaller radius, so that neighbouring ellipsoids overlap at the joints
and thick short bones (the trunk) merge into one body instead of a string of discs."""
MAX_JOINTS = 100_000
"""Joints a skeleton file may hold (rigs have tens to a few hundred)."""
MAX_SKELETON_BYTES = 256 << 20
MAX_OFFSET_M = 1000.0
"""The farthest a joint may sit from its parent, metres (the largest animal is 30 m long):
beyond, the numbers are a unit mistake or damage, and the rig's arithmetic breaks down."""


@dataclass(frozen=True)
class Joint:
    """One joint of a skeleton, as stored in the JSON file.

    Attributes
    ----------
    name : str
    parent : str or None
        None for the root only.
    offset : tuple of 3 float
        Position of the joint in its parent's frame at rest, metres (the root's rest position
        in the world).
    channels : tuple of str
        Subset of ``("tx", "ty", "tz", "rz", "rx", "ry")`` in that order; translations only on
        the root; empty for end sites.
    limits : dict of str to (float, float)
        Optional (lower, upper) bounds in degrees per rotation channel.
    side : {"L", "R", "C"}
        Left (-Z), right (+Z, facing the side camera) or centre.
    mirror : str or None
        Name of the joint on the other side (required for "L"/"R" joints).
    bone_radii : tuple of 2 float or None
        Half-widths (in the XY plane, along Z) of the ellipsoid drawn for the bone from the
        parent to this joint, metres; None when the bone is not drawn.
    bone_color : tuple of 3 float
        RGB in [0, 1] of that ellipsoid.
    """

    name: str
    parent: str | None
    offset: tuple[float, float, float]
    channels: tuple[str, ...]
    limits: dict[str, tuple[float, float]] = field(default_factory=dict)
    side: str = "C"
    mirror: str | None = None
    bone_radii: tuple[float, float] | None = None
    bone_color: tuple[float, float, float] = (0.5, 0.5, 0.5)


@dataclass(frozen=True)
class BoneEllipsoid:
    """An ellipsoid drawn for one bone, riding rigidly on the frame of ``joint``.

    Attributes
    ----------
    joint : int
        Index of the joint whose world transform carries the ellipsoid (the bone's parent end).
    child : int
        Index of the joint at the other end of the bone.
    center : ndarray of shape (3,)
        Centre in the joint's local frame, metres.
    axes : ndarray of shape (3, 3)
        Unit semi-axis directions as columns (along the bone, in-plane normal, lateral).
    radii : ndarray of shape (3,)
        Semi-axis lengths, metres.
    color : tuple of 3 float
    """

    joint: int
    child: int
    center: np.ndarray
    axes: np.ndarray
    radii: np.ndarray
    color: tuple[float, float, float]

    def world_box(self, world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Its centre and its half-extent along each world axis in a pose whose joint
        transforms are ``world`` (J, 4, 4): the box that holds it, shape (3,) each."""
        rot = world[self.joint, :3, :3]
        semi = rot @ (self.axes * self.radii)  # world semi-axes as columns
        return rot @ self.center + world[self.joint, :3, 3], np.sqrt((semi ** 2).sum(axis=1))


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A validated joint hierarchy (parents listed before children).

    Build one with :meth:`from_json` or :func:`gaitcore.rig.templates.load_template`.

    Attributes
    ----------
    name : str
    joints : tuple of Joint
    channel_names : tuple of str
        ``"<joint>.<channel>"`` for every channel, in pose-vector order.
    parents : ndarray of int, shape (J,)
        Parent index per joint, -1 for the root.
    offsets : ndarray of shape (J, 3)
    """

    name: str
    joints: tuple[Joint, ...]
    channel_names: tuple[str, ...] = field(init=False)
    parents: np.ndarray = field(init=False, repr=False)
    offsets: np.ndarray = field(init=False, repr=False)
    _chan_joint: np.ndarray = field(init=False, repr=False)
    _chan_slot: np.ndarray = field(init=False, repr=False)
    _joint_at: dict[str, int] = field(init=False, repr=False)
    _channel_at: dict[str, int] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        _validate(self.joints)
        index = {j.name: i for i, j in enumerate(self.joints)}
        names, cj, cs = [], [], []
        for i, joint in enumerate(self.joints):
            for ch in joint.channels:
                names.append(f"{joint.name}.{ch}")
                cj.append(i)
                cs.append(CHANNEL_ORDER.index(ch))  # slots 0..2 translation, 3..5 rz, rx, ry
        parents = np.array([-1 if j.parent is None else index[j.parent] for j in self.joints])
        object.__setattr__(self, "channel_names", tuple(names))
        object.__setattr__(self, "_joint_at", index)
        object.__setattr__(self, "_channel_at", {c: i for i, c in enumerate(names)})
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", np.array([j.offset for j in self.joints], float))
        object.__setattr__(self, "_chan_joint", np.array(cj, dtype=int))
        object.__setattr__(self, "_chan_slot", np.array(cs, dtype=int))

    # ---------------------------------------------------------------- construction, I/O
    @classmethod
    def from_json(cls, source: str | Path | Mapping[str, Any]) -> Skeleton:
        """Load a skeleton from a JSON file path or an already parsed mapping.

        The document holds ``"format": "gaitstudio-skeleton"``, ``"version": 1``, ``"name"``
        and ``"joints"``: a list, parents first, of objects with ``name``, ``parent`` (null for
        the root), ``offset`` [x, y, z] in metres in the parent frame, ``channels`` (subset of
        tx ty tz rz rx ry in that order), optional ``limits`` {"rz": [lo, hi], ...} in degrees,
        ``side`` ("L", "R" or "C"), ``mirror`` (partner name for L/R joints) and optional
        ``bone`` {"radii": [in_plane, lateral], "color": [r, g, b]} for the ellipsoid drawn
        from the parent to the joint. Informative keys (units, axes) are checked when present.

        Raises
        ------
        GaitInputError
            Unreadable file, wrong format or version, or an invalid joint list (unknown
            parent, cycle, duplicate name, bad channels, limits or mirror partners).
        """
        if isinstance(source, JsonValue):
            doc = source
        elif isinstance(source, Mapping):
            doc = JsonValue(dict(source), "skeleton")
        else:
            doc = read_json(source, what="skeleton file", max_bytes=MAX_SKELETON_BYTES)
        if not isinstance(doc.value, dict):
            raise doc.fail("a JSON object with a 'joints' list")
        found = (doc.value.get("format"), doc.value.get("version"))
        if found != (FORMAT, VERSION) or isinstance(found[1], bool):
            raise GaitInputError(f"{doc.what}: expected format {FORMAT!r} version {VERSION}, "
                                 f"got {describe(found[0])} version {describe(found[1])}")
        for key, want in (("units", "m"), ("up_axis", "Y"), ("forward_axis", "X"),
                          ("rotation_order", "ZXY"), ("angle_units", "deg")):
            if doc.has(key) and doc.value[key] != want:
                raise doc.key(key).fail(repr(want))
        items = doc.key("joints").items(min_len=1, max_len=MAX_JOINTS)
        joints = tuple(_parse_joint(item) for item in items)
        return cls(name=doc.key("name", "skeleton").text(max_len=256), joints=joints)

    def to_dict(self) -> dict[str, Any]:
        """The JSON document of this skeleton (see :meth:`from_json`)."""
        out = []
        for j in self.joints:
            item: dict[str, Any] = {"name": j.name, "parent": j.parent,
                                    "offset": list(j.offset), "channels": list(j.channels),
                                    "side": j.side}
            if j.mirror is not None:
                item["mirror"] = j.mirror
            if j.limits:
                item["limits"] = {k: list(v) for k, v in j.limits.items()}
            if j.bone_radii is not None:
                item["bone"] = {"radii": list(j.bone_radii), "color": list(j.bone_color)}
            out.append(item)
        return {"format": FORMAT, "version": VERSION, "name": self.name, "units": "m",
                "up_axis": "Y", "forward_axis": "X", "rotation_order": "ZXY",
                "angle_units": "deg", "joints": out}

    def to_json(self, path: str | Path | None = None) -> str:
        """JSON text of :meth:`to_dict`, one joint per line; also written to ``path`` if given."""
        doc = self.to_dict()
        joints = doc.pop("joints")
        head = dump_json(doc, indent=2, what=f"skeleton {self.name}")[:-2]
        body = ",\n".join("    " + dump_json(j, what=f"skeleton {self.name}") for j in joints)
        text = f'{head},\n  "joints": [\n{body}\n  ]\n}}\n'
        if path is not None:
            Path(path).write_text(text, encoding="utf-8")
        return text

    # ---------------------------------------------------------------- lookups
    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def n_channels(self) -> int:
        return len(self.channel_names)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    def joint_index(self, name: str) -> int:
        """Index of the joint called ``name``; GaitInputError if there is none."""
        try:
            return self._joint_at[name]
        except KeyError:
            raise GaitInputError(f"skeleton {self.name!r} has no joint {name!r}") from None

    def channel_index(self, name: str) -> int:
        """Index in the pose vector of channel ``name`` ("<joint>.<channel>")."""
        try:
            return self._channel_at[name]
        except KeyError:
            raise GaitInputError(f"skeleton {self.name!r} has no channel {name!r}") from None

    def channel_indices(self, channel: str) -> np.ndarray:
        """Pose-vector indices of every channel of one kind ("rz", "tx", ...), joint order."""
        return np.array([i for i, n in enumerate(self.channel_names)
                         if n.rsplit(".", 1)[1] == channel], dtype=int)

    @property
    def sagittal_angle_indices(self) -> np.ndarray:
        """Indices of the angles about Z, the axis perpendicular to the side-view image.

        These are the angles the paper's Section 4 evaluates (36 on its horse).
        """
        return self.channel_indices("rz")

    def limits_array(self) -> np.ndarray:
        """(k, 2) lower and upper bound per channel, degrees; +-inf where unbounded."""
        lim = np.tile([-np.inf, np.inf], (self.n_channels, 1))
        for i, name in enumerate(self.channel_names):
            joint, ch = name.rsplit(".", 1)
            bounds = self.joints[self.joint_index(joint)].limits.get(ch)
            if bounds is not None:
                lim[i] = bounds
        return lim

    def rest_pose(self) -> np.ndarray:
        """The all-zero pose vector, shape (k,)."""
        return np.zeros(self.n_channels)

    # ---------------------------------------------------------------- kinematics
    def forward_kinematics(self, poses: np.ndarray) -> np.ndarray:
        """World transforms of every joint.

        Parameters
        ----------
        poses : array_like of shape (k,) or (n, k)
            Pose vectors (metres, degrees), laid out as :attr:`channel_names`.

        Returns
        -------
        ndarray of shape (J, 4, 4) or (n, J, 4, 4)
            Homogeneous joint-to-world transforms.

        Raises
        ------
        GaitInputError
            Wrong last dimension or non-finite values.
        """
        p = self._check_poses(poses)
        single = p.ndim == 1
        p = np.atleast_2d(p)
        n = p.shape[0]
        params = np.zeros((n, self.n_joints, 6))
        params[:, self._chan_joint, self._chan_slot] = p
        local = np.zeros((n, self.n_joints, 4, 4))
        local[..., :3, :3] = euler_zxy_matrix(params[..., 3:])
        local[..., :3, 3] = self.offsets + params[..., :3]
        local[..., 3, 3] = 1.0
        world = np.empty_like(local)
        for j, parent in enumerate(self.parents):
            world[:, j] = local[:, j] if parent < 0 else world[:, parent] @ local[:, j]
        return world[0] if single else world

    def joint_positions(self, poses: np.ndarray) -> np.ndarray:
        """World joint positions, shape (J, 3) or (n, J, 3), metres."""
        return self.forward_kinematics(poses)[..., :3, 3]

    def mirror_pose(self, poses: np.ndarray) -> np.ndarray:
        """Mirror poses about the sagittal plane (Z -> -Z), swapping left and right joints.

        With R = Rz Rx Ry, reflecting Z keeps rz and negates rx, ry; root.tz is negated.

        Parameters
        ----------
        poses : array_like of shape (k,) or (n, k)

        Returns
        -------
        ndarray of the same shape
        """
        p = self._check_poses(poses)
        perm, sign = self._mirror_map()
        out = np.empty_like(p)
        out[..., perm] = p * sign
        return out

    def bone_ellipsoids(self) -> tuple[BoneEllipsoid, ...]:
        """The ellipsoids to draw, one per joint whose JSON entry has a ``bone``.

        The ellipsoid of the bone parent -> joint is centred half-way along the bone in the
        parent's frame, elongated along it (see BONE_LENGTH_SCALE, BONE_END_ROUNDING)
        and carried by the parent's world transform.
        """
        out = []
        for i, joint in enumerate(self.joints):
            if joint.bone_radii is None:
                continue
            off = np.asarray(joint.offset, float)
            length = float(np.linalg.norm(off))
            along = off / length
            ref = np.array([0.0, 0.0, 1.0]) if abs(along[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
            normal = np.cross(ref, along)
            normal /= np.linalg.norm(normal)
            lateral = np.cross(along, normal)
            along_r = 0.5 * length * BONE_LENGTH_SCALE + BONE_END_ROUNDING * min(joint.bone_radii)
            radii = np.array([along_r, *joint.bone_radii])
            out.append(BoneEllipsoid(int(self.parents[i]), i, off / 2,
                                     np.column_stack([along, normal, lateral]), radii,
                                     tuple(joint.bone_color)))
        return tuple(out)

    # ---------------------------------------------------------------- helpers
    def _check_poses(self, poses: np.ndarray) -> np.ndarray:
        p = np.asarray(poses, dtype=float)
        if p.ndim not in (1, 2) or p.shape[-1] != self.n_channels:
            raise GaitInputError(
                f"pose array has shape {p.shape}; skeleton {self.name!r} needs (k,) or (n, k) "
                f"with k = {self.n_channels} channels"
            )
        if not np.all(np.isfinite(p)):
            raise GaitInputError("pose array contains NaN or infinite values")
        return p

    def _mirror_map(self) -> tuple[np.ndarray, np.ndarray]:
        perm = np.empty(self.n_channels, dtype=int)
        sign = np.ones(self.n_channels)
        for i, name in enumerate(self.channel_names):
            joint, ch = name.rsplit(".", 1)
            partner = self.joints[self.joint_index(joint)].mirror or joint
            perm[i] = self.channel_index(f"{partner}.{ch}")
            if ch in ("tz", "rx", "ry"):
                sign[i] = -1.0
        return perm, sign


def _parse_joint(item: JsonValue) -> Joint:
    name = item.key("name").text(max_len=256)
    if not name or "." in name:
        raise item.key("name").fail("a non-empty name without dots")
    offset = item.key("offset").floats(length=3)
    channels = tuple(c.text(max_len=2) for c in item.key("channels", []).items(max_len=6))
    limits = {}
    raw_limits = item.key("limits", None)
    if not raw_limits.is_null():
        for ch, bounds in raw_limits.entries(max_len=6):
            lo, hi = bounds.floats(length=2)
            limits[ch] = (lo, hi)
    radii, color = None, (0.5, 0.5, 0.5)
    bone = item.key("bone", None)
    if not bone.is_null():
        radii = bone.key("radii").floats(length=2)
        color = bone.key("color", [0.5, 0.5, 0.5]).floats(length=3)
        if min(radii) <= 0:
            raise bone.key("radii").fail("two positive numbers")
    return Joint(name, item.key("parent", None).text(max_len=256, optional=True), offset,
                 channels, limits, item.key("side", "C").text(max_len=1),
                 item.key("mirror", None).text(max_len=256, optional=True), radii, color)


def _validate(joints: tuple[Joint, ...]) -> None:
    index: dict[str, int] = {}
    for i, j in enumerate(joints):
        if j.name in index:
            raise GaitInputError(f"duplicate joint name {j.name!r}; every joint needs its own")
        index[j.name] = i
    for j in joints:
        if j.parent is not None and j.parent not in index:
            raise GaitInputError(f"joint {j.name!r} has unknown parent {j.parent!r}")
    _refuse_cycles(joints, index)
    roots = [j.name for j in joints if j.parent is None]
    if roots != [joints[0].name]:
        raise GaitInputError(f"the first joint must be the only root (parent null), got {roots}")
    for i, j in enumerate(joints):
        if j.parent is not None and index[j.parent] > i:
            raise GaitInputError(
                f"joint {j.name!r} is listed before its parent; list parents first")
        _validate_channels(j)
        if not all(abs(v) <= MAX_OFFSET_M for v in j.offset):
            far = max(j.offset, key=abs)
            raise GaitInputError(f"joint {j.name!r}: an offset of {far:g} m is beyond the "
                                 f"{MAX_OFFSET_M:g} m any rig spans: is the file in other units?")
        if j.bone_radii is not None and (j.parent is None or not any(j.offset)):
            raise GaitInputError(f"joint {j.name!r}: a bone needs a parent and a non-zero offset")
    for j in joints:
        if j.side not in ("L", "R", "C"):
            raise GaitInputError(f"joint {j.name!r}: side must be 'L', 'R' or 'C', got {j.side!r}")
        if j.side == "C":
            if j.mirror not in (None, j.name):
                raise GaitInputError(f"centre joint {j.name!r} cannot have mirror {j.mirror!r}")
            continue
        partner = joints[index[j.mirror]] if j.mirror in index else None
        if partner is None or partner.mirror != j.name or partner.side == j.side or \
                partner.side == "C" or partner.channels != j.channels:
            raise GaitInputError(
                f"joint {j.name!r} (side {j.side}) needs a mirror partner on the other side "
                f"that names it back and has the same channels; got mirror {j.mirror!r}"
            )


def _refuse_cycles(joints: tuple[Joint, ...], index: dict[str, int]) -> None:
    """Raise when walking up the parents from some joint never reaches a root.

    Each joint is visited once: a walk stops at the first joint already known to reach a
    root, so the check is linear in the number of joints, whatever the depth.
    """
    reaches_root = [False] * len(joints)
    for start in range(len(joints)):
        path, on_path, cur = [], set(), start
        while not reaches_root[cur] and joints[cur].parent is not None:
            if cur in on_path:
                raise GaitInputError(f"joint hierarchy has a cycle through {joints[cur].name!r}")
            path.append(cur)
            on_path.add(cur)
            cur = index[joints[cur].parent]
        for k in path + [cur]:
            reaches_root[k] = True


def _validate_channels(j: Joint) -> None:
    problem = _channel_problem(j.channels, j.parent is None)
    if problem:
        raise GaitInputError(f"joint {j.name!r}: {problem}")
    for ch, (lo, hi) in j.limits.items():
        if ch not in j.channels or ch not in ROTATION_CHANNELS or not lo <= hi:
            raise GaitInputError(f"joint {j.name!r}: limits for {ch!r} must name one of its "
                                 f"rotation channels with lower <= upper")


@lru_cache(maxsize=256)
def _channel_problem(chans: tuple[str, ...], root: bool) -> str:
    """What is wrong with a joint's channel list ("" when nothing); rigs repeat a few lists."""
    if any(c not in CHANNEL_ORDER for c in chans) or len(set(chans)) != len(chans):
        return f"channels {list(chans)} must be distinct names from {list(CHANNEL_ORDER)}"
    if list(chans) != sorted(chans, key=CHANNEL_ORDER.index):
        return f"channels must follow the order {list(CHANNEL_ORDER)} (rotation order Z, X, Y)"
    if not root and any(c.startswith("t") for c in chans):
        return "only the root may have translation channels"
    return ""
