"""Pose tables as CSV: a ``frame`` column and one numeric column per pose channel.

Used for the key poses the artist provides (one row per key and alternate frame) and for the
animation curves ``gaitcore animate`` writes (one row per frame). Angles are in degrees.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gaitcore.errors import GaitInputError

if TYPE_CHECKING:
    from gaitcore.rig.skeleton import Skeleton

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
    """

    frames: np.ndarray
    columns: tuple[str, ...]
    values: np.ndarray

    def as_dict(self) -> dict[int, np.ndarray]:
        """Pose vector of each frame."""
        return {int(f): self.values[i] for i, f in enumerate(self.frames)}


def read_pose_table(path: str | Path) -> PoseTable:
    """Read a pose CSV.

    Raises
    ------
    GaitInputError
        Missing file, no ``frame`` column, no channel column, a non-numeric or missing
        value (with its line and column), a fractional or negative frame number, or a frame
        listed twice.
    """
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh))
    except FileNotFoundError:
        raise GaitInputError(f"pose file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise GaitInputError(f"cannot read pose file {path}: {exc}") from None
    rows = [r for r in rows if any(cell.strip() for cell in r)]
    if not rows:
        raise GaitInputError(f"pose file {path} is empty; expected a header 'frame,<channel>,...'")
    header = [h.strip() for h in rows[0]]
    if not header or header[0] != "frame":
        raise GaitInputError(
            f"pose file {path}: the first column must be 'frame', found {header[:1]}"
        )
    if len(header) < 2:
        raise GaitInputError(f"pose file {path} has no channel columns after 'frame'")
    if len(set(header)) != len(header):
        raise GaitInputError(f"pose file {path} has duplicate column names")
    values = np.empty((len(rows) - 1, len(header)))
    for i, row in enumerate(rows[1:]):
        line = i + 2
        if len(row) != len(header):
            raise GaitInputError(
                f"pose file {path}, line {line}: {len(row)} values for {len(header)} columns"
            )
        for j, cell in enumerate(row):
            try:
                values[i, j] = float(cell)
            except ValueError:
                raise GaitInputError(
                    f"pose file {path}, line {line}, column '{header[j]}': "
                    f"'{cell}' is not a number"
                ) from None
    if not np.all(np.isfinite(values)):
        i, j = np.argwhere(~np.isfinite(values))[0]
        raise GaitInputError(
            f"pose file {path}, line {i + 2}, column '{header[j]}': value is missing or NaN; "
            "every channel of every posed frame needs a number"
        )
    frames = values[:, 0]
    if np.any(frames != np.round(frames)) or np.any(frames < 0):
        raise GaitInputError(f"pose file {path}: frame numbers must be whole numbers from 0")
    frames = frames.astype(int)
    uniq, counts = np.unique(frames, return_counts=True)
    if np.any(counts > 1):
        raise GaitInputError(
            f"pose file {path}: frame {int(uniq[counts > 1][0])} is listed twice; keep one row per frame"
        )
    return PoseTable(frames=frames, columns=tuple(header[1:]), values=values[:, 1:])


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
