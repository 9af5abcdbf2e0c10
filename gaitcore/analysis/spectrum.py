"""Spectral diagnosis of the PC trajectories: is this clip usable? (paper Section 5.2).

The first principal component of a usable clip oscillates at the gait frequency. A peak
``peak(f) = 1 / (1 + ((f - f0) / (fb - f0))**2)`` (paper equation (20)) is fitted to its
amplitude spectrum, the band ``f0 +/- 3 |fb - f0|`` (where the peak is down to 10 %) is kept
by a rectangular band-pass filter, and every PC trajectory is compared with its band-passed
version: PC1 and PC2 must both correlate at r >= 0.6 for the clip to be usable.

All frequencies are in cycles per frame; periods are in frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import gammaln

from gaitcore.analysis.verdict import Verdict, explain
from gaitcore.errors import GaitInputError

MIN_FRAMES = 8
"""Fewest frames :func:`diagnose` accepts."""

PAD_FACTOR = 16
"""The spectrum is computed on a grid PAD_FACTOR times finer than the plain FFT's 1/n."""

MIN_FFT_LENGTH = 4096
"""Shortest zero-padded FFT, so that short clips still get a smooth spectrum to plot."""

_FLAT_RTOL = 1e-12
"""A trajectory whose standard deviation is below this fraction of its largest magnitude is
treated as constant."""

_BIN_TOL = 1e-9
"""Tolerance, in FFT bins, for deciding whether a bin lies on a band edge (edges inclusive)."""


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    f0 : float
        Frequency of the largest non-DC amplitude of PC1, in cycles per frame.
    fb : float
        Frequency nearest to ``f0`` at which PC1's amplitude has fallen to half its maximum.
    band : tuple of float
        ``(f0 - 3 |fb - f0|, f0 + 3 |fb - f0|)``, the lower end clipped at 0, cycles per frame.
    period_frames : float
        ``1 / f0``. For a side-view walk, whose two half-cycles look alike, PC1 may oscillate
        twice per gait cycle: this is then the half-cycle.
    correlations : ndarray of shape (c,)
        ``r_k``, Pearson correlation of PC_k with its band-passed version, in [-1, 1]
        (0 when either is constant).
    periodicity_p : float
        Fisher's test of the first two columns' loop against white noise
        (:func:`fisher_periodicity_p`): small when they hold a rhythm.
    filtered : ndarray of shape (n, c)
        Band-passed trajectories (they may drive the animation instead of the raw ones).
    frequencies : ndarray of shape (m,)
        Frequencies of the zero-padded spectrum, from 0 to 0.5, for plotting (paper Fig. 9).
    amplitudes : ndarray of shape (m, c)
        Amplitude spectrum of each PC (mean removed), scaled by ``2 / n`` so that a sinusoid
        of amplitude A shows a peak of height about A.
    verdict : Verdict
    reason : str
        Plain words for an artist: what the numbers say and what to do next.
    """

    f0: float
    fb: float
    band: tuple[float, float]
    period_frames: float
    correlations: np.ndarray
    filtered: np.ndarray
    frequencies: np.ndarray
    amplitudes: np.ndarray
    periodicity_p: float
    verdict: Verdict
    reason: str

    def peak(self, f: float | np.ndarray) -> float | np.ndarray:
        """The peak function fitted to PC1's spectrum.

        Parameters
        ----------
        f : float or ndarray of any shape
            Frequencies, cycles per frame.

        Returns
        -------
        float or ndarray of the shape of ``f``
            ``1 / (1 + ((f - f0) / (fb - f0))**2)``: 1 at ``f0``, 1/2 at ``fb``, 1/10 at the
            band edges.

        Notes
        -----
        Paper equation (20).
        """
        u = (np.asarray(f, dtype=float) - self.f0) / (self.fb - self.f0)
        return 1.0 / (1.0 + u * u)


def diagnose(
    projections: np.ndarray, *, threshold: float = 0.6, sketched: bool = False,
    f0_hint: float | None = None, names: tuple[str, ...] = ("PC1", "PC2"),
) -> Diagnosis:
    """Decide from the PC trajectories whether a clip is usable.

    Parameters
    ----------
    projections : array_like of shape (n, c)
        PCA projections p(t) of the n frames on c >= 2 components (PC1 first), finite,
        n >= 8.
    threshold : float
        Smallest r1 and r2 of a usable clip, in [0, 1]. The paper uses 0.6.
    sketched : bool
        True when the silhouettes already are sketches: a failing clip is then declared not
        usable instead of suggesting to sketch it.
    f0_hint : float, optional
        The rhythm's frequency found from the silhouettes' repeats (cycles per frame,
        :func:`gaitcore.analysis.rhythm.find_rhythm`), taken as ``f0``: on a clip of two or
        three cycles a single component's spectral peak is broad and can be pulled by a
        slow residue, while the frames' repeats time the cycle to a frame.
    names : tuple of str
        What the first two columns are called in the reason ("PC3", "PC5"...).

    Returns
    -------
    Diagnosis

    Raises
    ------
    GaitInputError
        If ``projections`` is not a finite (n, c) array with n >= 8 and c >= 2, if PC1 is
        constant (no motion), or if ``threshold`` is not in [0, 1].

    Notes
    -----
    Paper Section 5.2, equation (20). The spectrum of PC1 (mean removed) is computed with an
    FFT zero-padded to at least ``PAD_FACTOR * n`` points (a grid 16 times finer than 1/n),
    ``f0`` is refined by a parabola through the three grid amplitudes around the maximum,
    and ``fb`` is where the amplitude crosses half the maximum, interpolated linearly between
    grid points, on whichever side of ``f0`` is nearer. Zero padding does not sharpen the
    peak (its width stays about 1.2/n for a perfectly periodic signal) but samples it finely
    enough for ``f0`` and ``fb`` to be read off without the 1/n quantisation of a plain FFT.
    The band-pass window's grid is aligned on ``f0``; see :func:`band_pass`.
    The clip counts as having no periodic peak when ``f0 * n < MIN_CYCLES``. On clips shorter
    than about 35 frames the band covers so much of the spectrum that white noise reaches
    r of about 0.5 to 0.9; the verdict rule is unchanged but ``reason`` then carries a caution.
    """
    x = _as_projections(projections)
    threshold = _as_threshold(threshold)
    n, c = x.shape

    # Work in units of each column's largest magnitude: correlations do not depend on scale,
    # and sums of squares cannot overflow whatever the input's magnitude.
    scale = np.abs(x).max(axis=0)
    scale[scale == 0.0] = 1.0
    xn = x / scale
    centered = xn - xn.mean(axis=0)
    if centered[:, 0].std() <= _FLAT_RTOL:
        raise GaitInputError(
            "PC1 is constant over the clip: there is no motion to diagnose. Check that the "
            "silhouettes change from frame to frame (segmentation or sketches may be empty)."
        )

    n_fft = _padded_length(n)
    frequencies = np.fft.rfftfreq(n_fft)
    amplitudes_n = (2.0 / n) * np.abs(np.fft.rfft(centered, n=n_fft, axis=0))
    f0, peak_amp = _peak_frequency(frequencies, amplitudes_n[:, 0], f0_hint)
    fb = _half_max_frequency(frequencies, amplitudes_n[:, 0], f0, 0.5 * peak_amp)
    half_width = abs(fb - f0)
    band = (max(0.0, f0 - 3.0 * half_width), f0 + 3.0 * half_width)

    filtered_n = band_pass(xn, band, centre=f0)
    correlations = np.array([_pearson(xn[:, k], filtered_n[:, k]) for k in range(c)])
    pair = centered[:, :2] / np.maximum(centered[:, :2].std(axis=0), _FLAT_RTOL)
    p_value = fisher_periodicity_p(pair[:, 0] + 1j * pair[:, 1])
    verdict, reason = explain(correlations, f0, band, n, threshold, sketched, p_value, names)
    return Diagnosis(
        f0=float(f0),
        fb=float(fb),
        band=(float(band[0]), float(band[1])),
        period_frames=float(1.0 / f0),
        correlations=correlations,
        filtered=filtered_n * scale,
        frequencies=frequencies,
        amplitudes=amplitudes_n * scale,
        periodicity_p=p_value,
        verdict=verdict,
        reason=reason,
    )


def fisher_periodicity_p(signal: np.ndarray) -> float:
    """Probability that white noise has a periodogram peak as dominant as ``signal``'s.

    Parameters
    ----------
    signal : ndarray of shape (n,), real or complex
        Mean-removed trajectory; complex for a pair of them (``a + 1j * b``, each scaled to
        unit variance): a loop that turns one way then puts its whole rhythm on one side of
        the spectrum.

    Returns
    -------
    float
        p-value of Fisher's g test (Fisher 1929): g is the largest periodogram ordinate over
        the sum of the ordinates at the Fourier frequencies 1..(n-1)//2 (DC and Nyquist
        excluded; for a complex signal, the negative frequencies too); small p means a real
        rhythm.
    """
    z = np.asarray(signal)
    n = len(z)
    if np.iscomplexobj(z):
        spectrum = np.fft.fft(z)
        bins = [k for k in range(1, n) if 2 * k != n]
        power = np.abs(spectrum[bins]) ** 2
    else:
        power = np.abs(np.fft.rfft(z)[1 : (n - 1) // 2 + 1]) ** 2
    m = power.size
    total = power.sum()
    if m < 2 or total <= 0:
        return 1.0
    g = power.max() / total
    j = np.arange(1, int(np.floor(1.0 / g)) + 1)
    j = j[j * g < 1.0]
    log_binom = gammaln(m + 1) - gammaln(j + 1) - gammaln(m - j + 1)
    terms = (-1.0) ** (j - 1) * np.exp(log_binom + (m - 1) * np.log1p(-j * g))
    return float(np.clip(terms.sum(), 0.0, 1.0))


def band_pass(
    trajectories: np.ndarray, band: tuple[float, float], *, centre: float | None = None
) -> np.ndarray:
    """Keep only the frequencies inside ``band`` (a rectangular window in frequency).

    Parameters
    ----------
    trajectories : array_like of shape (n,) or (n, c)
        Signals along time, one per column, finite, n >= 2.
    band : tuple of float
        ``(low, high)`` in cycles per frame, ``0 <= low <= high``; both edges are inclusive.
    centre : float, optional
        A frequency the window's grid passes through exactly (the fitted peak ``f0``);
        the middle of the band by default.

    Returns
    -------
    ndarray of the shape of ``trajectories``
        The filtered signals. The mean (DC) is removed unless ``low == 0``.

    Raises
    ------
    GaitInputError
        If the trajectories are not a finite 1-D or 2-D array of at least 2 frames, or the
        band is not two finite numbers with ``0 <= low <= high``.

    Notes
    -----
    Paper Section 5.2. The window keeps the sinusoids of the band. Done with a plain FFT its
    grid is the bins k / n, and a clip that does not hold a whole number of cycles (nearly
    every real one) leaks out of the band through the jump between its last and first
    frames: a pure sinusoid of 5.7 cycles keeps only r = 0.97 and its filtered ends are
    pulled towards each other. Here the grid is shifted to pass through ``centre``
    (frequencies ``centre + k / n`` inside the band, the same count as FFT bins, so the
    same share of noise passes) and the signal is projected on those sinusoids by least
    squares. The gait's own rhythm, at ``f0``, is then kept exactly, with no wrap-around.
    """
    try:
        x = np.asarray(trajectories, dtype=float)
    except (TypeError, ValueError) as exc:
        raise GaitInputError(f"trajectories must be numbers: {exc}") from None
    if x.ndim not in (1, 2) or x.shape[0] < 2:
        raise GaitInputError(
            f"trajectories must have shape (n,) or (n, c) with n >= 2 frames, got shape "
            f"{x.shape}: pass one row per frame."
        )
    if not np.all(np.isfinite(x)):
        raise GaitInputError("trajectories contain NaN or infinite values: fix or drop them.")
    low, high = _as_band(band)
    if centre is None:
        centre = 0.5 * (low + high)
    basis = _band_basis(x.shape[0], low, high, float(centre))
    if low > 0.0:
        x = x - x.mean(axis=0)
    if basis.shape[1] == 0:
        return np.zeros_like(x)
    return basis @ (basis.T @ x)


def _band_basis(n: int, low: float, high: float, centre: float) -> np.ndarray:
    """Orthonormal basis (n, k) of the sinusoids at ``centre + j / n`` inside [low, high]."""
    t = np.arange(n)
    j0 = int(np.ceil((low - centre) * n - _BIN_TOL))
    j1 = int(np.floor((high - centre) * n + _BIN_TOL))
    freqs = centre + np.arange(j0, j1 + 1) / n
    freqs = freqs[(freqs > _BIN_TOL / n) & (freqs <= 0.5 + _BIN_TOL / n)]
    phase = 2.0 * np.pi * np.outer(t, freqs)
    columns = [np.cos(phase), np.sin(phase)]
    if low == 0.0:
        columns.append(np.ones((n, 1)))
    vectors = np.concatenate(columns, axis=1)
    if vectors.shape[1] == 0:
        return vectors
    u, sing, _ = np.linalg.svd(vectors, full_matrices=False)
    return u[:, sing > 1e-9 * sing.max()]


def _as_projections(projections: np.ndarray) -> np.ndarray:
    try:
        x = np.asarray(projections, dtype=float)
    except (TypeError, ValueError) as exc:
        raise GaitInputError(f"projections must be numbers: {exc}") from None
    if x.ndim != 2:
        raise GaitInputError(
            f"projections must be a 2-D array of shape (n frames, c components), got shape "
            f"{x.shape}: pass one row per frame."
        )
    n, c = x.shape
    if c < 2:
        raise GaitInputError(
            f"the diagnosis needs at least 2 components (PC1 and PC2), got {c}: fit the PCA "
            "with n_components >= 2."
        )
    if n < MIN_FRAMES:
        raise GaitInputError(
            f"the diagnosis needs at least {MIN_FRAMES} frames, got {n}: use a longer clip "
            "holding at least 1.5 gait cycles."
        )
    if not np.all(np.isfinite(x)):
        raise GaitInputError(
            "projections contain NaN or infinite values: recompute the PCA from valid frames."
        )
    return x


def _as_threshold(threshold: float) -> float:
    try:
        value = float(threshold)
    except (TypeError, ValueError):
        raise GaitInputError(f"threshold must be a number in [0, 1], got {threshold!r}") from None
    if not 0.0 <= value <= 1.0:
        raise GaitInputError(
            f"threshold must be in [0, 1], got {value}: the paper uses 0.6."
        )
    return value


def _as_band(band: tuple[float, float]) -> tuple[float, float]:
    try:
        low, high = (float(v) for v in band)
    except (TypeError, ValueError):
        raise GaitInputError(
            f"band must be two numbers (low, high) in cycles per frame, got {band!r}"
        ) from None
    if not (np.isfinite(low) and np.isfinite(high) and 0.0 <= low <= high):
        raise GaitInputError(
            f"band must satisfy 0 <= low <= high (cycles per frame), got ({low}, {high})."
        )
    return low, high


def _padded_length(n: int) -> int:
    """Power of two at least PAD_FACTOR * n and MIN_FFT_LENGTH."""
    target = max(PAD_FACTOR * n, MIN_FFT_LENGTH)
    return 1 << (target - 1).bit_length()


def _peak_frequency(frequencies: np.ndarray, amplitude: np.ndarray,
                    hint: float | None = None) -> tuple[float, float]:
    """Frequency and height of the largest non-DC amplitude, refined by a parabola; or
    ``hint`` and the amplitude there, when given."""
    if hint is not None and np.isfinite(hint) and 0 < hint <= frequencies[-1]:
        return float(hint), float(np.interp(hint, frequencies, amplitude))
    k = int(np.argmax(amplitude[1:])) + 1
    if k == len(amplitude) - 1:
        return float(frequencies[k]), float(amplitude[k])
    a, b, c = amplitude[k - 1 : k + 2]
    curvature = a - 2.0 * b + c
    if curvature >= 0.0:  # flat top: keep the grid point
        return float(frequencies[k]), float(b)
    shift = 0.5 * (a - c) / curvature  # in (-0.5, 0.5] grid steps since b is the maximum
    step = frequencies[1] - frequencies[0]
    return float(frequencies[k] + shift * step), float(b - 0.25 * (a - c) * shift)


def _half_max_frequency(
    frequencies: np.ndarray, amplitude: np.ndarray, f0: float, half: float
) -> float:
    """Nearest frequency to f0 where the amplitude falls to ``half``, interpolated linearly."""
    k = int(np.argmin(np.abs(frequencies - f0)))
    candidates = []
    below = np.flatnonzero(amplitude[:k] <= half)
    if below.size:  # last grid point below half, left of the peak
        i = below[-1]
        candidates.append(_crossing(frequencies, amplitude, i, i + 1, half))
    above = np.flatnonzero(amplitude[k + 1 :] <= half)
    if above.size:  # first grid point below half, right of the peak
        j = k + 1 + above[0]
        candidates.append(_crossing(frequencies, amplitude, j - 1, j, half))
    if not candidates:  # cannot happen with the mean removed (amplitude 0 at DC)
        return float(frequencies[0])
    fb = min(candidates, key=lambda f: abs(f - f0))
    if fb == f0:  # degenerate; keep the peak function defined
        fb = f0 - (frequencies[1] - frequencies[0])
    return float(fb)


def _crossing(
    frequencies: np.ndarray, amplitude: np.ndarray, i: int, j: int, level: float
) -> float:
    """Where the straight line between grid points i and j reaches ``level``."""
    ai, aj = amplitude[i], amplitude[j]
    t = 0.0 if aj == ai else (level - ai) / (aj - ai)
    return float(frequencies[i] + t * (frequencies[j] - frequencies[i]))


def _pearson(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation in [-1, 1]; 0 when either signal is (numerically) constant."""
    da = a - a.mean()
    db = b - b.mean()
    na = float(np.sqrt(da @ da))
    nb = float(np.sqrt(db @ db))
    if na <= _FLAT_RTOL * np.sqrt(len(a)) or nb <= 1e-9 * na:
        return 0.0
    return float(np.clip((da @ db) / (na * nb), -1.0, 1.0))
