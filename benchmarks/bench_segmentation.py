"""Segmentation benchmark (paper Section 2.2): quality, speed and memory.

- Mean IoU on DAVIS "bear" of the paper's plain mixture model ("gmm") and of the default
  method ("grabcut"), from rectangles drawn on the first frame only.
- Throughput of segmentation + ROI on the same 854x480 frames, beside the bare decode rate.
- A small animal in HD: the synthetic horse (about 270 x 170 pixels) pasted into 1920x1080
  textured footage; IoU and speed of the default method against the same method with the
  working size set from the frame only (``subject_side_px=0``, the earlier behaviour).
- Peak resident memory of the whole ``gaitcore analyze`` of a generated 10,000-frame 640x480
  video, measured in a fresh subprocess (``VmHWM`` of /proc/self/status) so that the
  baseline is clean.

Run ``python -m benchmarks segmentation`` to print the tables.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from benchmarks import Section
from gaitcore.footage.image_folder import read_mask_folder
from gaitcore.footage.sources import open_frames
from gaitcore.silhouettes.annotations import Rect
from gaitcore.silhouettes.segmentation import SegmentationSettings, segment_clip

ROOT = Path(__file__).resolve().parents[1]
DAVIS = ROOT.parent / "shared" / "data" / "davis-bear"
# Chosen once by eye on frame 0 (see tests/gaitcore/test_segmentation.py): the subject on the
# bear's back and hind leg; the background on the wall, the ground to the right, the rocks.
BEAR_SUBJECT = [Rect(180, 245, 200, 70), Rect(385, 335, 30, 50)]
BEAR_BACKGROUND = [Rect(0, 0, 854, 190), Rect(500, 180, 354, 300), Rect(0, 440, 120, 40),
                   Rect(0, 200, 90, 120)]
LONG_FRAMES, LONG_W, LONG_H = 10_000, 640, 480


def run() -> list[Section]:
    """All sections of this benchmark (DAVIS rows are skipped when the data is absent)."""
    return [davis_quality_and_speed(), small_animal_in_hd(), long_clip_memory()]


def davis_quality_and_speed() -> Section:
    headers = ["method", "mean IoU", "min IoU", "segment+ROI fps", "decode fps", "decode / segment"]
    if not (DAVIS / "JPEGImages").is_dir():
        return Section("Segmentation on DAVIS bear (854x480, 82 frames)", headers, [],
                       [f"skipped: real footage not found at {DAVIS}"])
    refs = read_mask_folder(DAVIS / "Annotations")
    source = open_frames(DAVIS / "JPEGImages")
    decode_fps = max(_rate(lambda: sum(1 for _ in source), len(source)) for _ in range(3))
    rows = []
    for method in ("gmm", "grabcut"):
        masks: dict[int, np.ndarray] = {}

        def segment() -> None:
            segment_clip(source, BEAR_SUBJECT, BEAR_BACKGROUND, method=method,
                         mask_sink=lambda i, m: masks.__setitem__(i, m > 0))

        fps = max(_rate(segment, len(source)) for _ in range(3))
        iou = np.array([_iou(masks[t], refs[t]) for t in range(len(refs))])
        rows.append([method, round(float(iou.mean()), 3), round(float(iou.min()), 3),
                     round(fps, 1), round(decode_fps, 1), round(decode_fps / fps, 2)])
    notes = [
        "targets: grabcut mean IoU >= 0.85; >= 25 fps; segmentation within 3x of decoding",
        "fps include decoding the JPEGs (on a second thread) and handing every full-frame "
        "mask to a sink; best of 3 runs; 2-core machine",
        f"rectangles on frame 0 only: subject {[r.as_tuple() for r in BEAR_SUBJECT]}, "
        f"background {[r.as_tuple() for r in BEAR_BACKGROUND]}",
    ]
    return Section("Segmentation on DAVIS bear (854x480, 82 frames)", headers, rows, notes)


def small_animal_in_hd(n_frames: int = 60) -> Section:
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    from gaitcore.bench import generate_gait
    from gaitcore.rig.render import render_clip
    from gaitcore.rig.skeleton import load_template

    horse = load_template("horse")
    rgb, masks = render_clip(horse, generate_gait(horse, "canter", n_frames), width=320,
                             height=240)
    rows_px, cols_px, y0, x0 = 1080, 1920, 600, 800
    rng = np.random.default_rng(0)
    ground = cv2.GaussianBlur(cv2.resize(rng.integers(60, 200, (27, 48, 3), dtype=np.uint8),
                                         (cols_px, rows_px), interpolation=cv2.INTER_CUBIC),
                              (0, 0), 3)
    frames, truth = [], []
    for image, mask in zip(rgb, masks):
        frame = ground.copy()
        frame[y0 : y0 + 240, x0 : x0 + 320][mask] = image[..., ::-1][mask]
        full = np.zeros((rows_px, cols_px), bool)
        full[y0 : y0 + 240, x0 : x0 + 320] = mask
        frames.append(frame)
        truth.append(full)
    ys, xs = np.nonzero(truth[0])
    subject = [Rect(int(xs.min()), int(ys.min()), int(np.ptp(xs)), int(np.ptp(ys)))]
    background = [Rect(0, 0, 400, 300), Rect(1400, 100, 400, 300)]
    table = []
    for name, settings in (("working size from the frame (baseline)",
                            SegmentationSettings(subject_side_px=0)),
                           ("grows to the subject (default)", SegmentationSettings())):
        found: dict[int, np.ndarray] = {}

        def segment() -> None:
            segment_clip(frames, subject, background, settings=settings,
                         mask_sink=lambda i, m: found.__setitem__(i, m > 0))

        fps = max(_rate(segment, n_frames) for _ in range(2))
        iou = np.array([_iou(found[t], truth[t]) for t in range(n_frames)])
        table.append([name, round(float(iou.mean()), 3), round(float(iou.min()), 3),
                      round(fps, 1)])
    return Section(
        f"A small animal in HD footage ({cols_px}x{rows_px}, horse about "
        f"{int(np.ptp(xs))}x{int(np.ptp(ys))} px, {n_frames} frames)",
        ["grabcut", "mean IoU", "min IoU", "segment+ROI fps"], table,
        ["frames in memory (no decoding); best of 2 runs; the subject rectangle is the "
         "horse's box on frame 0, the background rectangles two corners of the ground"],
    )


def long_clip_memory(n_frames: int = LONG_FRAMES) -> Section:
    headers = ["frames", "size", "method", "peak RSS MB", "baseline RSS MB", "seconds", "fps",
               "lost frames"]
    with tempfile.TemporaryDirectory(prefix="gait-bench-") as tmp:
        path = Path(tmp) / "long.mp4"
        subject, background = write_long_video(path, n_frames)
        result = _measure_in_subprocess(path, subject, background)
    if result["status"] != 0:
        raise RuntimeError(f"gaitcore analyze failed on the long clip (status {result['status']})")
    rows = [[n_frames, f"{LONG_W}x{LONG_H}", "grabcut", round(result["peak_mb"]),
             round(result["baseline_mb"]), round(result["seconds"], 1),
             round(n_frames / result["seconds"], 1), result["lost"]]]
    notes = ["target: peak RSS < 1500 MB; measured as VmHWM of a fresh subprocess running the "
             "whole `gaitcore analyze` (decode, segment, ROI, PCA, diagnosis, key selection, "
             "masks written to disk)",
             "baseline = VmHWM after imports, before segmenting"]
    return Section("Memory of a whole analysis on a long clip (generated mp4v video)", headers,
                   rows, notes)


def write_long_video(path: Path, n_frames: int, *, seed: int = 0) -> tuple[list, list]:
    """A brown animal pacing back and forth over textured grass; returns its rectangles."""
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
    return [(280, 225, 80, 30)], [(0, 0, LONG_W, 120), (0, 400, LONG_W, 80)]


_CHILD = r"""
import io, json, sys, time, contextlib
from gaitcore.cli import main

def vmhwm_mb():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
base = vmhwm_mb()
path, subject, background = sys.argv[1], json.loads(sys.argv[2]), json.loads(sys.argv[3])
args = ["analyze", path, "--out", sys.argv[4], "--json"]
args += [a for r in subject for a in ("--subject", ",".join(map(str, r)))]
args += [a for r in background for a in ("--background", ",".join(map(str, r)))]
t0 = time.perf_counter()
out = io.StringIO()
with contextlib.redirect_stdout(out):
    status = main(args)
seconds = time.perf_counter() - t0
result = json.loads(out.getvalue()) if status == 0 else {}
print(json.dumps({"peak_mb": vmhwm_mb(), "baseline_mb": base, "seconds": seconds,
                  "lost": len(result.get("lost_frames", [])), "status": status}))
"""


def _measure_in_subprocess(path: Path, subject: list, background: list) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(path), json.dumps(subject), json.dumps(background),
         str(path.parent / "analysis")],
        check=True, capture_output=True, text=True, env=env,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _rate(fn, n: int) -> float:
    t0 = time.perf_counter()
    fn()
    return n / (time.perf_counter() - t0)


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


if __name__ == "__main__":
    for section in run():
        print(f"\n## {section.title}")
        print(" | ".join(map(str, section.headers)))
        for row in section.rows:
            print(" | ".join(map(str, row)))
        for note in section.notes:
            print(f"- {note}")
