"""Advice that names what stands in the way of a usable analysis, and the one next step.

The paper's diagnosis (Section 5.2) says whether a clip is usable; when it is not, the artist
needs to know why, because each cause has another remedy:

- *silhouettes unstable*: the area or the outline jumps from frame to frame, or the lower
  part (the legs, which carry the gait) is missing: correct or sketch the silhouettes;
- *not side-on*: the subject's box changes shape (it turns, walks towards the camera): trim
  to the stretch where it crosses the view side-on;
- *too few cycles*: the silhouettes come back, but only after a lag longer than the clip can
  show 1.5 times (:attr:`gaitcore.analysis.rhythm.Rhythm.slow_lag_frames`): a longer clip;
- *no rhythm*: stable, side-on silhouettes that do not cycle: another clip.

The causes are tested in that order, because each one also spoils the tests after it
(legless silhouettes show no rhythm); the first two are reported even on a usable clip.
Every figure is computed on the silhouette crops alone.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import Enum

import numpy as np

from gaitcore.analysis.cycles import Cycle
from gaitcore.analysis.spectrum import Diagnosis
from gaitcore.analysis.verdict import Verdict
from gaitcore.silhouettes.tracking import RoiClip

AREA_JUMP = 0.25
"""A frame's area jumps when it differs from the previous frame's by more than this share."""
OUTLINE_JUMP_IOU = 0.6
"""A frame's outline jumps when it overlaps the previous frame's by less than this (IoU)."""
UNSTABLE_SHARE = 0.05
"""Silhouettes are unstable when more than this share of frames jump."""
LOWER_PART_WIDTH = 0.6
"""Legs are missing when the lowest 30 % of the subject's box is, on the median frame, at least
this wide relative to its widest row: a trunk without legs (measured: 0.8 for a horse cut at
the belly, 0.13 to 0.4 for whole animals, real and synthetic)."""
BOX_SPREAD = 1.5
"""Not side-on when the box's width/height ratio varies by more than this factor (90th over
10th percentile; 1.07 to 1.2 for side-on gaits, 3 and more for an animal that turns)."""


class Cause(str, Enum):
    """What stands in the way (NONE: nothing, the clip is usable)."""

    NONE = "none"
    UNSTABLE = "silhouettes unstable"
    NOT_SIDE_ON = "not side-on"
    TOO_FEW_CYCLES = "too few cycles"
    NO_RHYTHM = "no rhythm"


@dataclass(frozen=True)
class SilhouetteCues:
    """Figures of the silhouettes behind the advice.

    Attributes
    ----------
    area_jumps, outline_jumps : float
        Share of frames whose area, or outline, jumps from the previous frame's.
    lower_width : float
        Median over frames of the mean width of the lowest 30 % of the subject's box over
        its widest row (small when legs are there).
    box_spread : float
        90th over 10th percentile of the box's width/height ratio.
    """

    area_jumps: float
    outline_jumps: float
    lower_width: float
    box_spread: float


@dataclass(frozen=True)
class Advice:
    """The cause, in a sentence, and the one next step.

    Attributes
    ----------
    cause : Cause
    message : str
        What the figures say, for an artist.
    next_step : str
        What to do now ("" when nothing needs doing).
    suggested_range : (int, int) or None
        Source frames ``start, stop`` to trim to, when that is the next step.
    cues : SilhouetteCues
    notes : tuple of str
        What the analysis saw and did about it whatever the cause (the animal's size
        evened out, frames left out), one sentence each.
    """

    cause: Cause
    message: str
    next_step: str
    suggested_range: tuple[int, int] | None
    cues: SilhouetteCues
    notes: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        return {"cause": self.cause.value, "message": self.message, "next_step": self.next_step,
                "suggested_range": None if self.suggested_range is None
                else list(self.suggested_range), "notes": list(self.notes)}


def silhouette_cues(crops: np.ndarray, lost: np.ndarray | None = None) -> SilhouetteCues:
    """Measure the silhouettes of a clip (see :class:`SilhouetteCues`).

    Parameters
    ----------
    crops : ndarray of shape (n, rows, cols), bool
    lost : ndarray of shape (n,), bool, optional
        Frames left out of every figure.
    """
    c = np.asarray(crops, dtype=bool)
    if lost is not None:
        c = c[~np.asarray(lost, dtype=bool)]
    n = len(c)
    if n < 2:
        return SilhouetteCues(0.0, 0.0, 0.0, 1.0)
    area = c.reshape(n, -1).sum(axis=1).astype(float)
    ratio = np.maximum(area[1:], 1) / np.maximum(area[:-1], 1)
    area_jumps = float(np.mean(np.abs(np.log(ratio)) > np.log1p(AREA_JUMP)))
    inter = (c[1:] & c[:-1]).reshape(n - 1, -1).sum(axis=1)
    union = np.maximum((c[1:] | c[:-1]).reshape(n - 1, -1).sum(axis=1), 1)
    outline_jumps = float(np.mean(inter / union < OUTLINE_JUMP_IOU))
    lower, aspect = [], []
    for img in c:
        rows = np.flatnonzero(img.any(axis=1))
        cols = np.flatnonzero(img.any(axis=0))
        if rows.size < 4:
            continue
        width = img[rows[0]:rows[-1] + 1].sum(axis=1)
        k = max(1, round(0.3 * width.size))
        lower.append(width[-k:].mean() / width.max())
        aspect.append((cols[-1] - cols[0] + 1) / (rows[-1] - rows[0] + 1))
    if not aspect:
        return SilhouetteCues(area_jumps, outline_jumps, 0.0, 1.0)
    spread = float(np.percentile(aspect, 90) / np.percentile(aspect, 10))
    return SilhouetteCues(area_jumps, outline_jumps, float(np.median(lower)), spread)


def advise(roi: RoiClip, diagnosis: Diagnosis, cycles: tuple[Cycle, ...], *,
           first_frame: int = 0, sketched: bool = False, slow_lag: float | None = None,
           notes: tuple[str, ...] = ()) -> Advice:
    """Name the cause that stands in the way of a usable analysis, and the next step (see
    :func:`advise_cause`); ``notes`` (what the framing did) are kept beside it."""
    return replace(advise_cause(roi, diagnosis, cycles, first_frame=first_frame,
                                sketched=sketched, slow_lag=slow_lag), notes=tuple(notes))


def advise_cause(roi: RoiClip, diagnosis: Diagnosis, cycles: tuple[Cycle, ...], *,
                 first_frame: int = 0, sketched: bool = False,
                 slow_lag: float | None = None) -> Advice:
    """Name the cause that stands in the way of a usable analysis, and the next step.

    Parameters
    ----------
    roi : RoiClip
        The silhouettes analysed.
    diagnosis : Diagnosis
        Their spectral diagnosis.
    cycles : tuple of Cycle
        Stretches of steady gait (:func:`gaitcore.analysis.cycles.find_cycles`), in frames
        counted from ``first_frame``.
    first_frame : int
        Source frame of the cycles' frame 0.
    sketched : bool
        The silhouettes are sketches already (no point advising to sketch them).
    slow_lag : float, optional
        The lag after which the silhouettes come back when it is too long for the clip
        (:attr:`gaitcore.analysis.rhythm.Rhythm.slow_lag_frames`).

    Returns
    -------
    Advice
    """
    cues = silhouette_cues(roi.crops, roi.lost)
    n = roi.crops.shape[0]
    best = next((c for c in cycles if c.usable), None)
    stretch = None if best is None else (best.start + first_frame, best.stop + first_frame)
    usable = diagnosis.verdict is Verdict.USABLE
    unstable = _instability(cues)
    if unstable and not sketched:
        return Advice(Cause.UNSTABLE, ("Usable, but the s" if usable else "S")
                      + f"ilhouettes are unstable: {unstable}.",
                      "Correct the silhouettes (strokes on the frames that jump, the legs where "
                      "they are missing) or sketch them, then analyse again.", None, cues)
    if usable and cues.box_spread <= BOX_SPREAD:
        if best is not None and best.stop - best.start < 0.75 * n:
            return Advice(Cause.NONE, "Usable.", f"The steadiest stretch is frames {stretch[0]} "
                          f"to {stretch[1] - 1}; trim to it for a cleaner cycle.", stretch, cues)
        return Advice(Cause.NONE, "Usable.", "", None, cues)
    if cues.box_spread > BOX_SPREAD:
        message = (f"Not side-on: the subject's box changes shape (its width/height ratio varies "
                   f"{cues.box_spread:.1f}-fold), so the animal turns or moves towards the camera.")
        if stretch is not None:
            return Advice(Cause.NOT_SIDE_ON, message, f"Trim to frames {stretch[0]} to "
                          f"{stretch[1] - 1}, where it stays side-on.", stretch, cues)
        return Advice(Cause.NOT_SIDE_ON, message, "Choose a clip where the animal crosses the "
                      "view side-on.", None, cues)
    if slow_lag is not None:
        return Advice(Cause.TOO_FEW_CYCLES, f"Too few cycles: the silhouettes come back after "
                      f"about {slow_lag:.0f} frames, {n / slow_lag:.1f} times in {n} frames.",
                      f"Use a longer clip of the same gait: at least "
                      f"{int(np.ceil(2 * slow_lag))} frames.", None, cues)
    return Advice(Cause.NO_RHYTHM, "No rhythm: stable, side-on silhouettes that do not follow "
                  "one gait cycle.", "Choose a clip of a steady gait (walk, trot, gallop) seen "
                  "from the side.", stretch, cues)


def _instability(cues: SilhouetteCues) -> str:
    """What makes the silhouettes unstable, in words ("" when they are stable)."""
    parts = []
    if cues.area_jumps > UNSTABLE_SHARE:
        parts.append(f"the area jumps in {100 * cues.area_jumps:.0f} % of frames")
    if cues.outline_jumps > UNSTABLE_SHARE:
        parts.append(f"the outline jumps in {100 * cues.outline_jumps:.0f} % of frames")
    if cues.lower_width > LOWER_PART_WIDTH:
        parts.append("the lower part (the legs) is missing")
    return "; ".join(parts)
