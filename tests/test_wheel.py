"""The package installs whole: a wheel in a fresh venv outside the checkout runs every command.

The wheel is built from this checkout and installed with ``--no-deps`` into a new virtual
environment in a temporary folder; the heavy dependencies (Qt, OpenCV, numpy...) are borrowed
from the test environment through a path entry, so nothing is downloaded, while gaitcore and
the app can only come from the wheel (the checkout's editable install is not visible there).
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from tests.conftest import ROOT

pytestmark = pytest.mark.slow


def _run(args: list[str], cwd: Path, env: dict,
         timeout: float = 300) -> subprocess.CompletedProcess:
    out = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert out.returncode == 0, f"{' '.join(map(str, args))} failed:\n{out.stdout}\n{out.stderr}"
    return out


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> tuple[Path, dict]:
    """A venv outside the checkout with the wheel of this checkout installed."""
    base = tmp_path_factory.mktemp("wheel")
    wheels = base / "dist"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
          "-w", str(wheels), str(ROOT)], cwd=base, env=env)
    (wheel,) = wheels.glob("gaitstudio-*.whl")
    target = base / "venv"
    venv.EnvBuilder(with_pip=False).create(target)
    bin_dir = target / "bin"
    site = Path(subprocess.check_output(
        [bin_dir / "python", "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        text=True).strip())
    (site / "borrowed-deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    _run([sys.executable, "-m", "pip", "--python", str(bin_dir / "python"), "install", "-q",
          "--no-deps", str(wheel)], cwd=base, env=env)
    env["PATH"] = f"{bin_dir}{os.pathsep}{env.get('PATH', '')}"
    return base, env


def test_the_wheel_holds_the_package_and_its_resources(installed):
    base, env = installed
    out = _run(["python", "-c", "import gaitcore, app; from importlib.resources import files; "
                "print(gaitcore.__file__); print(app.__file__); "
                "print((files('gaitcore.resources') / 'skeletons' / 'horse.json').is_file()); "
                "print((files('gaitcore') / 'py.typed').is_file()); "
                "from gaitcore.rig.pose_library import shipped_library; "
                "print(len(shipped_library()))"], cwd=base, env=env)
    gaitcore_file, app_file, has_template, typed, examples = out.stdout.split()
    assert Path(gaitcore_file).is_relative_to(base / "venv"), "gaitcore must come from the wheel"
    assert Path(app_file).is_relative_to(base / "venv"), "the app must come from the wheel"
    assert has_template == "True" and typed == "True"
    assert int(examples) > 0  # the gait library of example poses (resources/poses)


def test_the_installed_commands_synthesize_analyse_and_show_the_demo(installed):
    base, env = installed
    _run(["gaitcore", "synth", "--gait", "walk", "--frames", "40", "--out", "clip"], cwd=base,
         env=env)
    out = _run(["gaitcore", "analyze", "clip/masks", "--out", "an", "--keys", "3"], cwd=base,
               env=env)
    assert "key-images:" in out.stdout and (base / "an" / "analysis.json").is_file()
    if not os.environ.get("DISPLAY"):
        pytest.skip("gaitstudio --demo --screenshot needs an X display (make test runs under Xvfb)")
    env = dict(env, XDG_CACHE_HOME=str(base / "cache"), XDG_CONFIG_HOME=str(base / "config"),
               PYOPENGL_PLATFORM="egl", PYQTGRAPH_QT_LIB="PySide6")
    _run(["gaitstudio", "--demo", "--screenshot", "shot.png"], cwd=base, env=env, timeout=600)
    assert (base / "shot.png").stat().st_size > 10_000
