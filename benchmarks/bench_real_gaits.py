"""Real gaits: ridden horses walking past a fixed camera (``../shared/data/horse-walks/``).

Each clip is segmented from one box and analysed as ``gaitcore analyze --switching`` does;
its stride comes from the keypoints, and the animation of its keypoints from 4 (then 6) posed
key-images is measured against them (:mod:`gaitcore.bench.real_gaits` has the protocol).
"""

from __future__ import annotations

import tempfile
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from benchmarks import Section
from gaitcore.analysis.analyze import Analysis, AnalysisSettings
from gaitcore.bench.real_gaits import (
    Keypoints,
    ineligible_keys,
    oracle,
    per_stride,
    pose_errors,
    rig_body_length,
    withers_stride,
)
from gaitcore.project.document import Silhouettes
from gaitcore.project.footage_fit import fit_rig, travel_direction, travel_metres
from gaitcore.project.steps import analyze
from gaitcore.rig.proportions import proportioned
from gaitcore.rig.silhouette_fit import fit_proportions
from gaitcore.rig.templates import load_template
from gaitcore.silhouettes.annotations import Rect
from gaitcore.silhouettes.extract import load_silhouettes

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "horse-walks"
KEYS = (4, 6)
PERIOD_TOLERANCE = 0.1
NEAREST_SHARE, MEAN_SHARE, ORACLE_SHARE = 1.0, 0.8, 1.2


def clips() -> list[Path]:
    """The clip folders (holding ``source.avi`` and ``joints.csv``)."""
    if not DATA.is_dir():
        return []
    return sorted(p for p in DATA.iterdir() if (p / "source.avi").is_file()
                  and (p / "joints.csv").is_file())


def segment(clip: Path, out: Path) -> Silhouettes:
    """The clip's silhouettes from the keypoints' padded box on its first frame."""
    kp = Keypoints.read(clip / "joints.csv")
    cap = cv2.VideoCapture(str(clip / "source.avi"))
    size = (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)))
    cap.release()
    roi = load_silhouettes(clip / "source.avi", out, box=Rect(*kp.box(size)))
    return Silhouettes(roi, "segmented")


def period_ok(analysis: Analysis, stride: float) -> bool:
    """The analysis' period within ``PERIOD_TOLERANCE`` of the stride or of half of it."""
    period = analysis.diagnosis.period_frames
    return any(abs(period - target) <= PERIOD_TOLERANCE * target for target in
               (stride, stride / 2))


def run() -> list[Section]:
    title = "Horse walks from one box: period, verdict and keypoint error of the animation"
    headers = ["clip", "keys", "analysed frames", "stride (keypoints)", "period (analyze)",
               "pair", "verdict", "animation %", "nearest key %", "mean pose %", "oracle %",
               "meets the line"]
    found = clips()
    if not found:
        return [Section(title, headers, [], [f"skipped: the horse walks are not at {DATA}"])]
    rows, notes, fits, travels, strokes = [], [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for clip in found:
            kp = Keypoints.read(clip / "joints.csv")
            stride = kp.stride_frames()
            silhouettes = segment(clip, Path(tmp) / clip.name)
            strokes.append(rider_stroke(clip, kp))
            base = AnalysisSettings(switching=True, forbidden=ineligible_keys(kp))
            for m in KEYS:
                settings = replace(base, keys=m)
                analysis = analyze(silhouettes, settings)
                if m == KEYS[0]:
                    clip_fits, travel = rig_fits(clip.name, kp, silhouettes, analysis)
                    fits += clip_fits
                    travels.append(travel)
                err = pose_errors(analysis, kp)
                best = oracle(kp, settings, analysis.frame_range)
                ref = pose_errors(best, kp).animation
                usable = analysis.diagnosis.verdict.value == "usable"
                bar = (MEAN_SHARE * err.mean_pose if ref <= MEAN_SHARE * err.mean_pose
                       else ORACLE_SHARE * ref)  # the oracle's own, where it misses the mean's
                beats = err.animation <= min(NEAREST_SHARE * err.nearest_key, bar)
                ok = usable and period_ok(analysis, stride) and beats
                start, stop = analysis.frame_range
                rows.append([clip.name, m, f"{start}-{stop - 1}", f"{stride:.1f}",
                             f"{analysis.diagnosis.period_frames:.1f}", analysis.pair_name,
                             analysis.diagnosis.verdict.value, f"{err.animation:.1f}",
                             f"{err.nearest_key:.1f}", f"{err.mean_pose:.1f}", f"{ref:.1f}",
                             "yes" if ok else "no"])
                if m == KEYS[0] and analysis.advice is not None:
                    said = " ".join((analysis.advice.message, *analysis.advice.notes))
                    notes.append(f"{clip.name}: {said}")
    notes += [
        "line (issue 61): usable; period within 10% of the stride or of half of it; animation "
        "error at most the nearest key's and at most 0.8 x the mean pose's (or, where even the "
        "oracle misses that, within 1.2 x the oracle)",
        "box: the keypoints' box on frame 0 (likelihood > 0.6) padded a tenth on the sides and "
        "below and 0.8 of its height above (the rider); `analyze --switching`, keys chosen "
        "among frames whose 16 keypoints all have likelihood > 0.6, alternates posed too",
        "error: mean distance of the keypoints of likelihood > 0.9 on the frames not posed, "
        "in % of the clip's median keypoint height; the keypoints are a trained network's "
        "predictions, not hand labels",
        "oracle: the same protocol with the PCA taken on the true keypoints",
    ]
    return [Section(title, headers, rows, notes),
            Section("Fit rig on each key (4 keys) of the horse walks, rest pose",
                    ["clip", "key", "overlap", "rig length / silhouette's", "middle off",
                     "feet off the bottom", "rig height / silhouette's", "legs / withers",
                     "same twice", "verdict"], fits,
                    ["line (issue 62): length and place within 15% of the silhouette's box, "
                     "legs 0.4 to 0.7 of the withers' height, the same twice, a poor fit "
                     "reported; the height is not compared (the rider is in the silhouette)",
                     "legs: the free length, from the underside of the trunk to the ground"]),
            Section("Root travel from the footage against the withers' keypoint",
                    ["clip", "fitted on key", "root per stride (rig body lengths)",
                     "withers per stride (body lengths)", "ratio", "within 15%"], travels,
                    ["the root follows the silhouette's track at the scale of the first "
                     "key whose fit is not refused (`gaitcore.project.footage_fit."
                     "travel_metres`); body lengths: the rig's shoulder blade to hip joint, "
                     "the keypoints' withers to hip over each stride"]),
            Section("A background stroke on the rider: what it takes away, what comes in",
                    ["clip", "stroke on frame", "frames re-propagated", "rider taken away",
                     "most area gained by a frame", "within 2%"], strokes,
                    ["the clip segmented from the box, then one background stroke down the "
                     "rider's back (from the keypoints: 0.45 of the way from withers to "
                     "hip, from 0.8 to 0.15 body lengths above the withers); gained: pixels "
                     "of a frame's silhouette after that were not in it before, outside the "
                     "stroke, in % of its area before; rider: the silhouette above the "
                     "withers' height, share of it gone, over the frames re-propagated",
                     "line (issue 62): no frame gains more than 2% of its area"])]


STROKE_FRAME = 20


def rider_stroke(clip: Path, kp: Keypoints) -> list:
    """Segment the clip from the box, stroke the rider as background on
    :data:`STROKE_FRAME` and measure (module notes)."""
    from gaitcore.footage.sources import open_frames
    from gaitcore.silhouettes.annotations import Scribble
    from gaitcore.silhouettes.roto import RotoSegmentation

    f = STROKE_FRAME
    withers, hip = kp.xy[f, kp.index("Withers")], kp.xy[f, kp.index("Hip")]
    body = float(np.linalg.norm(withers - hip))
    x = withers[0] + 0.45 * (hip[0] - withers[0])
    line = [[x, withers[1] - 0.8 * body], [x, withers[1] - 0.15 * body]]
    stroke = Scribble(line, 0.08 * body, f, "background")
    with open_frames(clip / "source.avi") as frames:
        size = frames.size
        seg = RotoSegmentation(frames, box=Rect(*kp.box(size)))
        seg.run()
        before = [seg.mask(t) for t in range(seg.n)]
        first, stop = seg.correct([stroke])
        after = [seg.mask(t) for t in range(seg.n)]
    own = np.zeros(before[f].shape, np.uint8)
    cv2.polylines(own, [np.round(line).astype(np.int32)], False, 1, int(np.ceil(0.08 * body)))
    gained, rider_before, rider_after = [], 0, 0
    for t in range(seg.n):
        new = after[t] & ~before[t]
        if t == f:
            new &= own == 0
        gained.append(100.0 * new.sum() / max(before[t].sum(), 1))
        if first <= t < stop and np.isfinite(kp.xy[t, kp.index("Withers"), 1]):
            top = int(kp.xy[t, kp.index("Withers"), 1] - 0.1 * body)
            rider_before += int(before[t][:max(top, 0)].sum())
            rider_after += int(after[t][:max(top, 0)].sum())
    taken = 1.0 - rider_after / rider_before if rider_before else float("nan")
    worst = max(gained)
    return [clip.name, f, f"{first}-{stop - 1}", f"{100 * taken:.0f}%", f"{worst:.2f}%",
            "yes" if worst <= 2.0 else "no"]


def rig_fits(name: str, kp: Keypoints, silhouettes: Silhouettes, analysis: Analysis
             ) -> tuple[list[list], list]:
    """Fit rig on each key (twice), and the root's stride at the first accepted fit."""
    horse = load_template("horse")
    flip = travel_direction(silhouettes) < 0
    rows, accepted = [], None
    for key in analysis.key_frames:
        crop = silhouettes.roi.crops[key]
        first, again = (fit_proportions(crop[:, ::-1] if flip else crop, horse,
                                        horse.rest_pose()) for _ in range(2))
        (rx, ry, rw, rh), (sx, sy, sw, sh) = first.rig_box, first.silhouette_box
        problems = first.problems()
        if not problems and accepted is None:
            accepted = key
        across = abs(rx + rw / 2 - sx - sw / 2) / sw
        rows.append([name, key, f"{first.overlap:.2f}", f"{rw / sw:.2f}",
                     f"{100 * across:.0f}%", f"{100 * abs(ry + rh - sy - sh) / sh:.0f}%",
                     f"{rh / sh:.2f}",
                     f"{first.leg_length_m / first.withers_height_m:.2f}",
                     "yes" if first == again else "no", "; ".join(problems) or "accepted"])
    if accepted is None:
        return rows, [name, "none accepted", "", "", "", "no"]
    fit = fit_rig(horse, horse.rest_pose(), silhouettes, accepted, flip=flip)
    rig = proportioned(horse, fit.proportions)
    travel = travel_metres(analysis.travel, rig, fit.footage_fit)
    if travel is None:
        return rows, [name, accepted, "no travel", "", "", "no"]
    ours = per_stride(travel, np.full(len(travel), rig_body_length(rig)), kp.stride_frames())
    theirs = withers_stride(kp, analysis.frame_range)
    ratio = ours / theirs
    return rows, [name, accepted, f"{ours:.2f}", f"{theirs:.2f}", f"{ratio:.2f}",
                  "yes" if abs(ratio - 1) <= 0.15 else "no"]
