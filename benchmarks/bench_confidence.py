"""Confidence benchmark (issue 11): does a frame's confidence point the artist at the frames
that need a stroke?

Each clip is segmented from one box on frame 0 (the reference's bounding box padded 4%, as in
the segmentation benchmark). Over the frames that are neither the key frame nor lost, the
confidence ``segmentation.json`` gives is ranked against the frame's IoU with the reference
(Spearman's correlation: 1 would rank them exactly, 0 not at all), and the least confident
frame's IoU is set beside the clip's worst and median; the frames the timeline marks to check
are counted beside those under 0.5 IoU. Clips: DAVIS bear, dog and goat, then
every clip in the folder ``GAIT_MORE_DAVIS`` names (see the segmentation benchmark).

Run ``python -m benchmarks confidence`` to print the table and record it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

from benchmarks import Section
from benchmarks.bench_segmentation import CLIPS, DATA, _davis_at, _r, more_clips
from gaitcore.bench.scripted_user import iou, padded_box
from gaitcore.silhouettes.roto import DOUBTFUL_BELOW, RotoSegmentation


def run() -> list[Section]:
    headers = ["clip", "frames ranked", "Spearman (confidence, IoU)", "least confident frame's IoU",
               "worst IoU", "median IoU", "frames to check", "of them under 0.5 IoU",
               "frames under 0.5 IoU"]
    title = "Confidence against the true IoU, from one box"
    roots = [DATA / f"davis-{name}" for name in CLIPS if (DATA / f"davis-{name}").is_dir()]
    roots += more_clips()
    if not roots:
        return [Section(title, headers, [], [f"skipped: real footage not found at {DATA}"])]
    rows = [row for root in roots if (row := _ranked(root)) is not None]
    if len(rows) > 1:
        columns = list(zip(*rows))
        rows.append(["mean of the clips (frames: all)", sum(columns[1]),
                     *(_r(np.mean(c)) for c in columns[2:6]), *(sum(c) for c in columns[6:])])
    return [Section(title, headers, rows, [
        "frames ranked: all but the key frame (confidence 1) and the lost frames (flagged "
        "apart, confidence 0); a clip with none is left out",
        "confidence: how far the mask stands out from its surroundings under the key frame's "
        "colours, as a share of how far the key's own mask did; before, the cut's overlap with "
        "the mask carried by the flow ranked the same 21 clips at 0.10 on average",
        f"frames to check: those ranked with a confidence under {DOUBTFUL_BELOW} (the "
        "timeline's faint red marks)",
        "clips: DAVIS bear, dog and goat, then those under GAIT_MORE_DAVIS when it is set"])]


def _ranked(root: Path) -> list | None:
    """The clip's row; None when every frame but the key was lost (nothing to rank)."""
    source, refs = _davis_at(root)
    seg = RotoSegmentation(source, box=padded_box(refs[0]))
    seg.run()
    states = [seg.state(t) for t in range(seg.n)]
    ranked = [t for t in range(1, seg.n) if not states[t].lost]
    if not ranked:
        return None
    ious = np.array([iou(seg.mask(t), refs[t]) for t in ranked])
    confidence = np.array([states[t].confidence for t in ranked])
    rho = (float(spearmanr(confidence, ious).statistic)
           if len(ranked) > 2 and np.ptp(ious) > 0 and np.ptp(confidence) > 0 else 0.0)
    name = root.name.removeprefix("davis-")
    check, bad = confidence < DOUBTFUL_BELOW, ious < 0.5
    return [name, len(ranked), _r(rho), _r(ious[np.argmin(confidence)]), _r(ious.min()),
            _r(np.median(ious)), int(check.sum()), int((check & bad).sum()), int(bad.sum())]
