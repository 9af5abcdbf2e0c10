"""Principal component analysis of binary silhouette images (paper Section 2.3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report

_EIG_EPS = 1e-10
"""Eigenvalues below this fraction of the largest are treated as zero (no variance)."""

DENSE_LIMIT = 30_000_000
"""Above this many values (frames x pixels) the data is never copied to one float matrix:
the components come from a randomized SVD that streams the frames in chunks (long clips)."""

_CHUNK_ROWS = 512
_OVERSAMPLE = 10
_POWER_ITERS = 4
_STREAM_PASSES = 5 + 2 * _POWER_ITERS
"""Passes over the frames of the streamed fit: mean, variance, sketch, 2 per power
iteration, components, projections."""


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
    def fit(cls, images: np.ndarray, n_components: int = 5, *,
            progress: Progress | None = None) -> ImagePCA:
        """Fit the PCA to a stack of images.

        Parameters
        ----------
        images : array_like of shape (n, rows, cols)
            Binary (bool or 0/1 or 0/255) or grey images; converted to float in [0, 1] when
            integer-valued up to 255.
        n_components : int
            Number of components to keep, c >= 1. Fewer are kept when the clip has fewer
            non-zero eigenvalues (at most n - 1).
        progress : callable(done, total) -> bool, optional
            Called as the frames are read (after each chunk of a long clip); returning False
            cancels.

        Returns
        -------
        ImagePCA

        Raises
        ------
        GaitInputError
            Fewer than 2 frames, non-finite values, or frames that are all identical.
        Cancelled
            If ``progress`` returned False.

        Notes
        -----
        Paper equations (1)-(5). The eigenvectors come from the smaller of the n x n Gram
        matrix I I^T and the d x d covariance I^T I of the centred data matrix I (n x d).
        Clips larger than ``DENSE_LIMIT`` values (long clips) use a randomized SVD streaming
        the frames in chunks, so memory does not grow with n x d.
        """
        arr = np.asarray(images)
        _check_stack(arr)
        if n_components < 1:
            raise GaitInputError(f"n_components must be at least 1, got {n_components}")
        if arr.shape[0] * arr.shape[1] * arr.shape[2] > DENSE_LIMIT:
            return cls._fit_streamed(arr, n_components, progress)
        report(progress, 0, 1, _CANCELLED)
        x = _as_float_stack(arr)
        n = x.shape[0]
        mean = x.mean(axis=0)
        x -= mean
        frames_side = x.shape[0] <= x.shape[1]
        evals, vecs = np.linalg.eigh(x @ x.T if frames_side else x.T @ x)
        order = np.argsort(evals)[::-1]
        evals, vecs = np.maximum(evals[order], 0.0), vecs[:, order]
        keep = evals > _EIG_EPS * max(evals[0], np.finfo(float).tiny)
        if not keep.any() or evals[0] <= 0:
            raise GaitInputError(_IDENTICAL)
        c = min(n_components, int(keep.sum()))
        sing = np.sqrt(evals[:c])
        comps = (vecs[:, :c].T @ x) / sing[:, None] if frames_side else vecs[:, :c].T
        total = float(evals.sum()) / n
        report(progress, 1, 1, _CANCELLED)
        return cls._finish(arr.shape, mean, comps, sing, total, x @ comps.T)

    @classmethod
    def _fit_streamed(cls, arr: np.ndarray, n_components: int,
                      progress: Progress | None) -> ImagePCA:
        """Randomized SVD (Halko, Martinsson and Tropp 2011) over chunks of frames.

        Memory stays at a few chunks of float rows plus (frames + pixels) x (c + 10) floats,
        whatever the clip's length.
        """
        n = arr.shape[0]
        flat = arr.reshape(n, -1)
        d = flat.shape[1]
        # Scaled like _as_float_stack: 0/255 masks and grey levels map to [0, 1].
        scale = 255.0 if np.issubdtype(flat.dtype, np.integer) and flat.max(initial=0) > 1 else 1.0
        n_chunks = -(-n // _CHUNK_ROWS)
        passes = iter(range(_STREAM_PASSES))

        def chunks():  # one pass over the frames, reported chunk by chunk
            start = next(passes) * n_chunks
            for i, rows in enumerate(_chunks(flat, scale)):
                yield i, rows
                report(progress, start + i + 1, _STREAM_PASSES * n_chunks, _CANCELLED)

        mean = np.zeros(d)
        sq_sum = 0.0
        for _, rows in chunks():
            mean += rows.sum(axis=0)
        mean /= n
        for _, rows in chunks():
            sq_sum += float(((rows - mean) ** 2).sum())
        total = sq_sum / n
        if total <= 0:
            raise GaitInputError(_IDENTICAL)
        width = min(n_components + _OVERSAMPLE, n, d)

        def times(v: np.ndarray) -> np.ndarray:  # (X - mean) @ v, shape (n, l)
            out = np.empty((n, v.shape[1]))
            shift = mean @ v
            for i, rows in chunks():
                out[i * _CHUNK_ROWS : i * _CHUNK_ROWS + rows.shape[0]] = rows @ v - shift
            return out

        def times_t(u: np.ndarray) -> np.ndarray:  # (X - mean).T @ u, shape (d, l)
            acc = -np.outer(mean, u.sum(axis=0))
            for i, rows in chunks():
                acc += rows.T @ u[i * _CHUNK_ROWS : i * _CHUNK_ROWS + rows.shape[0]]
            return acc

        rng = np.random.default_rng(0)
        q = np.linalg.qr(times(rng.standard_normal((d, width))))[0]
        for _ in range(_POWER_ITERS):
            q = np.linalg.qr(times(np.linalg.qr(times_t(q))[0]))[0]
        _, sing_all, vt = np.linalg.svd(times_t(q).T, full_matrices=False)
        keep = sing_all**2 > _EIG_EPS * max(sing_all[0] ** 2, np.finfo(float).tiny)
        c = min(n_components, int(keep.sum()))
        if c == 0:
            raise GaitInputError(_IDENTICAL)
        comps = vt[:c]
        return cls._finish(arr.shape, mean, comps, sing_all[:c], total, times(comps.T))

    @classmethod
    def _finish(cls, shape, mean, comps, sing, total, scores) -> ImagePCA:
        """Fix signs, normalize projections and freeze the arrays."""
        eigenvalues = sing**2 / shape[0]
        # Fix the sign of each component so results do not flip between runs or machines:
        # the largest-magnitude pixel of each eigen-image is positive.
        flip = np.sign(comps[np.arange(comps.shape[0]), np.abs(comps).argmax(axis=1)])
        comps = comps * flip[:, None]
        projections = scores * flip / np.sqrt(eigenvalues)
        for arr in (mean, comps, eigenvalues, projections):
            arr.setflags(write=False)
        return cls(
            image_shape=(int(shape[1]), int(shape[2])),
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
        out = np.stack([self.mean - step, np.broadcast_to(self.mean, step.shape),
                        self.mean + step], 1)
        return out.reshape(self.n_components, 3, *self.image_shape)


_CANCELLED = "PCA cancelled"
_IDENTICAL = (
    "all frames are identical: there is no motion to analyse; check the silhouettes or "
    "choose another clip"
)


def _chunks(flat: np.ndarray, scale: float):
    """Rows of ``flat`` as float64 blocks of _CHUNK_ROWS, divided by ``scale``."""
    for i in range(0, flat.shape[0], _CHUNK_ROWS):
        yield flat[i : i + _CHUNK_ROWS].astype(float) / scale


def _check_stack(arr: np.ndarray, *, min_frames: int = 2) -> None:
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
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise GaitInputError("images contain NaN or infinite values")


def _as_float_stack(images: np.ndarray, *, min_frames: int = 2) -> np.ndarray:
    arr = np.asarray(images)
    _check_stack(arr, min_frames=min_frames)
    x = arr.reshape(arr.shape[0], -1)
    if x.dtype == bool:
        return x.astype(float)
    if np.issubdtype(x.dtype, np.integer):
        return x.astype(float) / (255.0 if x.max(initial=0) > 1 else 1.0)
    return x.astype(float, copy=True)
