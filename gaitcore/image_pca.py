"""Principal component analysis of binary silhouette images (paper Section 2.3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.errors import GaitInputError

_EIG_EPS = 1e-10
"""Eigenvalues below this fraction of the largest are treated as zero (no variance)."""


@dataclass(frozen=True, eq=False)
class ImagePCA:
    """PCA of a clip of equally sized images, with normalized projections.

    Build one with :meth:`fit`.

    Attributes
    ----------
    image_shape : tuple of int
        (rows, cols) of every image.
    mean : ndarray of shape (d,)
        Mean image, flattened, d = rows * cols.
    components : ndarray of shape (c, d)
        Unit eigen-images (rows of E transposed), by decreasing variance.
    eigenvalues : ndarray of shape (c,)
        Variance along each component (eigenvalues of (1/n) I^T I).
    total_variance : float
        Sum of all eigenvalues (trace of the covariance).
    projections : ndarray of shape (n, c)
        Normalized projections p(t) of the fitted frames: unit variance per column.
    """

    image_shape: tuple[int, int]
    mean: np.ndarray
    components: np.ndarray
    eigenvalues: np.ndarray
    total_variance: float
    projections: np.ndarray

    @classmethod
    def fit(cls, images: np.ndarray, n_components: int = 5) -> "ImagePCA":
        """Fit the PCA to a stack of images.

        Parameters
        ----------
        images : array_like of shape (n, rows, cols)
            Binary (bool or 0/1 or 0/255) or grey images; converted to float in [0, 1] when
            integer-valued up to 255.
        n_components : int
            Number of components to keep, c >= 1. Fewer are kept when the clip has fewer
            non-zero eigenvalues (at most n - 1).

        Returns
        -------
        ImagePCA

        Raises
        ------
        GaitInputError
            Fewer than 2 frames, non-finite values, or frames that are all identical.

        Notes
        -----
        Paper equations (1)-(5). The eigenvectors come from the SVD of the centred data
        matrix I (n x d) through the n x n Gram matrix I I^T when n < d, so the d x d
        covariance is never formed.
        """
        x = _as_float_stack(images)
        n = x.shape[0]
        if n_components < 1:
            raise GaitInputError(f"n_components must be at least 1, got {n_components}")
        mean = x.mean(axis=0)
        x -= mean
        if x.shape[0] <= x.shape[1]:
            gram = x @ x.T
            evals, u = np.linalg.eigh(gram)
            order = np.argsort(evals)[::-1]
            evals, u = evals[order], u[:, order]
            evals = np.maximum(evals, 0.0)
            keep = evals > _EIG_EPS * max(evals[0], np.finfo(float).tiny)
            if not keep.any() or evals[0] <= 0:
                raise GaitInputError(
                    "all frames are identical: there is no motion to analyse; check the "
                    "silhouettes or choose another clip"
                )
            c = min(n_components, int(keep.sum()))
            sing = np.sqrt(evals[:c])
            comps = (u[:, :c].T @ x) / sing[:, None]
            total = float(evals.sum()) / n
        else:
            _, sing_all, vt = np.linalg.svd(x, full_matrices=False)
            if sing_all[0] <= 0 or not np.any(sing_all > 0):
                raise GaitInputError(
                    "all frames are identical: there is no motion to analyse; check the "
                    "silhouettes or choose another clip"
                )
            keep = sing_all**2 > _EIG_EPS * sing_all[0] ** 2
            c = min(n_components, int(keep.sum()))
            sing = sing_all[:c]
            comps = vt[:c]
            total = float((sing_all**2).sum()) / n
        eigenvalues = sing**2 / n
        # Fix the sign of each component so results do not flip between runs or machines:
        # the largest-magnitude pixel of each eigen-image is positive.
        flip = np.sign(comps[np.arange(c), np.abs(comps).argmax(axis=1)])
        comps *= flip[:, None]
        projections = (x @ comps.T) / np.sqrt(eigenvalues)
        for arr in (mean, comps, eigenvalues, projections):
            arr.setflags(write=False)
        return cls(
            image_shape=_image_shape(images),
            mean=mean,
            components=comps,
            eigenvalues=eigenvalues,
            total_variance=total,
            projections=projections,
        )

    @property
    def n_components(self) -> int:
        return self.components.shape[0]

    @property
    def variance_ratio(self) -> np.ndarray:
        """Share of the total variance carried by each kept component, shape (c,)."""
        return self.eigenvalues / self.total_variance

    def project(self, images: np.ndarray) -> np.ndarray:
        """Normalized projections of new images onto the fitted components.

        Parameters
        ----------
        images : array_like of shape (n, rows, cols) or (rows, cols)

        Returns
        -------
        ndarray of shape (n, c) (or (c,) for one image)
        """
        arr = np.asarray(images)
        single = arr.ndim == 2
        x = _as_float_stack(arr[None] if single else arr, min_frames=1)
        if x.shape[1] != self.mean.size:
            raise GaitInputError(
                f"images are {arr.shape[-2]}x{arr.shape[-1]} but the PCA was fitted on "
                f"{self.image_shape[0]}x{self.image_shape[1]} images"
            )
        p = ((x - self.mean) @ self.components.T) / np.sqrt(self.eigenvalues)
        return p[0] if single else p

    def eigen_images(self, scale: float = 2.0) -> np.ndarray:
        """Mean minus and plus each component, as in the paper's Figure 7.

        Parameters
        ----------
        scale : float
            How many standard deviations to move along each component.

        Returns
        -------
        ndarray of shape (c, 3, rows, cols)
            For each component k: mean - s sqrt(l_k) e_k, mean, mean + s sqrt(l_k) e_k.
        """
        step = scale * np.sqrt(self.eigenvalues)[:, None] * self.components
        out = np.stack([self.mean - step, np.broadcast_to(self.mean, step.shape), self.mean + step], 1)
        return out.reshape(self.n_components, 3, *self.image_shape)


def _image_shape(images: np.ndarray) -> tuple[int, int]:
    arr = np.asarray(images)
    return int(arr.shape[-2]), int(arr.shape[-1])


def _as_float_stack(images: np.ndarray, *, min_frames: int = 2) -> np.ndarray:
    arr = np.asarray(images)
    if arr.ndim != 3:
        raise GaitInputError(
            f"expected a stack of images of shape (frames, rows, cols), got shape {arr.shape}"
        )
    if arr.shape[0] < min_frames:
        raise GaitInputError(
            f"need at least {min_frames} frames for PCA, got {arr.shape[0]}; use a longer clip"
        )
    if arr.shape[1] * arr.shape[2] == 0:
        raise GaitInputError("images are empty (zero rows or columns)")
    x = arr.reshape(arr.shape[0], -1)
    if x.dtype == bool:
        return x.astype(float)
    if np.issubdtype(x.dtype, np.integer):
        return x.astype(float) / (255.0 if x.max(initial=0) > 1 else 1.0)
    x = x.astype(float, copy=True)
    if not np.all(np.isfinite(x)):
        raise GaitInputError("images contain NaN or infinite values")
    return x
