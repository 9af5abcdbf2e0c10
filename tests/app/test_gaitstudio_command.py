"""The ``gaitstudio`` command: --demo --screenshot saves a loaded window and exits 0."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def run_gaitstudio(args, home: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", XDG_CACHE_HOME=str(home / "cache"),
               XDG_CONFIG_HOME=str(home / "config"), XDG_DATA_HOME=str(home / "data"))
    return subprocess.run([sys.executable, "-m", "app.main", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=180)


def test_demo_screenshot_shows_a_loaded_window(tmp_path, artifacts_dir):
    shot = tmp_path / "demo.png"
    run = run_gaitstudio(["--demo", "--screenshot", str(shot)], tmp_path)
    assert run.returncode == 0, run.stderr
    image = cv2.imread(str(shot))
    assert image is not None and image.shape[0] > 600 and image.shape[1] > 1000
    assert image.std() > 30, "a blank window is not a loaded window"
    shutil.copy(shot, artifacts_dir / "gaitstudio_demo.png")
    cached = list((tmp_path / "cache").rglob("complete"))
    assert len(cached) == 1, "the demo clip is cached for the next run"
    again = run_gaitstudio(["--demo", "--screenshot", str(shot)], tmp_path)
    assert again.returncode == 0, again.stderr


def test_a_bad_path_exits_2_with_one_line(tmp_path):
    run = run_gaitstudio([str(tmp_path / "nothing.mp4"), "--screenshot", str(tmp_path / "s.png")],
                         tmp_path)
    assert run.returncode == 2
    lines = [line for line in run.stderr.splitlines() if line.startswith("gaitstudio:")]
    assert len(lines) == 1 and "does not exist" in lines[0]
    assert "Traceback" not in run.stderr
    assert not (tmp_path / "s.png").exists()


def test_demo_screenshot_on_x11_shows_the_3d_viewport(tmp_path, artifacts_dir):
    """Under an X display (xvfb-run) the window has its GL viewport, and the screenshot too."""
    import pytest

    from tests.app.conftest import xcb_works

    if not xcb_works():
        pytest.skip("no X display with a working xcb platform (run under xvfb-run)")
    shot = tmp_path / "demo_gl.png"
    env = dict(os.environ, QT_QPA_PLATFORM="xcb", XDG_CACHE_HOME=str(tmp_path / "cache"),
               XDG_CONFIG_HOME=str(tmp_path / "config"), XDG_DATA_HOME=str(tmp_path / "data"))
    env.pop("QT_XCB_GL_INTEGRATION", None)  # the command chooses it itself
    run = subprocess.run([sys.executable, "-m", "app.main", "--demo", "--screenshot", str(shot)],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=180)
    assert run.returncode == 0, run.stderr
    assert "Error while drawing" not in run.stderr + run.stdout
    image = cv2.imread(str(shot))
    shutil.copy(shot, artifacts_dir / "gaitstudio_demo_gl.png")
    # The viewport's dark background fills the right half of the centre: it was drawn.
    from app.widgets.skeleton_gl import BACKGROUND_RGB

    dark = np.all(np.abs(image.astype(int) - BACKGROUND_RGB[::-1]) < 8, axis=2)
    assert dark.mean() > 0.03
