"""Project file benchmark: saving (and autosaving) the silhouettes of a long clip.

- ``save_project`` and ``load_project`` of a project with 10,000 tracked 200 x 260 crops, the
  size a 640 x 480 clip gives; every autosave after an edit pays the save (on the GUI thread).
- Baseline in the same process: the version 1 layout, one byte per pixel, serialised and
  hashed as version 1 did (``np.save`` to memory, SHA-256, write).

Run ``python -m benchmarks project``.
"""

from __future__ import annotations

import hashlib
import io
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from benchmarks import Section
from gaitcore.project.document import Project, Silhouettes
from gaitcore.project.storage import load_project, save_project, sidecar_dir
from gaitcore.silhouettes.tracking import RoiClip

N_FRAMES, ROWS, COLS = 10_000, 200, 260


def run() -> list[Section]:
    """All sections of this benchmark."""
    return [save_speed()]


def _crops() -> np.ndarray:
    """A trotting blob: body and four legs that swing, one crop per frame."""
    crops = np.zeros((N_FRAMES, ROWS, COLS), dtype=np.uint8)
    for t in range(N_FRAMES):
        phase = 2 * np.pi * t / 30
        cv2.ellipse(crops[t], (130, 90), (80, 35), 0, 0, 360, 1, -1)
        for i, x in enumerate((80, 100, 160, 180)):
            swing = int(25 * np.sin(phase + np.pi * (i % 2)))
            cv2.line(crops[t], (x, 110), (x + swing, 190), 1, 9)
    return crops.view(bool)


def _version_1_save(crops: np.ndarray, folder: Path) -> int:
    buf = io.BytesIO()
    np.save(buf, crops, allow_pickle=False)
    data = buf.getvalue()
    f = folder / f"crops-{hashlib.sha256(data).hexdigest()[:16]}.npy"
    if not f.exists():  # as version 1 did: an unchanged array is hashed, not written again
        f.write_bytes(data)
    return len(data)


def _timed(fn) -> tuple[float, object]:
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def save_speed() -> Section:
    crops = _crops()
    roi = RoiClip(crops, np.zeros((N_FRAMES, 2)), np.zeros(N_FRAMES, dtype=bool), 1.0)
    project = Project(silhouettes=Silhouettes(roi, "masks"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = folder / "clip.gaitproj"
        first, _ = _timed(lambda: save_project(project, path))
        again, _ = _timed(lambda: save_project(project, path))
        size = sum(f.stat().st_size for f in sidecar_dir(path).iterdir())
        load, loaded = _timed(lambda: load_project(path))
        assert np.array_equal(loaded.silhouettes.roi.crops, crops)
        (folder / "v1").mkdir()
        base, base_size = _timed(lambda: _version_1_save(crops, folder / "v1"))
        base_again, _ = _timed(lambda: _version_1_save(crops, folder / "v1"))
        base_load, _ = _timed(lambda: np.load(next((folder / "v1").iterdir())))
    rows = [
        ["version 1 layout (baseline), first save", f"{base:.2f}", f"{base_size / 1e6:.0f}",
         "1.00"],
        ["version 1 layout (baseline), saved again", f"{base_again:.2f}", "-", "1.00"],
        ["version 1 layout (baseline), load the crops", f"{base_load:.2f}", "-", "1.00"],
        ["format 2 (packed), first save", f"{first:.2f}", f"{size / 1e6:.0f}",
         f"{base / first:.2f}"],
        ["format 2 (packed), saved again (autosave after an edit)", f"{again:.2f}", "-",
         f"{base_again / again:.2f}"],
        ["format 2, load the project", f"{load:.2f}", "-", f"{base_load / load:.2f}"],
    ]
    return Section(
        title=f"Saving {N_FRAMES:,} silhouette crops of {ROWS} x {COLS}",
        headers=["what", "time (s)", "crops on disk (MB)", "speed-up vs baseline"],
        rows=rows,
        notes=["The autosave runs on the GUI thread, so its save time is how long the window "
               "holds still once a minute while there are unsaved edits.",
               "Format 2 packs 8 pixels to a byte (np.packbits); version 1 files still open."],
    )
