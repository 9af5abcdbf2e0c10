"""A library of small generated clips for the batch tests and the batch benchmark.

Gait clips are rendered horses (gaitcore.bench) at several gaits and periods, shifted
across a wider frame at several speeds (the camera lags the animal), written as folders of
binary masks or as colour videos with a box; clips without a gait are a still blob with
noisy edges and a blob that jitters at random; a corrupt file is a few bytes of junk.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from gaitcore.bench.evaluate import BenchSettings, render_bench_clip

SIZE_WH = (160, 120)
"""Size of the rendered horse; clips are wider by the drift of the fastest speed."""
SYMMETRIC = ("walk", "trot")
"""Gaits whose two half-cycles look alike from the side: the silhouettes repeat every half cycle."""


@dataclass(frozen=True)
class LibraryClip:
    """A generated clip: its manifest row and what a batch should find."""

    clip: str
    path: str
    box: str = ""
    period_frames: float | None = None  # period of the silhouettes; None: no gait
    corrupt: bool = False


def silhouette_period(gait: str, period_frames: float) -> float:
    """Frames between two alike silhouettes: half the cycle for a walk or a trot."""
    return period_frames / 2 if gait in SYMMETRIC else period_frames


def render_horse(gait: str, period_frames: float, n_frames: int) -> np.ndarray:
    """Masks (n, H, W) bool of a rendered horse in ``gait``."""
    w, h = SIZE_WH
    _, _, masks = render_bench_clip(BenchSettings(gait=gait, n_frames=n_frames, width=w, height=h,
                                                  period_frames=period_frames))
    return masks


def drifted(masks: np.ndarray, speed_px: float, extra_px: int) -> np.ndarray:
    """The clip pasted into a frame ``extra_px`` wider, moving right ``speed_px`` a frame."""
    n, h, w = masks.shape
    out = np.zeros((n, h, w + extra_px), bool)
    for t, m in enumerate(masks):
        x = int(round(speed_px * t)) % (extra_px + 1)
        out[t, :, x:x + w] = m
    return out


def write_masks(folder: Path, masks: np.ndarray) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i, m in enumerate(masks):
        cv2.imwrite(str(folder / f"{i:05d}.png"), m.astype(np.uint8) * 255)
    return folder


def write_colour_video(path: Path, masks: np.ndarray, seed: int) -> str:
    """An MJPG video of a brown animal on textured grass; returns the box of frame 0."""
    rng = np.random.default_rng(seed)
    n, h, w = masks.shape
    grass = (np.array([60, 140, 70], np.int16) + rng.integers(-25, 25, (h, w, 3))).clip(0, 255)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (w, h))
    for m in masks:
        frame = grass.astype(np.uint8)
        frame[m] = (40, 70, 150)
        writer.write(frame)
    writer.release()
    ys, xs = np.nonzero(masks[0])
    pad = 4
    return f"{xs.min() - pad},{ys.min() - pad},{np.ptp(xs) + 2 * pad},{np.ptp(ys) + 2 * pad}"


def still_blob(n_frames: int, seed: int) -> np.ndarray:
    """An ellipse that never moves, its edge pixels flickering at random."""
    rng = np.random.default_rng(seed)
    h, w = SIZE_WH[1], SIZE_WH[0]
    base = np.zeros((h, w), np.uint8)
    cv2.ellipse(base, (w // 2, h // 2), (40, 22), 0, 0, 360, 255, -1)
    edge = cv2.morphologyEx(base, cv2.MORPH_GRADIENT, np.ones((5, 5), np.uint8)) > 0
    return np.stack([(base > 0) ^ (edge & (rng.random((h, w)) < 0.3)) for _ in range(n_frames)])


def jittering_blob(n_frames: int, seed: int) -> np.ndarray:
    """An ellipse whose position, size and angle change at random every frame."""
    rng = np.random.default_rng(seed)
    h, w = SIZE_WH[1], SIZE_WH[0]
    out = np.zeros((n_frames, h, w), np.uint8)
    for m in out:
        centre = (w // 2 + int(rng.integers(-5, 6)), h // 2 + int(rng.integers(-5, 6)))
        axes = (int(rng.integers(30, 46)), int(rng.integers(14, 26)))
        cv2.ellipse(m, centre, axes, float(rng.uniform(-20, 20)), 0, 360, 255, -1)
    return out > 0


def make_library(root: Path, *, gaits: dict[str, tuple[float, ...]], speeds: tuple[float, ...],
                 n_frames: int, videos_every: int = 0, still: int = 0, jitter: int = 0,
                 corrupt: int = 0) -> list[LibraryClip]:
    """Write a library under ``root`` and return its clips (manifest rows and truths).

    Every (gait, period) is rendered once and shifted at every speed; every
    ``videos_every``-th gait clip is a colour video with a box (0: masks only).
    """
    extra = int(np.ceil(max(speeds) * (n_frames - 1))) if speeds else 0
    clips: list[LibraryClip] = []
    for gait, periods in gaits.items():
        for period in periods:
            masks = render_horse(gait, period, n_frames)
            for speed in speeds:
                name = f"{gait}-p{period:g}-v{speed:g}"
                moving = drifted(masks, speed, extra)
                truth = silhouette_period(gait, period)
                if videos_every and len(clips) % videos_every == videos_every - 1:
                    box = write_colour_video(root / f"{name}.avi", moving, seed=len(clips))
                    clips.append(LibraryClip(name, f"{name}.avi", box, truth))
                else:
                    write_masks(root / name, moving)
                    clips.append(LibraryClip(name, name, "", truth))
    for k in range(still):
        clips.append(LibraryClip(f"still-{k}",
                                 write_masks(root / f"still-{k}", still_blob(n_frames, k)).name))
    for k in range(jitter):
        clips.append(LibraryClip(f"jitter-{k}",
                                 write_masks(root / f"jitter-{k}",
                                             jittering_blob(n_frames, k)).name))
    for k in range(corrupt):
        (root / f"corrupt-{k}.mp4").write_bytes(b"\x00\x00\x00\x18ftypmp42" + bytes(range(256)) * 4)
        clips.append(LibraryClip(f"corrupt-{k}", f"corrupt-{k}.mp4", "10,10,40,30", corrupt=True))
    return clips


def write_manifest(path: Path, clips: list[LibraryClip]) -> Path:
    lines = ["clip,path,box"] + [f'{c.clip},{c.path},"{c.box}"' for c in clips]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
