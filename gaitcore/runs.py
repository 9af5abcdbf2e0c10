"""Runs of True in a boolean sequence (stretches of frames: steady gait, stance, frames to
check)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def true_runs(mask: ArrayLike) -> list[tuple[int, int]]:
    """``(start, stop)`` of every run of True in a 1-D boolean sequence, in order, ``stop``
    excluded: ``[F, T, T, F, T]`` -> ``[(1, 3), (4, 5)]``."""
    edges = np.flatnonzero(np.diff(np.r_[0, np.asarray(mask, np.int8), 0]))
    return [(int(start), int(stop)) for start, stop in zip(edges[::2], edges[1::2])]
