"""The ``gaitstudio`` command: --demo --screenshot saves a loaded window and exits 0."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from gaitcore.project.storage import load_project

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


@pytest.mark.slow
def test_the_demo_script_ends_in_the_app_on_its_posed_project(tmp_path, artifacts_dir):
    """What `make demo` runs once the .venv exists (headless: a screenshot, not a window)."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env.update(XDG_CACHE_HOME=str(tmp_path / "cache"), XDG_CONFIG_HOME=str(tmp_path / "config"))
    out = tmp_path / "demo"
    run = subprocess.run(["sh", "scripts/demo.sh", str(Path(sys.executable).parent), str(out)],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "mean |error|" in run.stdout
    project = load_project(out / "canter.gaitproj")
    analysis = json.loads((out / "analysis" / "analysis.json").read_text())
    assert sorted(project.key_poses) == sorted(analysis["key_frames"])
    shot = cv2.imread(str(out / "gaitstudio.png"))
    assert shot is not None and shot.std() > 10
    shutil.copy(out / "gaitstudio.png", artifacts_dir / "make_demo.png")
