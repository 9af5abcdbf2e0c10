"""The Gaussian kernel h shared by the RBF pose map and the key-image criterion (paper 2.4, 3.1).

h(r) = exp(-alpha r^2). The RBF map (:mod:`gaitcore.animation.rbf`) interpolates with it; the
key-image selection (:mod:`gaitcore.analysis.keyimages`) minimises the condition number of the
kernel matrix H it builds over the keys.
"""

from __future__ import annotations

from math import log

import numpy as np

DEFAULT_ALPHA = log(2.0)
"""The paper's kernel width: h(1) = 1/2, equal influence half-way between keys 2 apart."""


def gaussian_kernel(
    points_a: np.ndarray, points_b: np.ndarray, *, alpha: float = DEFAULT_ALPHA
) -> np.ndarray:
    """Gaussian kernel values between two point sets.

    Parameters
    ----------
    points_a : ndarray of shape (n, c)
    points_b : ndarray of shape (m, c)
    alpha : float
        Kernel width, h(r) = exp(-alpha r^2).

    Returns
    -------
    ndarray of shape (n, m)
        ``K[i, j] = exp(-alpha * |a_i - b_j|^2)``.

    Notes
    -----
    Paper equation (15).
    """
    a = np.asarray(points_a, dtype=float)
    b = np.asarray(points_b, dtype=float)
    sq = (a * a).sum(1)[:, None] + (b * b).sum(1)[None, :] - 2.0 * a @ b.T
    np.maximum(sq, 0.0, out=sq)
    return np.exp(-alpha * sq)
