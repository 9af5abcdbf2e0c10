"""Colour models of subject and background for segmentation (paper Section 2.2).

A Gaussian mixture per class, fitted in CIE Lab on the pixels of the artist's rectangles
(weighted histograms over quantized BGR, so refits are cheap), and a lookup table of the
subject's posterior over those BGR bins, so classifying a frame is one table lookup per pixel.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import lru_cache

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.silhouettes.annotations import Rect

_COV_REG = 4.0  # added to covariance diagonals (Lab units squared): JPEG noise, quantization


@lru_cache(maxsize=4)
def bin_centres_bgr(bits: int) -> np.ndarray:
    """BGR centres of the colour bins of :func:`bin_index`, shape (2**(3*bits), 3), float64."""
    step = 1 << (8 - bits)
    c = np.arange(1 << bits) * step + step // 2
    out = np.stack(np.meshgrid(c, c, c, indexing="ij"), -1).reshape(-1, 3).astype(np.float64)
    out.flags.writeable = False
    return out


@lru_cache(maxsize=4)
def _bin_lab(bits: int) -> np.ndarray:
    """Lab coordinates of the centres of the BGR bins, shape (2**(3*bits), 3), float64."""
    bgr = bin_centres_bgr(bits).astype(np.uint8).reshape(-1, 1, 3)
    lab = cv2.cvtColor(bgr, cv2.COLOR_BGR2Lab).reshape(-1, 3).astype(np.float64)
    lab.flags.writeable = False
    return lab


def bin_index(image: np.ndarray, bits: int) -> np.ndarray:
    """Flat bin index of every pixel of a BGR uint8 image, shape (rows, cols), intp."""
    q = image >> (8 - bits)
    return (q[..., 0].astype(np.intp) << 2 * bits) | (q[..., 1].astype(np.intp) << bits) | q[..., 2]


@dataclass(frozen=True, eq=False)
class _Gmm:
    means: np.ndarray  # (k, 3)
    covs: np.ndarray  # (k, 3, 3)
    weights: np.ndarray  # (k,)

    def component_loglik(self, x: np.ndarray) -> np.ndarray:
        """Log of weight times density of each component, shape (k, m), for x (m, 3)."""
        xt = [np.ascontiguousarray(x[:, i]) for i in range(3)]
        out = np.empty((self.weights.size, x.shape[0]))
        for j, (mu, cov, w) in enumerate(zip(self.means, self.covs, self.weights)):
            chol = np.linalg.cholesky(cov)
            a = np.linalg.inv(chol)  # lower triangular: z = a (x - mu)
            d0, d1, d2 = xt[0] - mu[0], xt[1] - mu[1], xt[2] - mu[2]
            q = (a[0, 0] * d0) ** 2
            q += (a[1, 0] * d0 + a[1, 1] * d1) ** 2
            q += (a[2, 0] * d0 + a[2, 1] * d1 + a[2, 2] * d2) ** 2
            out[j] = np.log(w + 1e-12) - np.log(np.diag(chol)).sum() - 0.5 * q
        return out

    def loglik(self, x: np.ndarray) -> np.ndarray:
        return _logsumexp0(self.component_loglik(x))

    @classmethod
    def fit(cls, x: np.ndarray, w: np.ndarray, k: int, *, init: _Gmm | None = None,
            iters: int = 30, seed: int = 0) -> _Gmm:
        """Weighted EM on points ``x`` (m, 3) with weights ``w`` (m,); k-means++ start."""
        k = min(k, x.shape[0])
        reg = np.eye(3) * _COV_REG
        if init is not None and init.weights.size == k:
            g = init
        else:
            rng = np.random.default_rng(seed)
            p = w / w.sum()
            centres = [x[rng.choice(x.shape[0], p=p)]]
            for _ in range(k - 1):
                d = np.min(((x[:, None, :] - np.array(centres)[None]) ** 2).sum(-1), axis=1) * w
                pick = rng.choice(x.shape[0], p=d / d.sum()) if d.sum() > 0 else 0
                centres.append(x[pick])
            cov = np.cov(x.T, aweights=w, bias=True) if x.shape[0] > 1 else np.zeros((3, 3))
            g = cls(np.array(centres), np.repeat((cov + reg)[None], k, 0), np.full(k, 1.0 / k))
        for _ in range(iters):
            ll = g.component_loglik(x)
            r = np.exp(ll - _logsumexp0(ll)) * w  # (k, m) responsibilities times weights
            nk = r.sum(1) + 1e-12
            means = (r @ x) / nk[:, None]
            covs = np.empty((k, 3, 3))
            for j in range(k):
                d = x - means[j]
                covs[j] = (d * r[j][:, None]).T @ d / nk[j] + reg
            g = cls(means, covs, nk / nk.sum())
        return g


def _logsumexp0(a: np.ndarray) -> np.ndarray:
    """log(sum(exp(a), axis=0)) without overflow."""
    top = a.max(axis=0)
    return top + np.log(np.exp(a - top).sum(axis=0))


@dataclass(frozen=True, eq=False)
class ColourModel:
    """Gaussian mixture colour models of subject and background, tabulated as a posterior.

    Attributes
    ----------
    lut : ndarray of shape (2**(3*bits),), uint8
        Posterior probability of "subject" times 255 for every quantized BGR colour.
    bits : int
        Bits kept per BGR channel.
    fg, bg : mixture models
        Subject and background mixtures (means, covariances and weights in Lab).
    first_fg_hist, first_bg_hist : ndarray of shape (2**(3*bits),), float64
        Normalized colour histograms of the first frame's rectangles (refits mix them in).

    Notes
    -----
    Paper Section 2.2: "a simple segmentation based on mixture of Gaussians". Mixtures are
    fitted in Lab to the histogram of the rectangles' pixels (weighted EM over occupied bins),
    with equal priors for subject and background.
    """

    lut: np.ndarray
    bits: int
    fg: _Gmm
    bg: _Gmm
    first_fg_hist: np.ndarray
    first_bg_hist: np.ndarray

    @classmethod
    def fit(cls, frame_bgr: np.ndarray, subject_rects: Sequence[Rect | tuple],
            background_rects: Sequence[Rect | tuple], *, n_components: int = 5,
            lut_bits: int = 5) -> ColourModel:
        """Fit both mixtures to the pixels under the rectangles of one frame.

        Parameters
        ----------
        frame_bgr : ndarray of shape (rows, cols, 3), uint8
        subject_rects, background_rects : sequence of Rect or (x, y, w, h)
            At least one each; clipped to the frame. Pixels under both kinds are ignored.

        Raises
        ------
        GaitInputError
            Missing, empty or out-of-frame rectangles, or too few pixels to fit.
        """
        frame = check_frame(frame_bgr)
        fg_m = rect_mask(frame.shape, subject_rects, "subject")
        bg_m = rect_mask(frame.shape, background_rects, "background")
        both = fg_m & bg_m
        fg_m, bg_m = fg_m & ~both, bg_m & ~both
        for name, m in (("subject", fg_m), ("background", bg_m)):
            if m.sum() < 16:
                raise GaitInputError(
                    f"the {name} rectangles hold fewer than 16 pixels of their own (do subject "
                    "and background rectangles overlap?): draw larger, separate rectangles"
                )
        return cls._fit(frame, fg_m, bg_m, n_components, lut_bits)

    @classmethod
    def fit_masks(cls, frame_bgr: np.ndarray, subject: np.ndarray, background: np.ndarray, *,
                  n_components: int = 5, lut_bits: int = 5) -> ColourModel | None:
        """Fit both mixtures to the pixels of two masks of one frame (rectangles or brush
        strokes); pixels in both are ignored. None when either keeps fewer than 16 pixels."""
        both = subject & background
        fg_m, bg_m = subject & ~both, background & ~both
        if min(int(fg_m.sum()), int(bg_m.sum())) < 16:
            return None
        return cls._fit(frame_bgr, fg_m, bg_m, n_components, lut_bits)

    @classmethod
    def _fit(cls, frame_bgr: np.ndarray, fg_m: np.ndarray, bg_m: np.ndarray, n_components: int,
             lut_bits: int) -> ColourModel:
        fh = _histogram(frame_bgr, fg_m, lut_bits)
        bh = _histogram(frame_bgr, bg_m, lut_bits)
        fg = _fit_hist(fh, lut_bits, n_components, None)
        bg = _fit_hist(bh, lut_bits, n_components, None)
        return cls(_make_lut(fg, bg, lut_bits), lut_bits, fg, bg, fh, bh)

    def refit(self, image_bgr: np.ndarray, fg_mask: np.ndarray, bg_mask: np.ndarray, *,
              keep_first: float = 0.5) -> ColourModel:
        """A model refitted to confident pixels of a later frame, mixed with the first frame's.

        Returns ``self`` when either mask holds fewer than 16 pixels.
        """
        if fg_mask.sum() < 16 or bg_mask.sum() < 16:
            return self
        a = float(np.clip(keep_first, 0.0, 1.0))
        fh = a * self.first_fg_hist + (1 - a) * _histogram(image_bgr, fg_mask, self.bits)
        bh = a * self.first_bg_hist + (1 - a) * _histogram(image_bgr, bg_mask, self.bits)
        fg = _fit_hist(fh, self.bits, self.fg.weights.size, self.fg)
        bg = _fit_hist(bh, self.bits, self.bg.weights.size, self.bg)
        return replace(self, lut=_make_lut(fg, bg, self.bits), fg=fg, bg=bg)

    def posterior(self, image_bgr: np.ndarray) -> np.ndarray:
        """Probability of "subject" per pixel times 255, shape (rows, cols), uint8."""
        return self.lut[bin_index(image_bgr, self.bits)]


def _histogram(image: np.ndarray, mask: np.ndarray, bits: int) -> np.ndarray:
    h = np.bincount(bin_index(image[mask], bits).ravel(), minlength=1 << 3 * bits).astype(float)
    return h / max(h.sum(), 1.0)


def _fit_hist(h: np.ndarray, bits: int, k: int, init: _Gmm | None) -> _Gmm:
    nz = np.nonzero(h)[0]
    return _Gmm.fit(_bin_lab(bits)[nz], h[nz], k, init=init, iters=8 if init else 30)


def _make_lut(fg: _Gmm, bg: _Gmm, bits: int) -> np.ndarray:
    lab = _bin_lab(bits)
    diff = np.clip(bg.loglik(lab) - fg.loglik(lab), -30, 30)
    return np.round(255.0 / (1.0 + np.exp(diff))).astype(np.uint8)


def check_frame(frame: np.ndarray) -> np.ndarray:
    """The frame as an array, or a GaitInputError if it is not 8-bit BGR colour."""
    arr = np.asarray(frame)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.dtype != np.uint8:
        raise GaitInputError(
            f"expected a BGR frame of shape (rows, cols, 3) and dtype uint8, got {arr.shape} "
            f"{arr.dtype}: convert the image to 8-bit colour"
        )
    return arr


def rect_mask(shape: tuple[int, ...], rects: Sequence[Rect | tuple], what: str) -> np.ndarray:
    """Union of rectangles clipped to the frame, as a (rows, cols) bool mask."""
    if not rects:
        raise GaitInputError(f"no {what} rectangle given: draw at least one on the first frame")
    rows, cols = shape[:2]
    out = np.zeros((rows, cols), bool)
    for r in rects:
        rect = r if isinstance(r, Rect) else Rect(*r)
        out[rect.clipped_to(cols, rows).slices()] = True
    return out


@dataclass(frozen=True, eq=False)
class ColourTable:
    """Log-likelihood ratio, subject against background, of every quantized BGR colour.

    Attributes
    ----------
    llr : ndarray of shape (2**(3*bits),), float32
        Clipped to [-8, 8].
    bits : int
        Bits kept per BGR channel.
    gap : float
        How far apart the two sides of the frame it was learnt on stand under it
        (:func:`colour_gap`); 0 when not known.
    """

    llr: np.ndarray
    bits: int = 5
    gap: float = 0.0

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """The ratio of every pixel of a BGR uint8 image, shape (rows, cols), float32."""
        return self.llr[bin_index(image, self.bits)]


def learn_colours(image: np.ndarray, mask: np.ndarray,
                  taught: tuple[np.ndarray, np.ndarray] | None = None) -> ColourTable | None:
    """The colour mixtures of a frame whose silhouette is known, tabulated.

    Parameters
    ----------
    image : ndarray of shape (h, w, 3), uint8
    mask : ndarray of shape (h, w), uint8 0/1
    taught : (ndarray of shape (n, 3) uint8, ndarray of shape (n,) uint8 0/1), optional
        More pixels and their sides, learnt from beside the image's (an artist's strokes);
        the gap is still measured on the image alone.

    Returns
    -------
    ColourTable, or None when either side has fewer than 16 pixels.

    Notes
    -----
    The mixtures are the graph cut's own (five Gaussians per side in BGR, learnt by
    ``cv2.grabCut`` from the mask as sure labels).
    """
    if taught is None:
        mixtures = _mixtures(image, mask, 1)
    else:
        mixtures = _mixtures(np.concatenate([image.reshape(-1, 3), taught[0]])[None],
                             np.concatenate([mask.reshape(-1), taught[1]])[None], 1)
    if mixtures is None:
        return None
    fgd, bgd = mixtures
    centres = bin_centres_bgr(6)
    llr = _mixture_loglik(fgd, centres) - _mixture_loglik(bgd, centres)
    llr = np.clip(llr, -8, 8).astype(np.float32)
    return ColourTable(llr, 6, colour_gap(llr[bin_index(image, 6)], mask > 0))


def colour_gap(ratios: np.ndarray, mask: np.ndarray) -> float:
    """The mean of a :class:`ColourTable`'s ratios over a mask's pixels less their mean over
    the others (0 when either side is empty): how far apart the two sides stand."""
    inside = ratios[mask]
    outside = ratios[~mask]
    if not inside.size or not outside.size:
        return 0.0
    return float(inside.mean() - outside.mean())


def colour_separation(image: np.ndarray, mask: np.ndarray) -> float:
    """How well colour mixtures fit to each side of a silhouette tell its sides apart.

    Parameters
    ----------
    image : ndarray of shape (h, w, 3), uint8
    mask : ndarray of shape (h, w), uint8 0/1

    Returns
    -------
    float
        The mean over the image of each pixel's log-likelihood ratio (within +-8, as in
        :func:`learn_colours`) for the side the mask gives it: GrabCut's data term, per
        pixel, with sign. -inf when either side has fewer than 16 pixels.

    Notes
    -----
    The mixtures are ``cv2.grabCut``'s initial ones (k-means, five Gaussians a side), fit
    and measured on every second pixel each way: cheap enough to compare several candidate
    cuts of one frame.
    """
    image, mask = image[::2, ::2], mask[::2, ::2]
    mixtures = _mixtures(image, mask, 0)
    if mixtures is None:
        return -np.inf
    fgd, bgd = mixtures
    x = image.reshape(-1, 3).astype(np.float64)
    llr = np.clip(_mixture_loglik(fgd, x) - _mixture_loglik(bgd, x), -8, 8)
    return float(np.where(mask.ravel() > 0, llr, -llr).mean())


def _mixtures(image: np.ndarray, mask: np.ndarray,
              iters: int) -> tuple[np.ndarray, np.ndarray] | None:
    """``cv2.grabCut``'s subject and background mixtures for a known silhouette (its sides as
    sure labels): k-means alone with ``iters`` 0, learnt again ``iters`` times otherwise;
    None when either side has fewer than 16 pixels."""
    if min(int(mask.sum()), int(mask.size - mask.sum())) < 16:
        return None
    labels = np.where(mask > 0, cv2.GC_FGD, cv2.GC_BGD).astype(np.uint8)
    bgd, fgd = np.zeros((1, 65)), np.zeros((1, 65))
    cv2.setRNGSeed(0)
    cv2.grabCut(np.ascontiguousarray(image), labels, None, bgd, fgd, iters,
                cv2.GC_INIT_WITH_MASK)
    return fgd, bgd


COLOUR_NOISE_VAR = 1.0
"""Variance added to every mixture component, (BGR levels)^2: one 8-bit level of noise.
Without it a component of one flat colour (a rendered or blown-out sky) is so narrow that the
few pixels of it a first cut takes outweigh the whole background, and the subject floods into
it."""


def _mixture_loglik(model: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Log density of ``cv2.grabCut``'s mixture (weights 5, means 5x3, covariances 5x9) at
    points ``x`` (m, 3)."""
    m = model.ravel()
    weights, means, covs = m[:5], m[5:20].reshape(5, 3), m[20:65].reshape(5, 3, 3)
    terms = np.full((5, x.shape[0]), -np.inf)
    for k in np.nonzero(weights > 0)[0]:
        cov = covs[k] + np.eye(3) * COLOUR_NOISE_VAR
        d = x - means[k]
        q = np.einsum("ni,ni->n", d @ np.linalg.inv(cov), d)  # 2.6 times the three-way einsum
        terms[k] = np.log(weights[k]) - 0.5 * np.log(np.linalg.det(cov)) - 0.5 * q
    top = terms.max(axis=0)
    return top + np.log(np.exp(terms - top).sum(axis=0))
