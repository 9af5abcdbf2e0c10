"""How close can any blend of key poses come to a motion? A floor under the paper's error.

The RBF map predicts every frame as a linear combination of the key poses,
``x(p) = sum_i w_i(p) x_i`` (paper Section 2.4), whatever the images, the PCA and the
kernel. So for a set of key poses no timing, kernel width, weight clamp or segmentation can
do better, frame by frame, than the best linear combination of those poses. This module
measures that floor in the paper's Section 4 metric (mean absolute angle difference over
frames and angles):

- :func:`blend_floor`: exact, for one set of keys, by least absolute deviations (a linear
  program per distinct frame);
- :func:`best_blend_floor`: over every set of ``m`` distinct poses of the motion, a proven
  lower bound (linear programming duality) and the exact floor of the set that least squares
  fits best (an achievable value, so the best floor lies between the two).

The duality: ``min_w |y - P^T w|_1 = max {u . y : P u = 0, |u|_inf <= 1}``; any ``u`` in the
null space of the key poses ``P`` scaled into the unit box gives a lower bound ``u . y``.
We take the least-squares residual, clipped at a few levels, projected on that null space.

Angles are compared without wrapping at 360 degrees: the floors are for motions whose angles
stay well inside +-180 degrees of each other, as joint angles do.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations
from math import comb

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report

MAX_SETS = 2_000_000
"""Most key sets :func:`best_blend_floor` enumerates."""

_CLIP_QUANTILES = (1.0, 0.9, 0.75, 0.6, 0.5, 0.4, 0.3, 0.2, 0.1, 0.05)
_CHUNK = 1000



@dataclass(frozen=True)
class BestBlendFloor:
    """Result of :func:`best_blend_floor`, degrees.

    Attributes
    ----------
    keys : int
        Number of key poses per set.
    n_sets : int
        Sets of distinct poses examined (all of them).
    lower_deg : float
        No set of ``keys`` poses of the motion blends closer than this (proven).
    achieved_deg : float
        Exact floor of the set that least squares fits best: a blend this close exists.
    key_frames : tuple of int
        First frame of each pose of that set.
    """

    keys: int
    n_sets: int
    lower_deg: float
    achieved_deg: float
    key_frames: tuple[int, ...]


def blend_floor(truth: np.ndarray, key_frames: Sequence[int]) -> float:
    """Least mean absolute error of any per-frame linear blend of the key poses.

    Parameters
    ----------
    truth : ndarray of shape (n, k)
        The true angles of every frame (degrees).
    key_frames : sequence of int
        Frames whose true poses are the keys.

    Returns
    -------
    float
        ``mean over frames and angles of |truth - w(t) P|`` for the best weights ``w(t)`` of
        every frame, degrees. Every method that blends these poses, the paper's RBF map
        included, has at least this error.
    """
    truth = _as_motion(truth)
    keys = _as_keys(key_frames, len(truth))
    poses, counts, _ = _distinct(truth)
    return _lad(truth[list(keys)], poses, counts / counts.sum())


def best_blend_floor(truth: np.ndarray, keys: int, *,
                     progress: Progress | None = None) -> BestBlendFloor:
    """The floor of :func:`blend_floor` over every set of ``keys`` distinct poses.

    Parameters
    ----------
    truth : ndarray of shape (n, k)
        The true angles of every frame (degrees).
    keys : int
        Poses per set.
    progress : callable(done, total) -> bool, optional
        Called after each chunk of sets; returning False cancels with Cancelled.

    Returns
    -------
    BestBlendFloor

    Raises
    ------
    GaitInputError
        ``keys`` outside 1 .. number of distinct poses, or more than MAX_SETS sets.
    Cancelled
        If ``progress`` returned False.
    """
    truth = _as_motion(truth)
    poses, counts, first = _distinct(truth)
    if isinstance(keys, bool) or int(keys) != keys or not 1 <= keys <= len(poses):
        raise GaitInputError(
            f"keys must be between 1 and the {len(poses)} distinct poses, got {keys!r}")
    n_sets = comb(len(poses), keys)
    if n_sets > MAX_SETS:
        raise GaitInputError(
            f"{n_sets} sets of {keys} among {len(poses)} distinct poses is more than "
            f"{MAX_SETS}; use fewer keys or a shorter motion")
    weights = counts / counts.sum()
    sets = np.fromiter(combinations(range(len(poses)), keys), dtype=(np.intp, keys),
                       count=n_sets)
    lower, fit, done = np.inf, np.inf, 0
    best = sets[0]
    for chunk in np.array_split(sets, -(-n_sets // _CHUNK)):
        lo, ls = _bounds(poses[chunk], poses, weights)
        lower = min(lower, float(lo.min()))
        if ls.min() < fit:
            fit, best = float(ls.min()), chunk[int(np.argmin(ls))]
        done += len(chunk)
        report(progress, done, n_sets, "floor search stopped")
    achieved = _lad(poses[best], poses, weights)
    return BestBlendFloor(keys, n_sets, lower, achieved, tuple(sorted(int(f) for f in first[best])))


def _bounds(key_sets: np.ndarray, poses: np.ndarray,
            weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Duality lower bound and least-squares-fit error for each key set (mean abs, degrees).

    key_sets : (s, m, k); poses : (f, k) distinct poses; weights : (f,) their frame shares.
    """
    gram_inv = np.linalg.pinv(np.einsum("smk,sjk->smj", key_sets, key_sets))

    def null_part(v: np.ndarray) -> np.ndarray:  # v minus its projection on the key poses
        coef = np.einsum("smj,sfj->sfm", gram_inv, np.einsum("smk,sfk->sfm", key_sets, v))
        return v - np.einsum("sfm,smk->sfk", coef, key_sets)

    residual = null_part(np.broadcast_to(poses, (len(key_sets),) + poses.shape))
    magnitude = np.abs(residual)
    lower = np.zeros(residual.shape[:2])
    for q in _CLIP_QUANTILES:
        level = np.maximum(np.quantile(magnitude, q, axis=-1), 1e-12)[..., None]
        u = null_part(np.clip(residual / level, -1.0, 1.0))
        u /= np.maximum(1.0, np.abs(u).max(axis=-1, keepdims=True))
        np.maximum(lower, np.einsum("sfk,fk->sf", u, poses), out=lower)
    k = poses.shape[1]
    return lower @ weights / k, magnitude.sum(axis=-1) @ weights / k


def _lad(key_poses: np.ndarray, poses: np.ndarray, weights: np.ndarray) -> float:
    """Exact weighted least-absolute-deviation blend error, one linear program."""
    f, k = poses.shape
    m = len(key_poses)
    blend = sparse.kron(sparse.identity(f), sparse.csr_matrix(key_poses.T))  # (f k, f m)
    slack = sparse.identity(f * k)
    a_ub = sparse.vstack([sparse.hstack([-blend, -slack]), sparse.hstack([blend, -slack])])
    b_ub = np.concatenate([-poses.ravel(), poses.ravel()])
    cost = np.concatenate([np.zeros(f * m), np.repeat(weights, k)])
    bounds = [(None, None)] * (f * m) + [(0, None)] * (f * k)
    result = linprog(cost, A_ub=a_ub.tocsc(), b_ub=b_ub, bounds=bounds, method="highs")
    if not result.success:
        raise GaitInputError(f"the blend floor could not be solved: {result.message}")
    return float(result.fun) / k


def _distinct(truth: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distinct poses (equal to 1e-9 degrees), their frame counts and first frames."""
    _, first, counts = np.unique(np.round(truth, 9), axis=0, return_index=True,
                                 return_counts=True)
    return truth[first], counts.astype(float), first


def _as_motion(truth: np.ndarray) -> np.ndarray:
    truth = np.asarray(truth, dtype=float)
    if truth.ndim != 2 or truth.shape[0] < 1 or truth.shape[1] < 1:
        raise GaitInputError(f"truth must be an (n frames, k angles) array, got {truth.shape}")
    if not np.isfinite(truth).all():
        raise GaitInputError("truth has NaN or infinite angles")
    return truth


def _as_keys(key_frames: Sequence[int], n: int) -> tuple[int, ...]:
    keys = tuple(int(f) for f in key_frames)
    if not keys or any(not 0 <= f < n for f in keys):
        raise GaitInputError(f"key frames must be in 0..{n - 1}, got {list(key_frames)}")
    return keys
