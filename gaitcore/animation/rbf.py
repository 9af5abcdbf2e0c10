"""Gaussian radial basis function pose map (paper Section 2.4).

A pose vector x(p) is predicted from PCA coordinates p as a weighted sum of the key poses,
x(p) = h(p) A with h(p)_i = exp(-alpha * |p - p_i|^2) and A solving H A = X.

Beyond the paper, the pose is blended from the weights the way its Section 5.3 suggests a
control might: negative weights are dropped and, where the others sum past one, they are
scaled to sum to one, so that a frame whose coordinates a noisy silhouette threw off the
keys' loop cannot swing the pose beyond what the keys span; and what the weights leave
(where they sum to less than one, between keys that lie far apart, as a real clip's keys
do) goes to the keys' mean pose, not to zero (the rest pose, or the trunk's origin for
positions): x(p) = mean + b(p) (X - mean) with b the blend (:meth:`RBFPoseMap.blend`). At
the keys the interpolation stays exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import LinAlgError, lu_factor, lu_solve

from gaitcore.analysis.kernel import DEFAULT_ALPHA, gaussian_kernel
from gaitcore.errors import GaitInputError


@dataclass(frozen=True, eq=False)
class RBFPoseMap:
    """A fitted RBF map from PCA coordinates to pose vectors.

    Build one with :meth:`fit`.

    Attributes
    ----------
    key_coords : ndarray of shape (m, c)
        PCA coordinates of the key-images.
    key_poses : ndarray of shape (m, k)
        Pose vector of each key-image.
    alpha : float
        Kernel width.
    clamp : tuple of float or None
        If set, every weight is clipped to ``[lo, hi]`` before use (the paper's optional
        "safe range", Section 5.3).
    """

    key_coords: np.ndarray
    key_poses: np.ndarray
    alpha: float
    clamp: tuple[float, float] | None
    _lu: tuple[np.ndarray, np.ndarray]

    @classmethod
    def fit(
        cls,
        key_coords: np.ndarray,
        key_poses: np.ndarray,
        *,
        alpha: float = DEFAULT_ALPHA,
        clamp: tuple[float, float] | None = None,
    ) -> RBFPoseMap:
        """Fit the map to m key-images and their poses.

        Parameters
        ----------
        key_coords : array_like of shape (m, c)
        key_poses : array_like of shape (m, k) or (m,)
        alpha : float, optional
            Kernel width (default ln 2).
        clamp : (float, float), optional
            Weight range to enforce in :meth:`weights`.

        Raises
        ------
        GaitInputError
            If shapes disagree, values are not finite, two keys share coordinates, or the
            kernel matrix is numerically singular.

        Notes
        -----
        Paper equations (6)-(13): with m keys H is square, so A = H^-1 X, solved by LU.
        """
        p = np.atleast_2d(np.asarray(key_coords, dtype=float))
        x = np.asarray(key_poses, dtype=float)
        if x.ndim == 1:
            x = x[:, None]
        if p.ndim != 2 or x.ndim != 2 or p.shape[0] != x.shape[0]:
            raise GaitInputError(
                f"need one pose per key-image: got {p.shape[0]} key coordinates and "
                f"{x.shape[0]} poses"
            )
        if p.shape[0] == 0:
            raise GaitInputError("need at least one key-image to interpolate poses")
        if not np.all(np.isfinite(p)):
            raise GaitInputError("key-image coordinates contain NaN or infinity")
        if not np.all(np.isfinite(x)):
            raise GaitInputError("key poses contain NaN or infinity: fill every value of every "
                                 "key pose")
        if not alpha > 0:
            raise GaitInputError(f"kernel width alpha must be positive, got {alpha}")
        if clamp is not None and not clamp[0] < clamp[1]:
            raise GaitInputError(f"weight clamp range must be (low, high) with low < high, "
                                 f"got {clamp}")
        d2 = ((p[:, None, :] - p[None, :, :]) ** 2).sum(-1)
        i, j = np.nonzero(np.triu(d2 <= 1e-24, k=1))
        if i.size:
            raise GaitInputError(
                f"key-images {int(i[0])} and {int(j[0])} have identical PCA coordinates; "
                "choose distinct frames as keys"
            )
        h = np.exp(-alpha * d2)
        if np.linalg.cond(h) > 1e12:
            raise GaitInputError(
                "the key-images are too close together in PCA space to interpolate between "
                "(kernel matrix is singular); pick keys further apart"
            )
        try:
            lu = lu_factor(h, check_finite=False)
        except LinAlgError as exc:  # pragma: no cover - caught by the condition test above
            raise GaitInputError(f"cannot solve the RBF system: {exc}") from exc
        p.setflags(write=False)
        x.setflags(write=False)
        return cls(key_coords=p, key_poses=x, alpha=float(alpha), clamp=clamp, _lu=lu)

    @property
    def mean_pose(self) -> np.ndarray:
        """The keys' mean pose, shape (k,): where the interpolation falls back far from them."""
        return self.key_poses.mean(axis=0)

    @property
    def n_keys(self) -> int:
        return self.key_coords.shape[0]

    def weights(self, coords: np.ndarray) -> np.ndarray:
        """Interpolation weights of every key at the given coordinates.

        Parameters
        ----------
        coords : array_like of shape (n, c) or (c,)

        Returns
        -------
        ndarray of shape (n, m) (or (m,) for one point)
            ``w(p) = h(p) H^-1``, so that ``x(p) = w(p) X`` (paper equation 14). Rows sum to
            about 1 near the keys and exactly 1 at them. Clipped to ``clamp`` if it is set.
        """
        q = np.asarray(coords, dtype=float)
        single = q.ndim == 1
        q = np.atleast_2d(q)
        if q.shape[1] != self.key_coords.shape[1]:
            raise GaitInputError(
                f"coordinates have {q.shape[1]} components but the map was fitted on "
                f"{self.key_coords.shape[1]}"
            )
        hq = gaussian_kernel(q, self.key_coords, alpha=self.alpha)
        # H is symmetric, so w = h H^-1 is the solution of H w^T = h^T.
        w = lu_solve(self._lu, hq.T, check_finite=False).T
        if self.clamp is not None:
            w = np.clip(w, *self.clamp)
        return w[0] if single else w

    def blend(self, coords: np.ndarray) -> np.ndarray:
        """What each key pose weighs in the predicted pose (see the module's notes).

        Parameters
        ----------
        coords : array_like of shape (n, c) or (c,)

        Returns
        -------
        ndarray of shape (n, m) (or (m,) for one point)
            :meth:`weights` without its negative values and, where the rest sum past one,
            scaled to sum to one: never negative, summing to at most one (exactly one at
            the keys); the keys' mean pose takes the remainder.
        """
        w = np.clip(self.weights(coords), 0.0, None)
        total = w.sum(axis=-1, keepdims=True)
        return np.where(total > 1.0, w / np.maximum(total, 1e-300), w)

    def predict(self, coords: np.ndarray) -> np.ndarray:
        """Predicted pose vectors.

        Parameters
        ----------
        coords : array_like of shape (n, c) or (c,)

        Returns
        -------
        ndarray of shape (n, k) (or (k,) for one point)
            ``mean + b(p) (X - mean)``, b the :meth:`blend` (see the module's notes).
        """
        mean = self.mean_pose
        return mean + self.blend(coords) @ (self.key_poses - mean)
