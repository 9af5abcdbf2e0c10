"""A tiny procedural 2-D walker for tests: an ellipse body with four swinging legs.

Not a substitute for the rendered synthetic bench (gaitcore.bench); it only gives tests a
fast, seeded, periodic clip of binary masks with a known period.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

LEGS = ((65, 0.0), (72, 0.5), (128, 0.25), (135, 0.75))  # hip x, phase (cycles)


def walker_frame(t: float, period: float = 24.0, size=(120, 200), shift_x: int = 0) -> np.ndarray:
    """One binary frame (uint8 0/255) of the walker at time t (frames)."""
    im = np.zeros(size, np.uint8)
    cy = 50 + 3 * np.sin(4 * np.pi * t / period)
    cx = 100 + shift_x
    cv2.ellipse(im, (cx, int(round(cy))), (45, 15), 0, 0, 360, 255, -1)
    for x0, ph in LEGS:
        a = 0.5 * np.sin(2 * np.pi * (t / period + ph))
        x1 = int(round(x0 + shift_x + 40 * np.sin(a)))
        y1 = int(round(cy + 10 + 40 * np.cos(a)))
        cv2.line(im, (x0 + shift_x, int(round(cy)) + 5), (x1, y1), 255, 6)
    return im


def walker_clip(n: int = 100, period: float = 24.0, *, drift_px: float = 0.5) -> np.ndarray:
    """n frames of the walker, drifting right (tracking must remove it), shape (n, 120, 260)."""
    return np.stack(
        [walker_frame(t, period, size=(120, 260), shift_x=int(drift_px * t) % 60) for t in range(n)]
    )


def write_mask_folder(folder: Path, clip: np.ndarray) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i, m in enumerate(clip):
        cv2.imwrite(str(folder / f"{i:05d}.png"), m)
    return folder
