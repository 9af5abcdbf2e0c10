"""The gait's own rhythm in the silhouettes: a slow drift taken out, the stride found, and the
pair of components the rhythm lives in.

On real footage the largest changes between silhouettes are rarely the legs: an animal that
walks away at an angle shrinks and turns, a camera pans, and the first principal components
follow that drift, which holds no rhythm at all. This module separates the two:

1. *Drift*: each trajectory's slow trend (slower than the longest period a clip can show
   :data:`MIN_CYCLES` times, :func:`slow_trend`) is removed where it is one
   (:data:`DRIFT_SHARE`).
2. *Stride*: the silhouettes come back after one gait cycle. The repeat curve (the mean
   distance between frames ``t`` and ``t + lag``, over every component, in units of the
   silhouettes' spread) dips at that lag; its first dip as deep as half the deepest is the
   cycle (:func:`cycle_lag`), as a pitch tracker takes the first strong dip of its
   difference function rather than a multiple of the period.
3. *The pair*: the rhythm's energy (the variance of each drift-free component band-passed
   around the cycle's frequency, and around twice it) names the two components that carry
   it. A walk seen from the side, whose two half-cycles look alike, carries more at twice
   the frequency: its loop turns twice per cycle, as the paper's switching models expect.
4. *Half-cycles*: silhouettes that come back exactly after L frames may be a whole cycle (a
   gallop) or half of one (a walk whose near and far legs cannot be told apart): nothing in
   the images says which. When the repeat curve also dips at about L / 2, L is a whole
   cycle whose halves only look alike; when it does not, a walk's cycle is taken to be 2 L
   (the paper's reading: its loop turns twice per cycle).

All periods are in frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.analysis.spectrum import MIN_FRAMES, band_pass
from gaitcore.errors import GaitInputError
from gaitcore.silhouettes.tracking import moving_average

MIN_CYCLES = 2.0
"""Fewest repeats of the rhythm a clip must hold for it to be found. The paper asks for 1.5
cycles of PC1's spectral peak; a lag seen only 1.5 times is as often an animal that paces
and turns back, or walks out of the view and in again, as a gait."""

MAX_PERIOD_FRAMES = 256
"""Longest gait cycle looked for, frames (a slow walk filmed at 60 frames per second)."""

DIP_SHARE = 0.5
"""A dip of the repeat curve counts when its depth is at least this share of the deepest's..."""

MIN_DIP = 0.15
"""... and at least this deep (in units of the curve: about 1 for unrelated frames): the
wobble of a curve over frames that never come back stays under it."""

DRIFT_SHARE = 0.25
"""A trajectory keeps its slow trend unless that trend holds at least this share of its
variance: fitted over a whole number of cycles plus a part, a steady rhythm alone leaves a
small trend that is no drift."""

BAND_CYCLES = 0.5
"""Half-width of the band that measures a rhythm's energy, in cycles over the clip (the width
of a peak of a clip's spectrum, 1.2 / n, and half again)."""


@dataclass(frozen=True, eq=False)
class Rhythm:
    """Where a clip's gait lives in its principal components.

    Attributes
    ----------
    order : tuple of int
        Component indices (0-based, by decreasing variance), the rhythm's pair first, then
        the others by decreasing energy at the rhythm's frequency.
    lag_frames : float or None
        The lag after which the silhouettes come back; None when the repeat curve shows no
        dip.
    period_frames : float or None
        The pair's loop period: ``lag_frames``, or half of it when the pair carries more of
        the rhythm at twice its frequency.
    half_dip : bool
        The repeat curve also dips at about half ``lag_frames``: the silhouettes of the two
        half-cycles look alike without being the same.
    slow_lag_frames : float or None
        When no lag is found: the lag, longer than a clip this short can show
        :data:`MIN_CYCLES` times, at which the silhouettes (drift included) do come back;
        None when they never do (a drift, or no rhythm at all).
    detrended : ndarray of shape (n, c)
        The trajectories, drift removed, in their original order and scale.
    drift_share : ndarray of shape (c,)
        Share of each trajectory's variance in its slow trend (removed where it is at least
        :data:`DRIFT_SHARE`).
    """

    order: tuple[int, ...]
    lag_frames: float | None
    period_frames: float | None
    half_dip: bool
    detrended: np.ndarray
    drift_share: np.ndarray
    slow_lag_frames: float | None = None

    @property
    def loops_per_cycle(self) -> int:
        """How many times the pair's loop turns per gait cycle of a walk (1 or 2): once only
        when it turns once per lag and the lag is a whole cycle (``half_dip``)."""
        if self.lag_frames is None or self.period_frames is None:
            return 2
        once = self.period_frames > 0.75 * self.lag_frames
        return 1 if once and self.half_dip else 2


def longest_period(n: int) -> float:
    """The longest gait cycle a clip of ``n`` frames can show :data:`MIN_CYCLES` times."""
    return min(n / MIN_CYCLES, MAX_PERIOD_FRAMES)


def slow_trend(x: np.ndarray, window: float) -> np.ndarray:
    """The drift of each column: what is slower than ``window`` frames.

    Parameters
    ----------
    x : ndarray of shape (n,) or (n, c)
    window : float
        The longest period kept out of the trend, frames.

    Returns
    -------
    ndarray of the shape of ``x``
        A quadratic in time fitted by least squares when the clip holds under two windows
        (it cannot show a slower rhythm anyway); else a moving average over ``window``
        frames, continued linearly over its half-width at each end.
    """
    a = np.asarray(x, dtype=float)
    flat = a.ndim == 1
    a = a.reshape(a.shape[0], -1)
    width = max(2, int(round(window)))
    trend = np.column_stack([moving_average(a[:, k], width, fit_degree=2)
                             for k in range(a.shape[1])])
    return trend[:, 0] if flat else trend


def repeat_curve(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Mean squared distance between frames ``lag`` apart, for lags 1..max_lag.

    Parameters
    ----------
    x : ndarray of shape (n, c)
        Trajectories (e.g. drift-free projections, in image units).
    max_lag : int
        Longest lag, ``< n``.

    Returns
    -------
    ndarray of shape (max_lag,)
        Entry ``lag - 1``: the mean over ``t`` of ``|x[t + lag] - x[t]|^2``, over twice the
        total variance (about 1 for unrelated frames, 0 for frames that repeat exactly).
    """
    x = np.asarray(x, dtype=float)
    spread = 2.0 * float(x.var(axis=0).sum())
    if spread <= 0.0:
        return np.ones(max_lag)
    return np.array([np.mean(np.sum((x[lag:] - x[:-lag]) ** 2, axis=1)) / spread
                     for lag in range(1, max_lag + 1)])


def cycle_lag(curve: np.ndarray, *, first_lag: int = 1) -> float | None:
    """The gait cycle, in frames, from a repeat curve (:func:`repeat_curve`).

    A dip at lag L is a local minimum; its depth is how far it lies under the lower of the
    highest points of the curve before it and after it (up to 1.5 L, the next harmonic's
    territory). The first dip at least :data:`DIP_SHARE` as deep as the deepest one (and
    :data:`MIN_DIP` deep) is the cycle, refined by a parabola through its neighbours. None
    when the curve has no such dip at ``first_lag`` or beyond.
    """
    d = np.asarray(curve, dtype=float)
    m = d.size
    if m < 3:
        return None
    dips = []
    for i in range(max(1, first_lag - 1), m - 1):
        if d[i] <= d[i - 1] and d[i] <= d[i + 1]:
            lag = i + 1
            after = d[i : min(m, int(1.5 * lag) + 1)]
            depth = min(float(d[:i].max()), float(after.max())) - float(d[i])
            if depth > 0.0:
                dips.append((i, depth))
    deepest = max((depth for _, depth in dips), default=0.0)
    if deepest < MIN_DIP:
        return None
    i = next(i for i, depth in dips if depth >= max(DIP_SHARE * deepest, MIN_DIP))
    a, b, c = d[i - 1 : i + 2]
    curvature = a - 2.0 * b + c
    shift = 0.5 * (a - c) / curvature if curvature > 0.0 else 0.0
    return float(i + 1 + shift)


def find_rhythm(projections: np.ndarray) -> Rhythm:
    """Take the drift out of PCA trajectories and find the gait's cycle and pair.

    Parameters
    ----------
    projections : ndarray of shape (n, c)
        Projections in image units (not normalized: the components' variances weigh the
        repeat curve as the images' distances do), c >= 2, finite.

    Returns
    -------
    Rhythm

    Raises
    ------
    GaitInputError
        Fewer than two components, or values that are not finite. Under ``MIN_FRAMES``
        frames no lag is looked for.

    Notes
    -----
    Beyond the paper, which takes PC1 and PC2 (Section 5.1) and PC1's spectral peak (5.2).
    """
    p = np.asarray(projections, dtype=float)
    if p.ndim != 2 or p.shape[1] < 2 or not np.all(np.isfinite(p)):
        raise GaitInputError(f"the rhythm needs finite trajectories of at least 2 components, "
                             f"got shape {p.shape}")
    n = p.shape[0]
    if n < MIN_FRAMES:  # too short to time anything: as the paper would, by variance
        order = tuple(int(k) for k in np.argsort(-p.var(axis=0), kind="stable"))
        return Rhythm(order, None, None, False, p - p.mean(axis=0), np.zeros(p.shape[1]))
    window = longest_period(n)
    trend = slow_trend(p, window)
    total = p.var(axis=0)
    drift_share = np.clip(trend.var(axis=0) / np.where(total > 0, total, 1.0), 0.0, 1.0)
    drifting = drift_share >= DRIFT_SHARE
    detrended = p - np.where(drifting, trend, trend.mean(axis=0))
    max_lag = max(2, min(n - 2, int(window)))
    curve = repeat_curve(detrended, max_lag)
    cycle = cycle_lag(curve)
    if cycle is None:
        energy = detrended.var(axis=0)
        order = tuple(int(k) for k in np.argsort(-energy, kind="stable"))
        slow = cycle_lag(repeat_curve(p - p.mean(axis=0), n - 2), first_lag=max_lag + 1)
        return Rhythm(order, None, None, False, detrended, drift_share, slow)
    best = None
    for loops in (1, 2):
        freq = loops / cycle
        if freq > 0.5:
            continue
        energy = _band_energy(detrended, freq)
        share = energy / np.maximum(detrended.var(axis=0), 1e-300)
        strength = energy * share  # strong, and concentrated in the band
        top = np.argsort(-strength, kind="stable")
        score = float(strength[top[:2]].sum())
        if best is None or score > best[0]:
            best = (score, loops, top)
    assert best is not None  # loops=1 always fits: cycle >= 2 frames
    _, loops, top = best
    return Rhythm(tuple(int(k) for k in top), cycle, cycle / loops, _dips_at(curve, cycle / 2),
                  detrended, drift_share)


def _dips_at(curve: np.ndarray, lag: float) -> bool:
    """Whether the repeat curve has a local minimum within a fifth of ``lag`` (frames)."""
    d = np.asarray(curve, dtype=float)  # entry j is lag j + 1
    first, last = max(1, int(np.floor(0.8 * lag)) - 1), min(d.size - 2, int(np.ceil(1.2 * lag)) - 1)
    return any(d[j] <= d[j - 1] and d[j] <= d[j + 1] for j in range(first, last + 1))


def _band_energy(x: np.ndarray, freq: float) -> np.ndarray:
    """Variance of each column band-passed around ``freq`` (cycles per frame)."""
    n = x.shape[0]
    half = BAND_CYCLES / n
    band = (max(0.0, freq - half), min(0.5, freq + half))
    return band_pass(x, band, centre=freq).var(axis=0)
