"""Segmentation benchmark (paper Section 2.2 and beyond): quality, corrections, speed, memory.

- DAVIS bear, dog and goat: mean IoU against the reference masks from one box on frame 0
  (the reference's bounding box padded 4%), and after one scripted stroke per 10 frames
  (:mod:`gaitcore.bench.scripted_user`); the same in the lower third of the reference box
  (the legs); the time of one re-propagation.
- DAVIS with the exposure swelling twice (x1.4, x0.6): from one box, exposure matched or not.
- A still camera: each DAVIS animal laid (by its reference masks) on a still plate of another
  clip's ground, from one box, with the still background's cue, with the nearby ground's
  only, and with neither.
- Any other clips in the DAVIS layout, in the folder named by ``GAIT_MORE_DAVIS`` (footage the
  team does not keep): the first frame's cut, then the first item's protocol.
- The paper's rectangles on DAVIS bear: the paper's "gmm" method beside the default.
- Muybridge's race horse through the whole ``gaitcore analyze``: usable (period 36 +- 1,
  r1 and r2 >= 0.8) from each of four sets of input a user could draw.
- Speed: ``gaitcore segment`` from one box on a 300-frame 854x480 video, process start
  included, beside decoding the same file in a fresh process; one correction re-propagated
  over a 100-frame clip, a subject stroke and a background stroke each.
- Peak resident memory of the whole ``gaitcore analyze`` of a generated 10,000-frame video,
  in a fresh subprocess (``VmHWM`` of /proc/self/status).

Run ``python -m benchmarks segmentation`` to print the tables and record them.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from benchmarks import Section
from gaitcore.bench.scripted_user import LOWERED_BY, iou, legs_iou, padded_box, run_scripted_user
from gaitcore.cli import main as gaitcore_main
from gaitcore.footage.image_folder import read_mask_folder
from gaitcore.footage.sources import open_frames
from gaitcore.silhouettes.annotations import Rect, Scribble
from gaitcore.silhouettes.exposure import exposed
from gaitcore.silhouettes.roto import RotoSegmentation
from gaitcore.silhouettes.segmentation import segment_clip
from gaitcore.silhouettes.settings import PropagationSettings

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
CLIPS = ("bear", "dog", "goat")
HORSE = DATA / "muybridge-race-horse" / "race_horse_loop.mp4"
# Input a user could draw on the race horse's first frame (issue 11): the test suite's
# rectangles, a user's rectangles that used to flood the ground, another user's, brush strokes
# alone, one box.
HORSE_INPUTS = {
    "test suite's rectangles": ["--subject", "300,200,200,80", "--subject", "620,130,150,60",
                                "--background", "20,20,300,120", "--background",
                                "650,330,250,120", "--background", "0,420,250,80"],
    "subject 300,240,160,60; background 0,0,450,60 and 0,440,280,60":
        ["--subject", "300,240,160,60", "--background", "0,0,450,60", "--background",
         "0,440,280,60"],
    "subject 560,150,120,50; background 0,0,960,90 and 650,330,300,150":
        ["--subject", "560,150,120,50", "--background", "0,0,960,90", "--background",
         "650,330,300,150"],
    "strokes: subject along the neck, background on the sky and the ground (--scribbles)":
        ["--scribbles", "HORSE_STROKES"],
    "--box 110,30,760,420": ["--box", "110,30,760,420"],
}
HORSE_STROKES = {"scribbles": [
    {"frame": 0, "label": "subject", "width": 8, "points": [[565, 175], [675, 172]]},
    {"frame": 0, "label": "background", "width": 8, "points": [[20, 45], [940, 45]]},
    {"frame": 0, "label": "background", "width": 8, "points": [[660, 400], [940, 400]]}]}
# Chosen once by eye on frame 0 of DAVIS bear (see tests/gaitcore/test_segmentation.py).
BEAR_SUBJECT = [Rect(180, 245, 200, 70), Rect(385, 335, 30, 50)]
BEAR_BACKGROUND = [Rect(0, 0, 854, 190), Rect(500, 180, 354, 300), Rect(0, 440, 120, 40),
                   Rect(0, 200, 90, 120)]
LONG_FRAMES, LONG_W, LONG_H = 10_000, 640, 480


def run() -> list[Section]:
    """All sections of this benchmark (real-footage rows are skipped when it is absent)."""
    return [davis_from_box(), davis_loose_box(), davis_later_start(), davis_exposure(),
            still_camera(), more_davis(), paper_rectangles(), muybridge_usable(), speed(),
            long_clip_memory()]


def _davis(name: str):
    return _davis_at(DATA / f"davis-{name}")


def _davis_at(root: Path):
    return open_frames(root / "JPEGImages"), [m > 0 for m in read_mask_folder(root / "Annotations")]


def davis_from_box() -> Section:
    headers = ["clip", "frames", "IoU from box", "legs IoU from box", "strokes",
               "strokes that lowered the clip", "IoU after strokes", "legs IoU after strokes",
               "s per re-propagation"]
    title = "DAVIS from one box, then one scripted stroke per 10 frames"
    if not (DATA / "davis-bear").is_dir():
        return Section(title, headers, [], [f"skipped: real footage not found at {DATA}"])
    rows = [[name, *_scripted(*_davis(name))[1]] for name in CLIPS]
    notes = ["targets (issue 11): IoU from the box >= 0.85; after the strokes >= 0.92 and legs "
             ">= 0.75, on each clip",
             "box: the reference mask's bounding box on frame 0, padded 4%; each round the "
             "scripted user strokes the middle of the largest wrong region of the worst frame",
             "legs: IoU inside the lower third of each frame's reference bounding box",
             LOWERED_NOTE,
             "for scale (not measured here): the DAVIS challenge's published results on DAVIS "
             "2016, 59 methods, the semi-supervised ones given the whole first-frame mask, read "
             "the goat at best 0.913 (OnAVOS) and the dog 0.956 (AnDiff); OSVOS 0.880 and "
             "0.907, ObjectFlow 0.865 and 0.897 (docs/segmentation.md)",
             "tried and left out (prototypes, bear / dog / goat): the background's colours "
             "learnt again every 5 frames beyond a tenth of the subject's side (the subject's "
             "kept from the key) gave 0.912 / 0.828 / 0.785 from the box, but the dog's "
             "after strokes fell to 0.854 (legs 0.714) and its figure from the box swung "
             "between 0.774 and 0.828 with the interval (3, 5, 10 frames); a cut not allowed "
             "to take new pixels that move with the camera (a homography fitted around the "
             "mask, 0.5 px) gave 0.923 / 0.886 / 0.814 after strokes but the bear's legs "
             "fell to 0.700"]
    return Section(title, headers, rows, notes)


LOWERED_NOTE = (f"strokes that lowered the clip: those after which the clip's mean IoU fell "
                f"by more than {LOWERED_BY} (a correction that left the artist further from "
                "the animal)")


def _scripted(source, refs) -> tuple[float, list]:
    """The first table's protocol on one clip: the IoU of the first frame's cut, and its row
    after the clip's name (frames, from the box, strokes, those that lowered the clip, after
    them, seconds)."""
    seg = RotoSegmentation(source, box=padded_box(refs[0]))
    seg.run()
    first = iou(seg.work.enlarge(seg.keys[0].mask), refs[0])
    result = run_scripted_user(seg, refs, len(refs) // 10)
    return _r(first), [len(refs), _r(result.ious[0].mean()), _r(result.legs[0].mean()),
                       len(result.seconds), result.lowered(), _r(result.ious[-1].mean()),
                       _r(result.legs[-1].mean()), round(float(result.seconds.mean()), 2)]


def davis_loose_box(pads: tuple[float, ...] = (0.04, 0.1, 0.2, 0.3)) -> Section:
    """How much the result depends on how loosely the box is drawn."""
    return _davis_mean_iou(
        "DAVIS from a looser box (mean IoU)", [f"box padded {round(100 * p)}%" for p in pads],
        [_Case(pad=p) for p in pads],
        "the reference mask's bounding box on frame 0 padded on each side by the share of its "
        "size shown, clipped to the frame (the dog's box runs past the frame's top from 10%, "
        "the bear's past its left and bottom edges at 30%); no strokes")


def davis_later_start(starts: tuple[int, ...] = (0, 15, 30)) -> Section:
    """The same clips cut to start later: another first frame, another box."""
    return _davis_mean_iou(
        "DAVIS from one box on a later first frame (mean IoU)",
        [f"from frame {s}" for s in starts], [_Case(start=s) for s in starts],
        "the clip from that frame on, boxed there as in the first table (the reference's "
        "bounding box padded 4%); no strokes")


def davis_exposure(tops: tuple[float, ...] = (1.4, 0.6), warmer: float = 1.06) -> Section:
    """The camera's exposure or white balance swelling during the clip, matched by the
    propagation or not."""
    cases = [*(_Case(lit=top) for top in tops), _Case(warmer=warmer)]
    names = [*(f"lit x{top}" for top in tops), f"warmer x{warmer}"]
    return _davis_mean_iou(
        "DAVIS from one box, with the exposure or the white balance swelling twice",
        ["as shot", *names, *(f"{name}, not matched" for name in names)],
        [_Case(), *cases, *(replace(case, match_exposure=False) for case in cases)],
        "mean IoU from the box (padded 4%); every frame is multiplied by a gain that rises "
        "from 1 to the given factor and back, twice over the clip (lit: all three channels; "
        "warmer: red times the factor, blue over it), rounded and saturated as the "
        "propagation's own `exposed` does (these columns move by about 0.05 on a rounding: "
        "with the products truncated, dog and goat lit x1.4 read 0.621 and 0.540 on "
        "2026-11-26); each propagated frame is brought back to its key frame's exposure and "
        "colour balance, measured at the points the optical flow pairs, before the key's "
        "colours judge it")


@dataclass(frozen=True)
class _Case:
    """One column of :func:`_davis_mean_iou`: the clip from frame ``start``, boxed there
    (the reference's bounding box padded by ``pad``), every frame multiplied by a gain that
    swells twice up to ``lit`` (its red by one up to ``warmer``, its blue divided by it),
    segmented with or without ``match_exposure``."""

    start: int = 0
    pad: float = 0.04
    lit: float = 1.0
    warmer: float = 1.0
    match_exposure: bool = True


def _davis_mean_iou(title: str, columns: list[str], cases: list[_Case], note: str) -> Section:
    """Mean IoU of each DAVIS clip segmented from one box, a column per case."""
    headers = ["clip", *columns]
    if not (DATA / "davis-bear").is_dir():
        return Section(title, headers, [], [f"skipped: real footage not found at {DATA}"])
    rows = []
    for name in CLIPS:
        source, refs = _davis(name)
        row: list = [name]
        for case in cases:
            frames = [source[t] for t in range(case.start, len(refs))]
            if case.lit != 1.0 or case.warmer != 1.0:
                swell = 0.5 - 0.5 * np.cos(4 * np.pi * np.arange(case.start, len(refs))
                                           / len(refs))
                lit, warm = 1 + (case.lit - 1) * swell, 1 + (case.warmer - 1) * swell
                frames = [exposed(f, (g / w, g, g * w)) for f, g, w in zip(frames, lit, warm)]
            seg = RotoSegmentation(frames, box=padded_box(refs[case.start], case.pad),
                                   settings=PropagationSettings(
                                       match_exposure=case.match_exposure))
            seg.run()
            row.append(_r(np.mean([iou(seg.mask(t), refs[case.start + t])
                                   for t in range(seg.n)])))
        rows.append(row)
    return Section(title, headers, rows, [note])


STILL_PLATES = {"bear": "dog", "dog": "goat", "goat": "bear"}
"""Whose ground each animal is laid on in :func:`still_camera`."""


def still_camera() -> Section:
    """DAVIS's animals as a camera that held still would see them: each clip's animal (its
    pixels under its reference masks, their edges feathered by a Gaussian of 1 pixel) laid
    on one still plate, another clip's last frame with that clip's animal painted out."""
    headers = ["animal", "on the ground of", "IoU, still background's cue", "legs IoU",
               "IoU, nearby ground's cue only", "legs IoU", "IoU, neither", "legs IoU"]
    title = "A still camera: DAVIS's animals on a still plate, from one box"
    if not (DATA / "davis-bear").is_dir():
        return Section(title, headers, [], [f"skipped: real footage not found at {DATA}"])
    rows = []
    for name, plate_of in STILL_PLATES.items():
        source, refs = _davis(name)
        frames = _on_still_plate(source, refs, _plate(plate_of, refs[0].shape))
        row: list = [name, plate_of]
        for settings in (PropagationSettings(), PropagationSettings(still_weight=0.0),
                         PropagationSettings(still_weight=0.0, nearby_weight=0.0)):
            seg = RotoSegmentation(frames, box=padded_box(refs[0]), settings=settings)
            seg.run()
            masks = [seg.mask(t) for t in range(seg.n)]
            row += [_r(np.mean([iou(m, r) for m, r in zip(masks, refs)])),
                    _r(np.mean([legs_iou(m, r) for m, r in zip(masks, refs)]))]
        rows.append(row)
    return Section(title, headers, rows, [
        "plate: the last frame of the clip named, its animal (reference mask grown by 7 "
        "pixels) painted out by cv2.inpaint (Telea), resized to the animal's frames; box: "
        "the reference's on frame 0 padded 4%, no strokes",
        "the still background: per pixel, the median of 15 frames sampled across the clip "
        "where the engine's own first masks leave the ground free; the clip is then carried "
        "again with how unlike it each pixel looks as a cue (ground.StillBackground.ratios)",
        "nearby ground's cue only: no still background is sought (still_weight 0), so the "
        "frames up to 8 either side of each give the ground behind the animal "
        "(ground.NearbyGround), as on a panning camera; on the tests' synthetic still "
        "scene (an animal of nearly the ground's colours) it reads 0.63, the still "
        "background's 0.97, neither 0.50",
        "a plain median of the frames (not masked by the animal) read bear / dog / goat "
        "0.927 / 0.804 / 0.605 at weight 1 in a prototype: where the animal lingers the "
        "median holds it, and the ground it uncovers looked like the subject (the goat's "
        "mask flooded from frame 45 on)"])


def _plate(name: str, shape: tuple[int, ...]) -> np.ndarray:
    """The last frame of DAVIS clip ``name`` with its animal painted out, at ``shape``."""
    source, refs = _davis(name)
    last = len(refs) - 1
    animal = cv2.dilate(refs[last].astype(np.uint8), np.ones((15, 15), np.uint8))
    plate = cv2.inpaint(source[last], animal, 5, cv2.INPAINT_TELEA)
    return cv2.resize(plate, (shape[1], shape[0]), interpolation=cv2.INTER_AREA)


def _on_still_plate(source, refs, plate: np.ndarray) -> list[np.ndarray]:
    """Each frame's animal (under its reference mask, feathered) laid on ``plate``."""
    out = []
    for t, ref in enumerate(refs):
        alpha = cv2.GaussianBlur(ref.astype(np.float32), (0, 0), 1.0)[..., None]
        out.append(np.clip(alpha * source[t] + (1 - alpha) * plate + 0.5, 0, 255)
                   .astype(np.uint8))
    return out


def more_clips() -> list[Path]:
    """Every folder under ``GAIT_MORE_DAVIS`` with ``JPEGImages`` and ``Annotations``, sorted
    (none when it is unset or not a folder)."""
    where = os.environ.get("GAIT_MORE_DAVIS")
    if not where or not Path(where).is_dir():
        return []
    return sorted(p for p in Path(where).iterdir()
                  if (p / "Annotations").is_dir() and (p / "JPEGImages").is_dir())


def more_davis() -> Section:
    """The first table's protocol on clips beyond ../shared/data: every folder under
    ``GAIT_MORE_DAVIS`` with ``JPEGImages`` and ``Annotations`` (DAVIS's layout; for instance
    DAVIS 2016's twenty validation clips, animals or not)."""
    headers = ["clip", "frames", "first frame's cut", "IoU from box", "legs IoU from box",
               "strokes", "strokes that lowered the clip", "IoU after strokes",
               "legs IoU after strokes", "s per re-propagation"]
    title = ("More clips in the DAVIS layout, from one box, then one scripted stroke per 10 "
             "frames (GAIT_MORE_DAVIS)")
    where = os.environ.get("GAIT_MORE_DAVIS")
    clips = more_clips()
    if not clips:
        return Section(title, headers, [], [
            "skipped: set GAIT_MORE_DAVIS to a folder of clips, each with JPEGImages/ and "
            "Annotations/ (one reference mask per frame), to run the first table's protocol "
            "on footage the benchmark has not seen"])
    rows = []
    for root in clips:
        first, (frames, *row) = _scripted(*_davis_at(root))
        rows.append([root.name, frames, first, *row])
    if len(rows) > 1:
        columns = list(zip(*rows))
        rows.append(["mean of the clips", sum(columns[1]), *(_r(np.mean(c)) for c in columns[2:5]),
                     sum(columns[5]), sum(columns[6]), *(_r(np.mean(c)) for c in columns[7:9]),
                     round(float(np.mean(columns[9])), 2)])
    return Section(title, headers, rows, [
        f"clips: every folder under {where} with JPEGImages/ and Annotations/; box and "
        "strokes as in the first table; legs: the lower third of each frame's reference box",
        "first frame's cut: the key frame the clip is propagated from, at the working size",
        LOWERED_NOTE])


def paper_rectangles() -> Section:
    headers = ["method", "mean IoU", "min IoU"]
    title = "DAVIS bear from the paper's rectangles (2 subject, 4 background, frame 0)"
    if not (DATA / "davis-bear").is_dir():
        return Section(title, headers, [], [f"skipped: real footage not found at {DATA}"])
    source, refs = _davis("bear")
    rows = []
    for method in ("gmm", "propagate"):
        masks: dict[int, np.ndarray] = {}
        segment_clip(source, BEAR_SUBJECT, BEAR_BACKGROUND, method=method,
                     mask_sink=lambda i, m: masks.__setitem__(i, m > 0))
        scores = np.array([iou(masks[t], refs[t]) for t in range(len(refs))])
        rows.append([method, _r(scores.mean()), _r(scores.min())])
    return Section(title, headers, rows, [
        f"subject {[r.as_tuple() for r in BEAR_SUBJECT]}, background "
        f"{[r.as_tuple() for r in BEAR_BACKGROUND]}"])


def muybridge_usable() -> Section:
    headers = ["input on frame 0", "period (frames)", "r1", "r2", "usable (36 +- 1, r >= 0.8)",
               "seconds", "seconds / the box's"]
    title = "Muybridge's race horse (540 frames, 960x540) through gaitcore analyze"
    if not HORSE.is_file():
        return Section(title, headers, [], [f"skipped: {HORSE} not found"])
    rows = []
    for label, args in HORSE_INPUTS.items():
        with tempfile.TemporaryDirectory(prefix="gait-bench-") as tmp:
            strokes = Path(tmp) / "strokes.json"
            strokes.write_text(json.dumps(HORSE_STROKES))
            args = [str(strokes) if a == "HORSE_STROKES" else a for a in args]
            t0 = time.perf_counter()
            with contextlib.redirect_stdout(io.StringIO()):
                status = gaitcore_main(["analyze", str(HORSE), "--out", tmp + "/out", *args])
            seconds = time.perf_counter() - t0
            data = (json.loads((Path(tmp) / "out" / "analysis.json").read_text())
                    if status == 0 else {})
        period, r = data.get("period_frames", float("nan")), data.get("correlations", [0, 0])
        ok = abs(period - 36) <= 1 and min(r[:2]) >= 0.8
        rows.append([label, round(period, 1), _r(r[0]), _r(r[1]), "yes" if ok else "NO",
                     round(seconds, 1)])
    box = rows[-1][-1]  # HORSE_INPUTS ends with the box
    for row in rows:
        row.append(round(row[-1] / box, 2))
    return Section(title, headers, rows, [
        "the loop repeats every 36 video frames",
        "seconds: the whole analyze command in this process (decode, segmentation, analysis, "
        "540 PNG masks); a rectangle or a stroke on part of the horse works at the size of the "
        "region it starts, like a box around the horse"])


def speed() -> Section:
    headers = ["what", "frames", "seconds", "frames/s", "decode frames/s", "decode / segment"]
    title = "Speed on a 300-frame 854x480 video (DAVIS bear, forth and back)"
    if not (DATA / "davis-bear").is_dir():
        return Section(title, headers, [], [f"skipped: real footage not found at {DATA}"])
    source, refs = _davis("bear")
    with tempfile.TemporaryDirectory(prefix="gait-bench-") as tmp:
        video = Path(tmp) / "bear300.mp4"
        _write_video(video, source, 300)
        box = padded_box(refs[0])
        decode_s = min(_timed([sys.executable, "-c", _DECODE, str(video)]) for _ in range(2))
        segment = [sys.executable, "-m", "gaitcore.cli", "segment", str(video), "--out",
                   str(Path(tmp) / "out"), "--box", ",".join(map(str, box.as_tuple()))]
        cache = {"GAIT_CACHE_DIR": str(Path(tmp) / "cache")}  # empty: the machine's first run
        first_s = _timed(segment, cache)
        seg_s = min(_timed(segment, cache) for _ in range(2))
        clip = open_frames(video, stop=100)
        correct_s = {}
        for label, stroke in _CORRECTIONS.items():
            seg = RotoSegmentation(clip, box=box)
            seg.run()
            t0 = time.perf_counter()
            seg.correct([stroke])
            correct_s[label] = time.perf_counter() - t0
    rows = [["gaitcore segment --box (process start, decode, segment, 300 PNG masks)", 300,
             round(seg_s, 2), round(300 / seg_s, 1), round(300 / decode_s, 1),
             round(decode_s / seg_s, 2)],
            ["the same, the machine's first run (the network compiled, not yet cached)", 300,
             round(first_s, 2), round(300 / first_s, 1), round(300 / decode_s, 1),
             round(decode_s / first_s, 2)],
            *([f"one correction on frame 50 of 100 ({label}), re-propagated both ways", 100,
               round(seconds, 2), round(100 / seconds, 1), "", ""]
              for label, seconds in correct_s.items())]
    notes = ["targets (issue 11): >= 25 frames/s from one box, process start included; one "
             "correction re-propagated over a 100-frame clip in <= 5 s",
             "decode: a fresh Python process reading every frame of the same file with OpenCV; "
             "best of 2 runs (segment: after the first run, which compiles the network and "
             "caches it, gaitcore.silhouettes.saliency.compiled_cache); 2-core machine"]
    return Section(title, headers, rows, notes)


_CORRECTIONS = {
    "a subject stroke on the bear's flank":
        Scribble([[250.0, 280.0], [320.0, 280.0]], 10, 50, "subject"),
    "a background stroke on the ground beside its legs":
        Scribble([[300.0, 440.0], [360.0, 440.0]], 10, 50, "background"),
}
"""Corrections on DAVIS bear's frame 50 (both lie where its reference mask says they should).
A subject stroke, or a background stroke off what the network calls salient, runs its passes
with the network (every ``saliency_every``-th frame); until 2026-11-29 the benchmark
timed a background stroke on the bear's own flank, which runs them without it."""

_DECODE = "import cv2, sys\ncap = cv2.VideoCapture(sys.argv[1])\nwhile cap.read()[0]:\n    pass\n"


def _write_video(path: Path, source, n: int) -> None:
    order = list(range(len(source))) + list(range(len(source) - 2, 0, -1))
    rows, cols = source.shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 25, (cols, rows))
    for t in range(n):
        writer.write(source[order[t % len(order)]])
    writer.release()


def _timed(cmd: list[str], more_env: dict[str, str] | None = None) -> float:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               **(more_env or {}))
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    return time.perf_counter() - t0


def long_clip_memory(n_frames: int = LONG_FRAMES) -> Section:
    headers = ["frames", "size", "input", "peak RSS MB", "baseline RSS MB", "seconds", "fps",
               "lost frames"]
    with tempfile.TemporaryDirectory(prefix="gait-bench-") as tmp:
        path = Path(tmp) / "long.mp4"
        box = write_long_video(path, n_frames)
        result = _measure_in_subprocess(path, box)
    if result["status"] != 0:
        raise RuntimeError(f"gaitcore analyze failed on the long clip (status {result['status']})")
    rows = [[n_frames, f"{LONG_W}x{LONG_H}", "--box", round(result["peak_mb"]),
             round(result["baseline_mb"]), round(result["seconds"], 1),
             round(n_frames / result["seconds"], 1), result["lost"]]]
    notes = ["target: peak RSS < 1500 MB; measured as VmHWM of a fresh subprocess running the "
             "whole `gaitcore analyze` (decode, segment, ROI, PCA, diagnosis, key selection, "
             "masks written to disk)",
             "baseline = VmHWM after imports, before segmenting"]
    return Section("Memory of a whole analysis on a long clip (generated mp4v video)", headers,
                   rows, notes)


def write_long_video(path: Path, n_frames: int, *, seed: int = 0) -> tuple[int, int, int, int]:
    """A brown animal pacing back and forth over textured grass; returns its box on frame 0."""
    rng = np.random.default_rng(seed)
    noise = cv2.GaussianBlur(rng.normal(0, 25, (LONG_H, LONG_W)).astype(np.float32), (0, 0), 3)
    grass = np.clip(np.array([50, 140, 70], np.float32) + noise[..., None] * [1, 1.5, 1], 0, 255)
    grass = grass.astype(np.uint8)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 25, (LONG_W, LONG_H))
    for t in range(n_frames):
        img = grass.copy()
        cx, cy = int(320 + 180 * np.sin(2 * np.pi * t / 400)), 240
        cv2.ellipse(img, (cx, cy), (90, 40), 0, 0, 360, (40, 80, 160), -1)
        swing = int(25 * np.sin(2 * np.pi * t / 16))
        for foot in (cx - 55, cx + 55):
            cv2.line(img, (foot, cy + 25), (foot + swing, cy + 110), (40, 80, 160), 14)
        cv2.circle(img, (cx + 95, cy - 30), 22, (40, 80, 160), -1)
        writer.write(img)
    writer.release()
    return 215, 180, 230, 185


_CHILD = r"""
import io, json, sys, time, contextlib
from gaitcore.cli import main

def vmhwm_mb():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
base = vmhwm_mb()
path, box = sys.argv[1], sys.argv[2]
t0 = time.perf_counter()
out = io.StringIO()
with contextlib.redirect_stdout(out):
    status = main(["analyze", path, "--out", sys.argv[3], "--json", "--box", box])
seconds = time.perf_counter() - t0
result = json.loads(out.getvalue()) if status == 0 else {}
print(json.dumps({"peak_mb": vmhwm_mb(), "baseline_mb": base, "seconds": seconds,
                  "lost": len(result.get("lost_frames", [])), "status": status}))
"""


def _measure_in_subprocess(path: Path, box: tuple) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(path), ",".join(map(str, box)),
         str(path.parent / "analysis")],
        check=True, capture_output=True, text=True, env=env,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _r(value: float) -> float:
    return round(float(value), 3)
