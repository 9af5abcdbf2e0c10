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
        PCA projections, preferably band-pass filtered (see
        :func:`gaitcore.analysis.spectrum.band_pass`).

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
    period_frames: float | None = None,
    forbidden: tuple[int, ...] = (),
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
        loop away from the key (within a quarter turn with ``period_frames``, half a turn
        without), where any frame is: on a clip of several cycles, the nearest frame may
        otherwise be the same pose one cycle later, which resolves nothing.
    period_frames : float, optional
        Half the gait cycle of a walk. When given, an alternate must lie an odd number of
        these from its key in time, within a quarter of one, so it is never in the
        neighbouring frames, whatever the noise does to the loop angle (where the loop
        angle and the time leave no frame together, the time decides).
    forbidden : tuple of int
        Frames never proposed (dropped by the artist, lost, left out).

    Returns
    -------
    tuple of int
        One alternate per key, in the order of ``key_frames``: never a key, never twice the
        same frame, never a frame whose coordinates are those of another key or alternate
        (a synthetic clip repeats exactly: the interpolation could not tell them apart).

    Raises
    ------
    GaitInputError
        If some key has no allowed frame; the message says where one was looked for.

    Notes
    -----
    Paper Section 3.2, step 2.
    """
    p = np.asarray(projections, dtype=float)
    n = p.shape[0]
    out: list[int] = []
    for k in key_frames:
        if not 0 <= k < n:
            raise GaitInputError(f"key frame {k} is outside the clip (0..{n - 1})")
        ok = _candidates(n, k, min_gap, theta, period_frames)
        if not ok.any():
            where = (f"about {period_frames:.0f} frames (half a stride) from key {k}"
                     if period_frames is not None else f"{min_gap} or more frames from key {k}")
            raise GaitInputError(
                f"no frame of the other half-cycle lies {where}: the clip is too short or "
                "too irregular to look for alternates; use a longer stretch of steady gait"
            )
        posed = list(key_frames) + out  # a frame poses one thing only
        ok[posed] = False
        others = [f for f in posed if f != k]  # nor the very silhouette of another posed frame
        if others:
            ok &= ((p[:, None, :] - p[others][None]) ** 2).sum(axis=2).min(axis=1) > 1e-12
        ok[[f for f in forbidden if 0 <= f < n]] = False
        if not ok.any():
            raise GaitInputError(
                f"every frame of the other half-cycle near key {k} is already a key or an "
                "alternate: use fewer keys, or a longer stretch of steady gait")
        d = np.where(ok, ((p - p[k]) ** 2).sum(axis=1), np.inf)
        out.append(int(np.argmin(d)))
    return tuple(out)


def _candidates(n: int, k: int, min_gap: int, theta: np.ndarray | None,
                period_frames: float | None) -> np.ndarray:
    """Frames allowed as key ``k``'s alternate, shape (n,) bool (see propose_alternates)."""
    frames = np.arange(n)
    reach = 0.25 if period_frames is not None else 0.5
    ok = np.abs(frames - k) >= min_gap
    if period_frames is not None:
        periods = np.abs(frames - k) / float(period_frames)
        ok &= np.abs(np.mod(periods - 1.0, 2.0) - 1.0) >= 1.0 - reach  # odd, +- a quarter
    if theta is not None and theta[-1] - theta[0] >= 2 * TWO_PI:
        # Turns of the loop between each frame and the key, modulo a gait cycle (2 turns):
        # about 1 in the other half-cycle, about 0 or 2 for the same pose a cycle away.
        # A noisy loop (real footage) may leave no frame that both say: time alone then.
        other_half = np.abs(np.mod((theta - theta[k]) / TWO_PI, 2.0) - 1.0) <= reach
        if np.any(ok & other_half):
            ok &= other_half
    return ok


def left_right_swaps(theta: np.ndarray, key_frames: tuple[int, ...] | list[int],
                     alternate_frames: tuple[int, ...] | list[int]) -> int:
    """How often, per gait cycle, a switching animation passes from a key's pose to an
    alternate's (the left/right mirror) or back.

    Parameters
    ----------
    theta : ndarray of shape (n,)
        Loop angle (:func:`loop_angle`); two turns make a gait cycle.
    key_frames, alternate_frames : sequence of int, same length

    Returns
    -------
    int
        Changes between keys and alternates along the gait cycle, the poses ordered by
        phase as the switching models order them. A walk swaps left and right twice per
        cycle; more means alternates that lie beside their keys, and an animation that
        swaps the legs faster than the gait does.
    """
    frames = list(key_frames) + list(alternate_frames)
    is_alt = np.array([False] * len(key_frames) + [True] * len(alternate_frames))
    phase = np.mod(np.asarray([theta[f] for f in frames]) - theta[key_frames[0]], 2 * TWO_PI)
    ordered = is_alt[np.argsort(phase, kind="stable")]
    return int(np.count_nonzero(ordered != np.roll(ordered, 1)))


def swap_warning(theta: np.ndarray, key_frames: tuple[int, ...] | list[int],
                 alternate_frames: tuple[int, ...] | list[int]) -> str | None:
    """A sentence for the artist when the alternates make the animation swap left and right
    faster than the gait (see :func:`left_right_swaps`), else None."""
    if not alternate_frames or len(alternate_frames) != len(key_frames):
        return None
    swaps = left_right_swaps(theta, key_frames, alternate_frames)
    if swaps <= 2:
        return None
    return (f"the switching animation swaps left and right {swaps} times per gait cycle where "
            "the gait does it twice: some alternates lie beside their keys instead of half a "
            "stride away; accept the proposed alternates again or turn switching off")
