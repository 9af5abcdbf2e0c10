"""Animate from key poses: the pose of every frame from the posed key-images (paper 2.4, 3.2).

One function, :func:`animate`, that the ``gaitcore animate`` command and the app both call:
plain RBF interpolation, or switching models when the keys have alternates.
"""

from __future__ import annotations

import numpy as np

from gaitcore.analysis.kernel import DEFAULT_ALPHA
from gaitcore.animation.rbf import RBFPoseMap
from gaitcore.animation.switching import SwitchingModel
from gaitcore.errors import GaitInputError


def animate(
    coords: np.ndarray,
    key_frames: tuple[int, ...],
    poses: dict[int, np.ndarray],
    *,
    alternate_frames: tuple[int, ...] | None = None,
    theta: np.ndarray | None = None,
    alpha: float = DEFAULT_ALPHA,
    clamp: tuple[float, float] | None = None,
) -> np.ndarray:
    """Pose of every frame by RBF interpolation of the posed key-images.

    Parameters
    ----------
    coords : ndarray of shape (n, c)
        PCA coordinates driving the animation (raw or band-pass filtered).
    key_frames : tuple of int
    poses : dict of int to ndarray of shape (k,)
        Pose vector of every key (and alternate) frame.
    alternate_frames : tuple of int, optional
        With ``theta``, animate with switching models (paper Section 3.2).
    theta : ndarray of shape (n,), optional
        Loop angle, required for switching.
    alpha, clamp
        RBF kernel width and optional weight clamp.

    Returns
    -------
    ndarray of shape (n, k)

    Raises
    ------
    GaitInputError
        A key without a pose, poses of different lengths, or a singular system.
    """
    needed = tuple(key_frames) + tuple(alternate_frames or ())
    missing = [f for f in needed if f not in poses]
    if missing:
        raise GaitInputError(
            f"the key poses lack frame(s) {missing}; add a row for every key"
            + (" and alternate" if alternate_frames else "")
            + " frame"
        )
    lengths = {np.asarray(poses[f]).shape for f in needed}
    if len(lengths) != 1:
        raise GaitInputError("every key pose must have the same channels")
    coords = np.asarray(coords, dtype=float)
    if alternate_frames:
        if theta is None:
            raise GaitInputError("switching models need the loop angle of every frame")
        model = SwitchingModel.fit(
            coords, theta, key_frames, alternate_frames, poses, alpha=alpha, clamp=clamp
        )
        return model.predict(coords, theta)
    rbf = RBFPoseMap.fit(
        coords[list(key_frames)], np.stack([poses[f] for f in key_frames]), alpha=alpha, clamp=clamp
    )
    return rbf.predict(coords)
