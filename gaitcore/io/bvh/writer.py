"""BVH (Biovision hierarchy) export of animation curves on a skeleton.

The hierarchy follows the skeleton's joints; rotation channels are written in the skeleton's
order, Zrotation Xrotation Yrotation (R = Rz Rx Ry, as in :mod:`gaitcore.rig.skeleton`). The
root's OFFSET is its rest position and its position channels are absolute, as Blender's
importer reads them (it subtracts the rest head), so a file read back by
:func:`gaitcore.io.bvh.reader.read_bvh` gives the same rest skeleton. Lengths are in the
skeleton's units (metres), angles in degrees.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.io.bone_names import bone_names
from gaitcore.io.pose_table import PoseTable, pose_matrix
from gaitcore.rig.skeleton import Skeleton

_BVH_CHANNEL = {
    "tx": "Xposition", "ty": "Yposition", "tz": "Zposition",
    "rz": "Zrotation", "rx": "Xrotation", "ry": "Yrotation",
}


def write_bvh(path: str | Path, skeleton: Skeleton, table: PoseTable, *, fps: float = 24.0,
              naming: str = "as-is") -> None:
    """Write the poses of ``table`` on ``skeleton`` as a BVH file.

    Parameters
    ----------
    path : str or Path
    skeleton : Skeleton
    table : PoseTable
        One row per frame, with a column for every channel of the skeleton (extra columns
        are ignored).
    fps : float
        Frame rate, written as ``Frame Time: 1/fps`` to 12 decimals, trailing zeros kept
        (Blender reads 24 fps back as exactly 24, not 23.999997; and a reader that snaps the
        rate to what the printed digits allow cannot take ``0.8``, 1.25 fps, for 1.2).
    naming : {"as-is", "rigify"}
        Joint names as in the skeleton, or with ``.L``/``.R`` suffixes
        (:func:`gaitcore.io.bone_names.bone_names`).

    Raises
    ------
    GaitInputError
        When the table lacks some of the skeleton's channels, or the frame rate is not
        positive.

    Notes
    -----
    A joint has at most one End Site: BVH readers (Blender's among them) keep one end point
    per joint and point the bone at it. Of several end points of one joint, the farthest
    (the muzzle, not the ears) is the End Site and the others are written as joints with
    ``CHANNELS 0``, so no point is lost and the bone points along the limb.
    """
    values = pose_matrix(skeleton, table)
    channel = {c: i for i, c in enumerate(skeleton.channel_names)}
    if not fps > 0:
        raise GaitInputError(f"frame rate must be positive, got {fps}")
    names = bone_names(skeleton, naming)
    children: dict[str, list[int]] = {}
    for i, j in enumerate(skeleton.joints):
        children.setdefault(j.parent or "", []).append(i)
    end_sites = _end_sites(skeleton, children)
    lines = ["HIERARCHY"]
    columns: list[np.ndarray] = []

    def emit(i: int, depth: int) -> None:
        j = skeleton.joints[i]
        pad = "  " * depth
        kids = children.get(j.name, [])
        if i in end_sites:
            lines.extend([f"{pad}End Site", f"{pad}{{", f"{pad}  OFFSET {_fmt(j.offset)}",
                          f"{pad}}}"])
            return
        head = "ROOT" if j.parent is None else "JOINT"
        lines.extend([f"{pad}{head} {names[i]}", f"{pad}{{", f"{pad}  OFFSET {_fmt(j.offset)}"])
        channels = j.channels or (("rz", "rx", "ry") if kids else ())
        lines.append(" ".join([f"{pad}  CHANNELS {len(channels)}"]
                              + [_BVH_CHANNEL[c] for c in channels]))
        for c in channels:
            name = f"{j.name}.{c}"
            col = values[:, channel[name]] if name in channel else np.zeros(len(table.frames))
            if c.startswith("t"):
                col = col + j.offset["xyz".index(c[1])]
            columns.append(col)
        for k in kids:
            emit(k, depth + 1)
        lines.append(f"{pad}}}")

    emit(children[""][0], 0)
    motion = np.column_stack(columns) if columns else np.zeros((len(table.frames), 0))
    _write(Path(path), lines, motion, fps)


def _write(path: Path, hierarchy: list[str], motion: np.ndarray, fps: float) -> None:
    """The file: the HIERARCHY lines, then MOTION with one line per frame."""
    lines = hierarchy + ["MOTION", f"Frames: {len(motion)}", f"Frame Time: {1.0 / fps:.12f}"]
    lines.extend(" ".join(f"{v:.6f}" for v in row) for row in motion)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _end_sites(skeleton: Skeleton, children: dict[str, list[int]]) -> set[int]:
    """The one end point per joint written as its End Site: the farthest channel-less leaf."""
    chosen = set()
    for parent, kids in children.items():
        leaves = [k for k in kids if parent and not skeleton.joints[k].channels
                  and not children.get(skeleton.joints[k].name)]
        if leaves:
            chosen.add(max(leaves, key=lambda k: np.linalg.norm(skeleton.offsets[k])))
    return chosen


def _fmt(v) -> str:
    return " ".join(f"{float(x):.6f}" for x in v)
