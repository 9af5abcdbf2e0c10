"""The stretches of a clip that hold a steady cyclic gait: where to trim before analysing.

A long clip rarely shows a steady gait from start to end: the animal stands, walks side-on for
a few strides, then turns away. :func:`find_cycles` finds the stretches worth analysing in
three steps:

1. *Windows*: the paper's spectral diagnosis (Section 5.2) is run on sliding windows of a few
   lengths (each window gets its own PCA). A window counts when it is usable (r1, r2 >= 0.6,
   a significant rhythm) and holds at least two of its periods. Crops centred on each
   frame's centre of mass jitter with the legs, which can hide PC2's rhythm: when windows
   show a significant rhythm where none is usable, the scan is run again on crops re-centred
   on the track averaged over that period
   (:func:`gaitcore.silhouettes.tracking.stabilize_rois`), and the scan that finds more
   steady gait is kept.
2. *Groups*: overlapping counted windows whose periods agree within ``period_tolerance`` make
   one candidate stretch, with the median of their periods.
3. *Ends*: a window is blunt at the ends of a stretch (a window holding some standing frames
   can still be usable), so each end is set frame by frame. A frame belongs to the gait when
   its silhouette repeats one period later or earlier (the silhouettes of a cycle come back)
   *and* it moves (it differs from the frames a quarter period away, which rules out an animal
   standing still, whose silhouettes repeat too; a frame within a quarter period of the
   clip's end, which lacks one of those, is compared with the frame of the same phase one
   period on instead). Distances are in the stretch's own units: its silhouettes' spread
   about their mean.

The period reported is the gait cycle, the lag at which the silhouettes come back: PC1 may
oscillate at half the gait cycle (the diagnosis' period), for a walk or a trot seen from the
side whose two half-cycles look alike, or for a body that bobs twice per stride; when the
silhouettes come back much better after two of those periods than after one, the period is
doubled (and the frame-by-frame test above uses the doubled one).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from gaitcore.analysis.image_pca import ImagePCA
from gaitcore.analysis.spectrum import MIN_FRAMES, diagnose
from gaitcore.analysis.verdict import PERIODICITY_ALPHA, Verdict
from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report
from gaitcore.runs import true_runs
from gaitcore.silhouettes.tracking import RoiClip, stabilize_rois


@dataclass(frozen=True)
class Cycle:
    """One stretch of steady cyclic gait.

    Attributes
    ----------
    start, stop : int
        Frames ``start <= f < stop`` of the clip given to :func:`find_cycles`.
    period_frames : float
        Gait cycle, frames: the silhouettes come back after this many frames.
    r1, r2 : float
        The paper's correlations of PC1 and PC2 with their band-passed versions, for a PCA
        and a diagnosis of this stretch alone.
    """

    start: int
    stop: int
    period_frames: float
    r1: float
    r2: float

    @property
    def usable(self) -> bool:
        """The stretch alone passes the paper's test (r1 and r2 at least 0.6)."""
        return min(self.r1, self.r2) >= 0.6

    @property
    def n_cycles(self) -> float:
        return (self.stop - self.start) / self.period_frames

    def to_dict(self, first_frame: int = 0) -> dict:
        """``{start, stop, period_frames, r1, r2}`` with frames offset by ``first_frame``."""
        return {"start": self.start + first_frame, "stop": self.stop + first_frame,
                "period_frames": round(self.period_frames, 3), "r1": round(self.r1, 4),
                "r2": round(self.r2, 4)}


@dataclass(frozen=True)
class CycleSettings:
    """How :func:`find_cycles` looks.

    Attributes
    ----------
    windows : tuple of int
        Lengths of the sliding windows, frames; a window sees periods up to half its length.
    period_tolerance : float
        Relative difference of period under which overlapping windows join one stretch.
    feature_side_px : int
        Silhouettes are compared shrunk to this longer side (area averaging).
    repeat_tolerance : float
        A frame repeats when its distance to the frame one period away is within this share
        of the way from the stretch's typical repeat distance to its spread (0: as well as
        the stretch's middle, 1: no better than any frame).
    motion_share : float
        A frame moves when its distance to the frames a quarter period away is at least this
        share of the stretch's typical one.
    """

    windows: tuple[int, ...] = (48, 96, 192, 384)
    period_tolerance: float = 0.2
    feature_side_px: int = 48
    repeat_tolerance: float = 0.25
    motion_share: float = 0.5


def find_cycles(
    roi: RoiClip,
    *,
    settings: CycleSettings = CycleSettings(),
    progress: Progress | None = None,
) -> tuple[Cycle, ...]:
    """Stretches of steady cyclic gait, best first.

    Parameters
    ----------
    roi : RoiClip
        Silhouette crops of the whole clip, one per frame; frames where the subject is lost
        never belong to a stretch.
    settings : CycleSettings
    progress : callable(done, total) -> bool, optional
        Reported window by window; returning False cancels with ``Cancelled``.

    Returns
    -------
    tuple of Cycle
        Disjoint stretches ranked usable first, then by length in cycles times min(r1, r2).
        Empty when no window of the clip shows a usable rhythm.

    Raises
    ------
    GaitInputError
        When the crops are not a stack of 2-D images.

    Notes
    -----
    Paper Section 5.2, applied to sliding windows.
    """
    f = _features(roi.crops, roi.lost, settings.feature_side_px)
    half = None if progress is None else (lambda d, t: progress(d, 2 * t))
    windows, rhythmic = _scan(f, settings, half)
    if _coverage(rhythmic) > _coverage(windows):  # some rhythm is not usable: re-centre
        steady = stabilize_rois(roi, float(np.median([w[2] for w in rhythmic])))
        f2 = _features(steady.crops, roi.lost, settings.feature_side_px)
        rest = None if progress is None else (lambda d, t: progress(t + d, 2 * t))
        windows2, _ = _scan(f2, settings, rest)
        if _coverage(windows2) > _coverage(windows):
            f, windows = f2, windows2
    if progress is not None:
        progress(1, 1)  # the second scan may have been skipped
    groups = _group(windows, settings.period_tolerance)
    cycles = []
    taken = np.zeros(len(f), dtype=bool)
    for a, b, period in groups:
        runs, cycle_frames = _refine(f, a, b, period, settings)
        for lo, hi in runs:
            if hi - lo < max(MIN_FRAMES, 1.5 * cycle_frames) or taken[lo:hi].any():
                continue
            cycle = _describe(f, lo, hi, cycle_frames)
            if cycle is not None:
                taken[lo:hi] = True
                cycles.append(cycle)
    return tuple(sorted(cycles, key=lambda c: (not c.usable, -c.n_cycles * min(c.r1, c.r2))))


def repeat_distance(roi: RoiClip, period_frames: float, *,
                    settings: CycleSettings = CycleSettings()) -> float:
    """How well the silhouettes come back after ``period_frames``: the median, over frames,
    of the distance to the frame one period (or two) away, in units of the silhouettes'
    spread about their mean (0: exactly; about 1: no better than any two frames).

    Raises
    ------
    GaitInputError
        When the crops are not a stack of 2-D images.
    """
    f = _features(roi.crops, roi.lost, settings.feature_side_px)
    f = f[~np.isnan(f).any(axis=1)]
    spread = 2.0 * float(np.mean(np.sum((f - f.mean(axis=0)) ** 2, axis=1))) if len(f) else 0.0
    if spread <= 0.0:
        return 0.0
    both = np.minimum(_repeat_distance(f, period_frames, spread),
                      _repeat_distance(f, 2 * period_frames, spread))
    finite = both[np.isfinite(both)]
    return float(np.median(finite)) if finite.size else 1.0


def _coverage(windows: list[tuple[int, int, float]]) -> int:
    """Frames covered by at least one window."""
    covered: set[int] = set()
    for a, b, _ in windows:
        covered.update(range(a, b))
    return len(covered)


def _features(images: np.ndarray, lost: np.ndarray, side: int) -> np.ndarray:
    """Images shrunk to ``side`` pixels on their longer side, flattened: (n, d) float32, NaN
    for lost frames."""
    imgs = np.asarray(images)
    if imgs.ndim != 3 or 0 in imgs.shape:
        raise GaitInputError(f"silhouettes must be a stack of images (n, rows, cols), "
                             f"got {imgs.shape}")
    n, rows, cols = imgs.shape
    scale = min(1.0, side / max(rows, cols))
    size = (max(1, round(cols * scale)), max(1, round(rows * scale)))
    out = np.empty((n, size[0] * size[1]), np.float32)
    unit = 1.0 if imgs.dtype == bool else 1.0 / 255.0
    for i, img in enumerate(imgs):
        small = cv2.resize(img.astype(np.float32) * unit, size, interpolation=cv2.INTER_AREA)
        out[i] = small.ravel()
    out[np.asarray(lost, dtype=bool)] = np.nan
    return out


def _window_diagnosis(f: np.ndarray, a: int, b: int, progress: Progress | None = None):
    """The paper's diagnosis of frames a..b-1 with their own PCA; None when it cannot run.
    ``progress`` is passed to the PCA, so that a cancel stops it mid-way."""
    block = f[a:b]
    if np.isnan(block).any():
        return None
    try:
        pca = ImagePCA.fit(block.reshape(b - a, 1, -1), n_components=5, progress=progress)
        if pca.n_components < 2:
            return None
        return diagnose(pca.projections)
    except GaitInputError:
        return None


def _scan(f: np.ndarray, settings: CycleSettings,
          progress: Progress | None) -> tuple[list[tuple[int, int, float]],
                                              list[tuple[int, int, float]]]:
    """Usable windows (start, stop, period), and every window (start, stop, period) that
    holds a significant rhythm at least twice, usable or not."""
    n = len(f)
    plan = []
    for width in settings.windows:
        if width > n:
            break
        starts = list(range(0, n - width + 1, max(4, width // 4)))
        plan += [(a, a + width) for a in starts + ([n - width] if starts[-1] != n - width else [])]
    if not plan and n >= 2 * MIN_FRAMES:
        plan = [(0, n)]  # a clip shorter than every window: one window over it all
    found, rhythmic = [], []
    for k, (a, b) in enumerate(plan):
        report(progress, k, len(plan), "cycle search cancelled")
        again = None if progress is None else (lambda _d, _t, k=k: progress(k, len(plan)))
        d = _window_diagnosis(f, a, b, again)
        if d is None or b - a < 2 * d.period_frames or d.periodicity_p > PERIODICITY_ALPHA:
            continue
        rhythmic.append((a, b, d.period_frames))
        if d.verdict is Verdict.USABLE:
            found.append((a, b, d.period_frames))
    if progress is not None:
        progress(len(plan), len(plan))
    return found, rhythmic


def _group(windows: list[tuple[int, int, float]], tolerance: float) -> list[tuple[int, int, float]]:
    """Overlapping windows with periods within ``tolerance`` -> (start, stop, median period)."""
    groups: list[list] = []
    for a, b, p in sorted(windows):
        for g in groups:
            if a < g[1] and b > g[0] and abs(p - g[2]) <= tolerance * g[2]:
                g[0], g[1] = min(g[0], a), max(g[1], b)
                g[3].append(p)
                g[2] = float(np.median(g[3]))
                break
        else:
            groups.append([a, b, p, [p]])
    return [(g[0], g[1], g[2]) for g in sorted(groups, key=lambda g: g[0] - g[1])]


def _lag_distance(f: np.ndarray, lag: int) -> np.ndarray:
    """Squared distance between frame t and frame t + lag, shape (n - lag,)."""
    d = f[lag:] - f[:-lag]
    return np.einsum("ij,ij->i", d, d)


def _refine(f: np.ndarray, a: int, b: int, period: float,
            settings: CycleSettings) -> tuple[list[tuple[int, int]], float]:
    """The stretches, with ends set frame by frame, that overlap windows a..b; and the gait
    cycle (``period`` or twice it, see the module notes)."""
    n = len(f)
    core = slice(a + (b - a) // 4, b - (b - a) // 4)
    spread = 2.0 * float(np.nanmean(np.sum((f[core] - np.nanmean(f[core], axis=0)) ** 2, axis=1)))
    cycle, repeat = period, _repeat_distance(f, period, spread)
    if 2 * period + 2 < b - a:
        twice = _repeat_distance(f, 2 * period, spread)
        if np.median(twice[core]) < 0.5 * np.median(repeat[core]):  # half-cycles look alike
            cycle, repeat = 2 * period, twice
    quarter = max(1, int(round(period / 4)))  # of the fastest rhythm: sharp ends
    motion = np.zeros(n)
    if quarter < n:
        d = np.nan_to_num(_lag_distance(f, quarter) / spread, nan=0.0)
        motion[:-quarter] = np.maximum(motion[:-quarter], d)
        motion[quarter:] = np.maximum(motion[quarter:], d)
        far = int(round(period)) - quarter  # a quarter period the other way, one period on
        if quarter < far <= n - quarter:  # stands in for the neighbour an end frame lacks
            e = np.nan_to_num(_lag_distance(f, far) / spread, nan=0.0)
            motion[:quarter] = np.maximum(motion[:quarter], e[:quarter])
            motion[-quarter:] = np.maximum(motion[-quarter:], e[-quarter:])
    floor = float(np.median(repeat[core]))
    typical = float(np.median(motion[core]))
    ok = (repeat <= floor + settings.repeat_tolerance * (1.0 - floor)) & (
        motion >= floor + settings.motion_share * (typical - floor))
    _close_gaps(ok, quarter)
    runs = [(lo, hi) for lo, hi in true_runs(ok) if lo < b and hi > a]
    return runs, cycle


def _repeat_distance(f: np.ndarray, period: float, spread: float) -> np.ndarray:
    """Per frame, the least distance (over ``spread``) to the frames one period before or
    after it, the period rounded either way; +inf where neither exists."""
    n, lag = len(f), int(round(period))
    repeat = np.full(n, np.inf)
    for k in (lag - 1, lag, lag + 1):
        if 0 < k < n:
            d = np.nan_to_num(_lag_distance(f, k) / spread, nan=np.inf)
            repeat[:-k] = np.minimum(repeat[:-k], d)
            repeat[k:] = np.minimum(repeat[k:], d)
    return repeat


def _close_gaps(ok: np.ndarray, shortest: int) -> None:
    """Accept, in place, runs of rejected frames shorter than ``shortest`` between accepted
    ones (a few bad silhouettes do not cut a stretch)."""
    for s0, s1 in true_runs(~ok):
        if s1 - s0 < shortest and s0 > 0 and s1 < len(ok):
            ok[s0:s1] = True


def _describe(f: np.ndarray, lo: int, hi: int, cycle: float) -> Cycle | None:
    """The diagnosis of frames lo..hi-1 alone; the cycle is its period, or twice it when the
    stretch's silhouettes come back only after two (``cycle`` says which)."""
    d = _window_diagnosis(f, lo, hi)
    if d is None:
        return None
    period = d.period_frames
    if abs(cycle - 2 * period) < abs(cycle - period):
        period *= 2.0
    return Cycle(lo, hi, float(period), float(d.correlations[0]), float(d.correlations[1]))
