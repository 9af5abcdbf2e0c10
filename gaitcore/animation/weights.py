"""What the animation preview shows besides the curves: RBF weights over time, one loop cycle.

:func:`interpolation_weights` gives what each posed frame weighs in the pose of every frame
(paper Figure 10's w_i(t), as the pose blends them: :meth:`RBFPoseMap.blend`), also under
the switching models of Section 3.2; :func:`loop_cycle` cuts one gait cycle out of the curves
and makes it close on itself, for a cycle that loops in an animation package.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.analysis.kernel import DEFAULT_ALPHA
from gaitcore.animation.rbf import RBFPoseMap
from gaitcore.animation.switching import SwitchingModel
from gaitcore.errors import GaitInputError


@dataclass(frozen=True, eq=False)
class InterpolationWeights:
    """Weight of every posed frame at every frame of the clip.

    Attributes
    ----------
    pose_frames : tuple of int
        The posed frames, one per column: key order, or gait-phase order under switching.
    weights : ndarray of shape (n, P)
        What pose i weighs at frame t (:meth:`~gaitcore.animation.rbf.RBFPoseMap.blend`);
        under switching, zero for poses outside the active set of frame t.
    states : ndarray of shape (n,), int, or None
        Active switching set per frame (None without switching).
    """

    pose_frames: tuple[int, ...]
    weights: np.ndarray
    states: np.ndarray | None = None

    @property
    def total(self) -> np.ndarray:
        """Sum of the weights per frame, shape (n,): 1 near the data (exactly at keys), less
        where the pose falls back towards the keys' mean pose."""
        return self.weights.sum(axis=1)


def interpolation_weights(
    coords: np.ndarray,
    key_frames: tuple[int, ...],
    *,
    alternate_frames: tuple[int, ...] | None = None,
    theta: np.ndarray | None = None,
    alpha: float = DEFAULT_ALPHA,
    clamp: tuple[float, float] | None = None,
) -> InterpolationWeights:
    """RBF weights w_i(t) of the posed frames, as :func:`gaitcore.analysis.analyze.animate`
    uses them.

    Parameters
    ----------
    coords : ndarray of shape (n, c)
        PCA coordinates driving the animation (raw or band-pass filtered).
    key_frames : tuple of int
    alternate_frames : tuple of int, optional
        With ``theta``: the weights of the switching models.
    theta : ndarray of shape (n,), optional
        Loop angle of every frame.
    alpha, clamp
        RBF kernel width and optional weight clamp.

    Returns
    -------
    InterpolationWeights

    Raises
    ------
    GaitInputError
        Coinciding keys (singular system), switching without ``theta``.

    Notes
    -----
    Paper Section 2.4, eq. (14) and Figure 10; the weights do not depend on the poses.
    """
    p = np.asarray(coords, dtype=float)
    keys = tuple(int(f) for f in key_frames)
    if not alternate_frames:
        rbf = RBFPoseMap.fit(p[list(keys)], np.zeros((len(keys), 1)), alpha=alpha, clamp=clamp)
        return InterpolationWeights(keys, rbf.blend(p))
    if theta is None:
        raise GaitInputError("switching models need the loop angle of every frame")
    frames = keys + tuple(int(f) for f in alternate_frames)
    dummy = {f: np.zeros(1) for f in frames}
    model = SwitchingModel.fit(p, theta, keys, tuple(alternate_frames), dummy, alpha=alpha,
                               clamp=clamp)
    states = model.states(theta)
    w = np.zeros((p.shape[0], len(frames)))
    for s, rbf in enumerate(model.maps):
        rows = np.nonzero(states == s)[0]
        if rows.size:
            w[np.ix_(rows, model.sets[s])] = rbf.blend(p[rows])
    return InterpolationWeights(model.pose_frames, w, states)


def loop_cycle(curves: np.ndarray, period_frames: float) -> tuple[int, np.ndarray]:
    """One gait cycle of ``curves`` that loops: its last frame leads back to its first.

    The cycle is the window of P = round(period) frames whose end (frame t0 + P) is closest
    to its start; the remaining mismatch is spread linearly over the window, so that playing
    the cycle over and over has no jump.

    Parameters
    ----------
    curves : ndarray of shape (n, k)
        A pose per frame.
    period_frames : float
        Gait period in frames (:attr:`gaitcore.analysis.spectrum.Diagnosis.period_frames`).

    Returns
    -------
    start : int
        First frame of the cycle in the clip.
    cycle : ndarray of shape (P, k)

    Raises
    ------
    GaitInputError
        A period that is not a number of at least 2 frames, or a clip shorter than a period
        and a frame.
    """
    x = np.asarray(curves, dtype=float)
    if not np.isfinite(period_frames) or round(period_frames) < 2:
        raise GaitInputError(f"no usable gait period ({period_frames} frames) to cut a cycle from")
    n, period = x.shape[0], int(round(period_frames))
    if n < period + 1:
        raise GaitInputError(f"the clip ({n} frames) is shorter than one period ({period} frames) "
                             "plus one frame: cannot cut a loop")
    gaps = np.linalg.norm(x[period:] - x[: n - period], axis=1)
    start = int(np.argmin(gaps))
    drift = x[start + period] - x[start]
    ramp = np.arange(period)[:, None] / period
    return start, x[start: start + period] - ramp * drift
