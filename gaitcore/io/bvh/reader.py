"""BVH (Biovision hierarchy) import: any rig an artist brings (Blender, Maya, mocap).

Any channel order per joint, 3 or 6 channels, End Sites, CRLF or tabs. Joints whose rotation
order is not Z X Y are converted exactly through their rotation matrices into the skeleton's
fixed order (R = Rz Rx Ry, :mod:`gaitcore.rig.skeleton`); root positions are read as absolute.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.io.bvh.hierarchy import Node, parse_hierarchy
from gaitcore.io.pose_table import PoseTable
from gaitcore.rig.rotations import axis_matrix, continuous_zxy
from gaitcore.rig.skeleton import Joint, Skeleton
from gaitcore.schema import MAX_FPS, MIN_FPS, is_number, read_text

_OUR_ROTATION_ORDER = "zxy"
_SIDE_WORDS = (("Left", "Right"), ("left", "right"), ("LEFT", "RIGHT"))
_SIDE_RULES = (
    # (pattern matching the side marker, groups: before, marker, after)
    re.compile(r"^(.*?)(?<![A-Za-z])(Left|left|LEFT|Right|right|RIGHT)(.*)$"),
    re.compile(r"^()([LlRr])((?:[_\-: ]|[A-Z]).*)$"),
    re.compile(r"^(.*[_\-: ])([LlRr])()$"),
)
MAX_BVH_BYTES = 2 << 30
DEFAULT_BONE_RATIO = 0.12
"""Radius of the ellipsoid drawn for a bone read from a BVH, as a fraction of its length
(BVH files carry no bone shapes)."""
TRANSLATION_TOLERANCE = 1e-4
"""A non-root joint may carry position channels (Blender writes them on unconnected bones)
if they stay within this many file units of their first value: they then become its offset."""


def read_bvh(path: str | Path, *, scale: float = 1.0,
             bone_ratio: float = DEFAULT_BONE_RATIO) -> tuple[Skeleton, PoseTable, float]:
    """Read a BVH file (from Blender, Maya, MotionBuilder, a mocap system...) into a skeleton.

    Parameters
    ----------
    path : str or Path
    scale : float
        Factor from the file's length unit to metres (e.g. 0.01 for centimetres).
    bone_ratio : float
        Radius of the ellipsoid drawn for each bone, as a fraction of the bone's length; 0
        draws none (BVH files carry no bone shapes).

    Returns
    -------
    skeleton : Skeleton
        Joints in file order. End Sites become channel-less joints named
        ``<parent>_end`` (BVH End Sites have no names). Dots and spaces in joint names become
        underscores. Joints whose names say left/right (``LeftArm``/``RightArm``,
        ``L_hip``/``R_hip``, ``thigh.L``/``thigh.R``...) are paired as mirror partners.
    table : PoseTable
        One row per motion frame (frames 0..n-1), columns ``skeleton.channel_names``, metres
        and degrees.
    fps : float
        1 / Frame Time.

    Raises
    ------
    GaitInputError
        With the line number: not a BVH file, unbalanced braces, a joint without OFFSET or
        CHANNELS, a JOINT outside the ROOT, an unknown or repeated channel, a non-root joint
        whose position channels move, a Frames count that does not match the motion lines, a
        motion line with too few or too many values, or a value that is not a finite number.

    Notes
    -----
    Position channels give the joint's translation in its parent's frame, replacing its
    OFFSET (Blender's and Biovision's reading): the root's rest position is its OFFSET and
    ``root.tx`` = Xposition - OFFSET x. Rotation channels compose in the order listed,
    ``R = R1 @ R2 @ R3``. Our joints rotate as ``Rz @ Rx @ Ry``: a joint listed in that order
    (or a sub-sequence of it) keeps its angles exactly; any other order is converted exactly
    through the rotation matrix, choosing among the equivalent (rz, rx, ry) triples the one
    closest to the previous frame so that curves have no 360-degree jumps.
    """
    path = Path(path)
    if not scale > 0 or not 0 <= bone_ratio < 10:
        raise GaitInputError(f"read_bvh: scale must be positive and bone_ratio within 0..10, "
                             f"got scale={scale}, bone_ratio={bone_ratio}")
    text = read_text(path, what="BVH file", max_bytes=MAX_BVH_BYTES, encoding="utf-8-sig",
                     fallback="latin-1")
    lines = text.splitlines()
    del text
    nodes, n_columns, motion_line = parse_hierarchy(lines, str(path))
    motion, frame_time, digits = _parse_motion(lines, motion_line, n_columns, str(path))
    skeleton, values = _build_skeleton(nodes, motion, scale, bone_ratio, path)
    table = PoseTable(np.arange(len(motion)), skeleton.channel_names, values)
    return skeleton, table, _frame_rate(frame_time, digits)


def _parse_motion(lines: list[str], motion_line: int, n_columns: int,
                  where: str) -> tuple[np.ndarray, float, int]:
    """The motion matrix (frames, columns), the frame time in seconds and its decimals."""
    rows = [(i + 1, ln) for i, ln in enumerate(lines[motion_line + 1:], start=motion_line + 1)
            if ln.strip()]
    after = lines[motion_line].split(None, 1)  # text after MOTION on its own line, if any
    if len(after) > 1:
        rows.insert(0, (motion_line + 1, after[1]))
    header: dict[str, float] = {}
    for key, pattern in (("frames", r"^\s*frames\s*:\s*(\S+)\s*$"),
                         ("time", r"^\s*frame\s+time\s*:\s*(\S+)\s*$")):
        if not rows:
            raise GaitInputError(f"{where}: MOTION must be followed by 'Frames: N' and "
                                 "'Frame Time: seconds' lines")
        number, text = rows.pop(0)
        m = re.match(pattern, text, re.IGNORECASE)
        try:
            value = float(m.group(1)) if m else None
        except ValueError:
            value = None
        if m and key == "time":
            digits = len(m.group(1).partition(".")[2])
        if value is None:
            expected = "Frames: N" if key == "frames" else "Frame Time: seconds"
            raise GaitInputError(f"{where}, line {number}: expected '{expected}', "
                                 f"found {text.strip()[:40]!r}")
        header[key] = value
    frames, frame_time = header["frames"], header["time"]
    if not (np.isfinite(frames) and frames == int(frames) and frames >= 0):
        raise GaitInputError(f"{where}: 'Frames:' must be a whole number, got {frames:g}")
    if not (np.isfinite(frame_time) and 1.0 / MAX_FPS <= frame_time <= 1.0 / MIN_FPS):
        raise GaitInputError(f"{where}: 'Frame Time:' must be a number of seconds from "
                             f"{1.0 / MAX_FPS:g} to {1.0 / MIN_FPS:g}, got {frame_time:g}")
    if len(rows) != frames:
        raise GaitInputError(
            f"{where}: 'Frames: {int(frames)}' but the file has {len(rows)} motion line(s); "
            "fix the Frames line or re-export the file (it may be truncated)")
    motion = np.empty((len(rows), n_columns))
    for r, (number, text) in enumerate(rows):
        cells = text.split()
        if len(cells) != n_columns:
            few = "too few" if len(cells) < n_columns else "too many"
            raise GaitInputError(f"{where}, line {number}: {few} values ({len(cells)}; the "
                                 f"CHANNELS of the hierarchy add up to {n_columns})")
        try:
            motion[r] = [float(c) for c in cells]
        except ValueError:
            bad = next(c for c in cells if not is_number(c))
            raise GaitInputError(f"{where}, line {number}: {bad!r} is not a number") from None
        if not np.all(np.isfinite(motion[r])):
            raise GaitInputError(f"{where}, line {number}: NaN or infinite value; every "
                                 "channel of every frame needs a finite number")
    return motion, frame_time, digits


def _frame_rate(frame_time: float, digits: int) -> float:
    """1 / frame_time, snapped to the roundest rate that prints as the same frame time.

    Files store the frame time rounded (``0.033333``), so 1/time is 30.0003 where 30 was meant.
    """
    tolerance = 0.5 * 10.0 ** -digits if digits else 0.0
    for decimals in range(4):
        fps = round(1.0 / frame_time, decimals)
        if fps > 0 and abs(1.0 / fps - frame_time) <= tolerance * (1 + 1e-9):
            return fps
    return 1.0 / frame_time


def _build_skeleton(nodes: list[Node], motion: np.ndarray, scale: float, bone_ratio: float,
                    path: Path) -> tuple[Skeleton, np.ndarray]:
    names = _joint_names(nodes)
    converted = [_joint_motion(node, name, motion, scale, path) for node, name in zip(nodes, names)]
    sides = _mirror_pairs(names, [channels for _, channels, _ in converted])
    joints = []
    for node, name, (offset, channels, _) in zip(nodes, names, converted):
        parent = None if node.parent < 0 else names[node.parent]
        length = math.hypot(*offset)
        radii = None
        if parent is not None and length > 1e-9 and bone_ratio > 0:
            radii = (bone_ratio * length, bone_ratio * length)
        side, mirror = sides.get(name, ("C", None))
        joints.append(Joint(name, parent, tuple(offset.tolist()), channels,
                            side=side, mirror=mirror, bone_radii=radii, bone_color=(0.6, 0.6, 0.6)))
    columns = [col for _, _, cols in converted for col in cols]
    values = np.empty((len(motion), len(columns)))
    direct = [(k, col) for k, col in enumerate(columns) if isinstance(col, int)]
    if direct:  # channels kept as they are: one gather instead of a column each
        targets, sources = zip(*direct)
        values[:, list(targets)] = motion[:, list(sources)]
    for k, col in enumerate(columns):
        if not isinstance(col, int):
            values[:, k] = col
    return Skeleton(name=path.stem, joints=tuple(joints)), values


def _joint_motion(node: Node, name: str, motion: np.ndarray, scale: float,
                  path: Path) -> tuple[np.ndarray, tuple[str, ...], list[np.ndarray | int]]:
    """Offset (metres), our channels and their curves for one BVH joint (a curve is a
    column of ``motion`` when the channel is kept as it is)."""
    offset = node.offset * scale
    trans = [(a, col) for k, a, col in node.channels if k == "t"]
    rot = [(a, col) for k, a, col in node.channels if k == "r"]
    channels: list[str] = []
    columns: list[np.ndarray | int] = []
    if trans and node.parent < 0:
        for a, col in sorted(trans, key=lambda ac: "xyz".index(ac[0])):
            channels.append("t" + a)
            columns.append(motion[:, col] * scale - offset["xyz".index(a)])
    elif trans:  # Blender writes positions on unconnected bones: fold them into the offset
        local = node.offset.copy()
        for a, col in trans:
            if len(motion) and np.ptp(motion[:, col]) > TRANSLATION_TOLERANCE:
                raise GaitInputError(
                    f"{path}, line {node.line}: joint {name!r} moves (its position channels "
                    "change over time); only the root may translate here: re-export with "
                    "root translation only")
            if len(motion):
                local["xyz".index(a)] = motion[0, col]
        offset = local * scale
    axes = "".join(a for a, _ in rot)
    if rot and _is_subsequence(axes, _OUR_ROTATION_ORDER):
        channels += ["r" + a for a in axes]
        columns += [col for _, col in rot]
    elif rot:
        matrices = np.broadcast_to(np.eye(3), (len(motion), 3, 3))
        for a, col in rot:
            matrices = matrices @ axis_matrix(a, motion[:, col])
        channels += ["rz", "rx", "ry"]
        columns += list(continuous_zxy(matrices).T)
    return offset, tuple(channels), columns


def _joint_names(nodes: list[Node]) -> list[str]:
    """Unique names without dots: ours use '<joint>.<channel>' for channel names."""
    names: list[str] = []
    taken: set[str] = set()
    for k, node in enumerate(nodes):
        base = (re.sub(r"[\s.]+", "_", node.name) if not node.end_site
                else f"{names[node.parent]}_end")
        base = base or f"joint{k}"
        name, n = base, 2
        while name in taken:
            name, n = f"{base}{n}", n + 1
        taken.add(name)
        names.append(name)
    return names


def _mirror_pairs(names: list[str], channels: list[tuple[str, ...]]) -> dict[str, tuple[str, str]]:
    """(side, partner) for joints whose names mark a side, with a partner of the same channels."""
    chans = dict(zip(names, channels))
    out: dict[str, tuple[str, str]] = {}
    for name in names:
        for rule in _SIDE_RULES:
            m = rule.match(name)
            if not m:
                continue
            before, marker, after = m.groups()
            swap = {"L": "R", "R": "L", "l": "r", "r": "l"}.get(marker)
            if swap is None:
                swap = next(rt if marker == lf else lf for lf, rt in _SIDE_WORDS
                            if marker in (lf, rt))
            partner = before + swap + after
            if partner in chans and partner != name and chans[partner] == chans[name]:
                out[name] = ("L" if marker[0] in "Ll" else "R", partner)
                break
    return {n: sp for n, sp in out.items() if out.get(sp[1], ("", ""))[1] == n}


def _is_subsequence(axes: str, order: str) -> bool:
    it = iter(order)
    return len(set(axes)) == len(axes) and all(a in it for a in axes)
