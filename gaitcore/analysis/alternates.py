"""Alternates for the left/right ambiguity of walks: the loop angle and where to look (paper 3.2).

From the side, the two half-cycles of a walk give nearly the same silhouettes with the left and
right legs swapped. The analysis proposes, for each key-image, an *alternate* in the other
half-cycle; the switching models of :mod:`gaitcore.animation.switching` then animate with both.
"""

from __future__ import annotations

import numpy as np

from gaitcore.errors import GaitInputError

TWO_PI = 2.0 * np.pi


def loop_angle(trajectory: np.ndarray) -> np.ndarray:
    """Unwrapped, non-decreasing angle of a (PC1, PC2) trajectory around its centre.

    Parameters
    ----------
    trajectory : ndarray of shape (n, c), c >= 2
        PCA projections, preferably band-pass filtered (see :func:`gaitcore.analysis.spectrum.band_pass`).

    Returns
    -------
    ndarray of shape (n,)
        Angle in radians, starting near atan2 of the first point, increasing by 2 pi per turn
        of the loop. The direction of travel is normalised to be positive.
    """
    p = np.asarray(trajectory, dtype=float)
    if p.ndim != 2 or p.shape[1] < 2:
        raise GaitInputError("the loop angle needs at least 2 principal components")
    centred = p[:, :2] - p[:, :2].mean(axis=0)
    theta = np.unwrap(np.arctan2(centred[:, 1], centred[:, 0]))
    if theta[-1] < theta[0]:
        theta = -theta
    return np.maximum.accumulate(theta)


def propose_alternates(
    projections: np.ndarray,
    key_frames: tuple[int, ...] | list[int],
    *,
    min_gap: int = 3,
    theta: np.ndarray | None = None,
) -> tuple[int, ...]:
    """Propose, for each key-image, the frame with the same silhouette in the other half-cycle.

    Parameters
    ----------
    projections : ndarray of shape (n, c)
    key_frames : sequence of int
    min_gap : int
        The alternate is at least this many frames away from its key (the paper uses 3).
    theta : ndarray of shape (n,), optional
        Loop angle (see :func:`loop_angle`). When given and the clip covers a whole gait
        cycle (two turns), candidates are restricted to frames an odd number of turns of the
        loop away from the key (within half a turn): on a clip of several cycles, the nearest
        frame may otherwise be the same pose one cycle later, which resolves nothing.

    Returns
    -------
    tuple of int
        One alternate per key, in the order of ``key_frames``.

    Raises
    ------
    GaitInputError
        If some key has no frame at least ``min_gap`` frames away.

    Notes
    -----
    Paper Section 3.2, step 2.
    """
    p = np.asarray(projections, dtype=float)
    n = p.shape[0]
    frames = np.arange(n)
    use_phase = theta is not None and theta[-1] - theta[0] >= 2 * TWO_PI
    out = []
    for k in key_frames:
        if not 0 <= k < n:
            raise GaitInputError(f"key frame {k} is outside the clip (0..{n - 1})")
        ok = np.abs(frames - k) >= min_gap
        if use_phase:
            # Turns of the loop between each frame and the key, modulo a gait cycle (2 turns):
            # about 1 in the other half-cycle, about 0 or 2 for the same pose a cycle away.
            turns = np.mod((theta - theta[k]) / TWO_PI, 2.0)
            other_half = (turns >= 0.5) & (turns < 1.5)
            if np.any(ok & other_half):
                ok &= other_half
        if not ok.any():
            raise GaitInputError(
                f"no frame is at least {min_gap} frames away from key {k}: the clip is too "
                "short to look for the other half-cycle"
            )
        d = np.where(ok, ((p - p[k]) ** 2).sum(axis=1), np.inf)
        out.append(int(np.argmin(d)))
    return tuple(out)
