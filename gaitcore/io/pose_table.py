"""Pose tables as CSV: a ``frame`` column and one numeric column per pose channel.

Used for the key poses the artist provides (one row per key and alternate frame) and for the
animation curves ``gaitcore animate`` writes (one row per frame). Angles are in degrees.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.schema import is_number, read_text

if TYPE_CHECKING:
    from gaitcore.rig.skeleton import Skeleton

MAX_POSE_BYTES = 1 << 30
MAX_FRAME = 10**8
MAX_LISTED = 12
"""Missing channels named in an error message before '... and N more'."""
MAX_LISTED_JOINTS = 10
"""Joints named in an error message before '... and N more'."""
IGNORED_COLUMNS = ("time_s",)
"""Columns of a pose table that are never pose channels."""


@dataclass(frozen=True, eq=False)
class PoseTable:
    """Rows of pose vectors labelled by frame number.

    Attributes
    ----------
    frames : ndarray of shape (r,), int
    columns : tuple of str
        Channel names, k of them (the ``frame`` column excluded).
    values : ndarray of shape (r, k), float

    Raises
    ------
    GaitInputError
        A value that is not a finite number (it would leave the product in a curves file,
        a BVH or a glTF): the message names its frame and column.
    """

    frames: np.ndarray
    columns: tuple[str, ...]
    values: np.ndarray

    def __post_init__(self) -> None:
        values = np.asarray(self.values, dtype=float)
        bad = np.argwhere(~np.isfinite(values))
        if bad.size:
            row, col = (int(v) for v in bad[0])
            name = self.columns[col] if col < len(self.columns) else f"column {col + 1}"
            raise GaitInputError(
                f"the motion is not a number on frame {int(np.asarray(self.frames)[row])}, "
                f"{name} ({len(bad)} value(s) in all): nothing was written; check the key "
                "poses and the analysis it came from")

    def as_dict(self) -> dict[int, np.ndarray]:
        """Pose vector of each frame."""
        return {int(f): self.values[i] for i, f in enumerate(self.frames)}


def read_pose_table(path: str | Path) -> PoseTable:
    """Read a pose CSV.

    Rows are parsed as they are read, so memory stays a small multiple of the file.

    Raises
    ------
    GaitInputError
        Missing file or not a regular file, no ``frame`` column, no channel column, a
        non-numeric, infinite or missing value (with its line and column), a cell longer
        than the CSV reader allows, a fractional or negative frame number, or a frame
        listed twice.
    """
    path = Path(path)
    text = read_text(path, what="pose file", max_bytes=MAX_POSE_BYTES, encoding="utf-8-sig")
    reader = csv.reader(io.StringIO(text, newline=""))
    header: list[str] | None = None
    rows: list[np.ndarray] = []
    try:
        for row in reader:
            if not any(cell.strip() for cell in row):
                continue
            if header is None:
                header = _header(row, path)
            else:
                rows.append(_numbers(row, header, f"pose file {path}, line {reader.line_num}"))
    except csv.Error as exc:
        raise GaitInputError(f"pose file {path}, line {reader.line_num}: {exc}; is it a CSV "
                             "pose table?") from None
    if header is None:
        raise GaitInputError(f"pose file {path} is empty; expected a header 'frame,<channel>,...'")
    values = np.array(rows).reshape(len(rows), len(header))
    frames = values[:, 0]
    if np.any(frames != np.round(frames)) or np.any(frames < 0) or np.any(frames > MAX_FRAME):
        raise GaitInputError(f"pose file {path}: frame numbers must be whole numbers from 0 "
                             f"to {MAX_FRAME}")
    frames = frames.astype(int)
    uniq, counts = np.unique(frames, return_counts=True)
    if np.any(counts > 1):
        raise GaitInputError(
            f"pose file {path}: frame {int(uniq[counts > 1][0])} is listed twice; "
            "keep one row per frame"
        )
    return PoseTable(frames=frames, columns=tuple(header[1:]), values=values[:, 1:])


def _header(row: list[str], path: Path) -> list[str]:
    header = [h.strip() for h in row]
    if header[0] != "frame":
        raise GaitInputError(
            f"pose file {path}: the first column must be 'frame', found '{_shown(header[0])}'"
        )
    if len(header) < 2:
        raise GaitInputError(f"pose file {path} has no channel columns after 'frame'")
    if len(set(header)) != len(header):
        raise GaitInputError(f"pose file {path} has duplicate column names")
    return header


def _numbers(row: list[str], header: list[str], where: str) -> np.ndarray:
    """One data row as finite floats; ``where`` names the file and line in messages."""
    if len(row) != len(header):
        raise GaitInputError(f"{where}: {len(row)} values for {len(header)} columns")
    try:
        values = np.array([float(cell) for cell in row])
    except ValueError:
        j, cell = next((j, c) for j, c in enumerate(row) if not is_number(c))
        raise GaitInputError(f"{where}, column '{_shown(header[j])}': '{_shown(cell)}' is not "
                             "a number") from None
    if not np.all(np.isfinite(values)):
        j = int(np.argmin(np.isfinite(values)))
        raise GaitInputError(f"{where}, column '{_shown(header[j])}': value is missing or NaN or "
                             "infinite; every channel of every posed frame needs a number")
    return values


def _shown(text: str) -> str:
    """``text`` on one short line, for a message."""
    text = " ".join(text.split())
    return text if len(text) <= 40 else text[:37] + "..."


def write_pose_table(path: str | Path, table: PoseTable, *, fps: float | None = None) -> None:
    """Write a pose CSV (``frame``, optionally ``time_s``, then one column per channel)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    header = ["frame"] + (["time_s"] if fps else []) + list(table.columns)
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for f, row in zip(table.frames, table.values):
            lead = [int(f)] + ([f"{f / fps:.6f}"] if fps else [])
            w.writerow(lead + [repr(float(v)) for v in row])


def pose_matrix(skeleton: Skeleton, table: PoseTable) -> np.ndarray:
    """The table's values re-ordered as ``skeleton.channel_names``, shape (n, k).

    Raises
    ------
    GaitInputError
        Some channels of the skeleton are not columns of the table; the message lists them.
    """
    index = {c: i for i, c in enumerate(table.columns)}
    missing = [c for c in skeleton.channel_names if c not in index]
    if missing:
        listed = ", ".join(missing[:MAX_LISTED])
        more = f" and {len(missing) - MAX_LISTED} more" if len(missing) > MAX_LISTED else ""
        raise GaitInputError(
            f"the curves lack {len(missing)} of the {skeleton.n_channels} channels of skeleton "
            f"{skeleton.name!r}: {listed}{more}; give the key poses a column for every channel "
            "of the skeleton")
    return np.asarray(table.values, float)[:, [index[c] for c in skeleton.channel_names]]


def joints_of(channels: list[str]) -> str:
    """The joints of ``channels`` ('joint.rz' ...), named for a message."""
    joints = list(dict.fromkeys(c.rsplit(".", 1)[0] for c in channels))
    more = (f" and {len(joints) - MAX_LISTED_JOINTS} more"
            if len(joints) > MAX_LISTED_JOINTS else "")
    return ", ".join(joints[:MAX_LISTED_JOINTS]) + more


def map_channels(columns: tuple[str, ...], values: np.ndarray, skeleton: Skeleton
                 ) -> tuple[np.ndarray, list[str]]:
    """A pose of ``skeleton`` from one row of named values, matched by channel name.

    Returns
    -------
    pose : ndarray of shape (k,)
    ignored : list of str
        Columns that are not channels of the skeleton.

    Raises
    ------
    GaitInputError
        Channels of the skeleton without a column; the message names their joints.
    """
    index = {c: i for i, c in enumerate(columns)}
    missing = [c for c in skeleton.channel_names if c not in index]
    if missing:
        raise GaitInputError(
            f"it lacks {len(missing)} of the {skeleton.n_channels} channels of the rig "
            f"{skeleton.name!r}, on joints {joints_of(missing)}; nothing was changed")
    pose = np.array([values[index[c]] for c in skeleton.channel_names], dtype=float)
    ignored = [c for c in columns if c not in skeleton.channel_names and c not in IGNORED_COLUMNS]
    return pose, ignored
