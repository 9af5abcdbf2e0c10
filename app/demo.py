"""The demo project: a synthetic horse canter (paper Section 4), rendered once and cached.

The clip is rendered with :mod:`gaitcore.bench` into the user's cache folder the first time
(a few seconds), then reused. The demo project shows the rendered images as footage and
tracks the exact masks rendered with them, so everything is computed at once.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import cv2
import numpy as np
from PySide6.QtCore import QStandardPaths

from gaitcore.progress import Progress
from gaitcore.project.document import Project
from gaitcore.project.steps import silhouettes_from_masks

DEMO_GAIT = "canter"
DEMO_FRAMES = 100
DEMO_FPS = 25.0
_DONE = "complete"


def demo_folder() -> Path:
    """Where the demo clip is cached (``<user cache>/demo/canter-100``)."""
    cache = QStandardPaths.writableLocation(QStandardPaths.StandardLocation.CacheLocation)
    return Path(cache) / "demo" / f"{DEMO_GAIT}-{DEMO_FRAMES}"


def ensure_demo_clip(folder: Path, progress: Progress | None = None) -> Path:
    """Render the demo clip into ``folder`` unless a complete copy is there; returns it.

    Writes ``images/00000.png...`` and ``masks/00000.png...`` like ``gaitcore synth``. The
    clip is rendered into a sibling folder first and renamed when complete, so an interrupted
    render is never mistaken for a finished one.

    Raises
    ------
    GaitInputError
        When rendering fails (no OpenGL).
    Cancelled
        When ``progress`` returned False.
    """
    if (folder / _DONE).exists():
        return folder
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    from gaitcore.bench import generate_gait, iter_render
    from gaitcore.rig.templates import load_template

    partial = folder.with_name(folder.name + ".partial")
    shutil.rmtree(partial, ignore_errors=True)
    (partial / "images").mkdir(parents=True)
    (partial / "masks").mkdir()
    skeleton = load_template("horse")
    poses = generate_gait(skeleton, DEMO_GAIT, DEMO_FRAMES)
    for i, (rgb, mask) in enumerate(iter_render(skeleton, poses, progress=progress)):
        cv2.imwrite(str(partial / "images" / f"{i:05d}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        cv2.imwrite(str(partial / "masks" / f"{i:05d}.png"), mask.astype(np.uint8) * 255)
    (partial / _DONE).write_text("rendered by Gait Studio\n")
    shutil.rmtree(folder, ignore_errors=True)
    partial.rename(folder)
    return folder


def demo_project(folder: Path, progress: Progress | None = None) -> Project:
    """The demo project on the cached clip (rendered first when needed), with silhouettes."""
    ensure_demo_clip(folder, progress)
    silhouettes = silhouettes_from_masks(folder / "masks", progress)
    return Project(footage=folder / "images", fps=DEMO_FPS, silhouettes=silhouettes)
