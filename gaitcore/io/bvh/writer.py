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
from gaitcore.io.pose_table import PoseTable, pose_matrix
from gaitcore.rig.skeleton import Skeleton

_BVH_CHANNEL = {
    "tx": "Xposition", "ty": "Yposition", "tz": "Zposition",
    "rz": "Zrotation", "rx": "Xrotation", "ry": "Yrotation",
}


def write_bvh(path: str | Path, skeleton: Skeleton, table: PoseTable, *, fps: float = 24.0) -> None:
    """Write the poses of ``table`` on ``skeleton`` as a BVH file.

    Parameters
    ----------
    path : str or Path
    skeleton : Skeleton
    table : PoseTable
        One row per frame, with a column for every channel of the skeleton (extra columns
        are ignored).
    fps : float
        Frame rate written as ``Frame Time: 1/fps``.

    Raises
    ------
    GaitInputError
        When the table lacks some of the skeleton's channels.
    """
    values = pose_matrix(skeleton, table)
    channel = {c: i for i, c in enumerate(skeleton.channel_names)}
    if not fps > 0:
        raise GaitInputError(f"frame rate must be positive, got {fps}")
    children: dict[str, list[int]] = {}
    for i, j in enumerate(skeleton.joints):
        children.setdefault(j.parent or "", []).append(i)
    lines = ["HIERARCHY"]
    columns: list[np.ndarray] = []

    def emit(i: int, depth: int) -> None:
        j = skeleton.joints[i]
        pad = "  " * depth
        kids = children.get(j.name, [])
        if not j.channels and not kids:
            lines.append(f"{pad}End Site")
            lines.append(f"{pad}{{")
            lines.append(f"{pad}  OFFSET {_fmt(j.offset)}")
            lines.append(f"{pad}}}")
            return
        head = "ROOT" if j.parent is None else "JOINT"
        lines.append(f"{pad}{head} {j.name}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {_fmt(j.offset)}")
        channels = j.channels or ("rz", "rx", "ry")
        lines.append(f"{pad}  CHANNELS {len(channels)} " + " ".join(_BVH_CHANNEL[c] for c in channels))
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
    lines.append("MOTION")
    lines.append(f"Frames: {len(table.frames)}")
    lines.append(f"Frame Time: {1.0 / fps:.10g}")  # 10 significant digits: reads back as the same rate
    motion = np.column_stack(columns) if columns else np.zeros((len(table.frames), 0))
    lines.extend(" ".join(f"{v:.6f}" for v in row) for row in motion)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _fmt(v) -> str:
    return " ".join(f"{float(x):.6f}" for x in v)


# ====================================================================== reading
