"""Shared fixtures: where test artifacts go and where the real footage lives."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = ROOT.parent / "shared" / "data"
ARTIFACTS = ROOT / "tests" / "_artifacts"

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")


@pytest.fixture(scope="session", autouse=True)
def _compiled_cache(tmp_path_factory):
    """The compiled network's cache (:func:`gaitcore.silhouettes.saliency.compiled_cache`) in
    a folder of the run's own, for the tests and the commands they start, not the user's."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("GAIT_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        yield


@pytest.fixture
def artifacts_dir() -> Path:
    """Folder for screenshots and plots that a person should look at after a run."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    return ARTIFACTS


@pytest.fixture
def shared_data() -> Path:
    """The real footage in ../shared/data; skips the test when it is not there."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real footage not found at {SHARED_DATA} (only present inside the workplace)")
    return SHARED_DATA


def pytest_collection_modifyitems(config, items):
    """Tests marked ``fuzz`` (thousands of cases per reader) run only with ``-m fuzz``."""
    if "fuzz" in (config.getoption("markexpr") or ""):
        return
    skip = pytest.mark.skip(reason="thousands of fuzz cases: run them with -m fuzz")
    for item in items:
        if item.get_closest_marker("fuzz") is not None:
            item.add_marker(skip)


@pytest.fixture
def without_saliency(tmp_path, monkeypatch) -> None:
    """The silhouettes cut without the salient-object network, as on an install without its
    model (:mod:`gaitcore.silhouettes.saliency`): for tests of the colour-only cuts and their
    safeguards, which the network's map otherwise decides before them."""
    monkeypatch.setenv("GAIT_SALIENCY_MODEL", str(tmp_path / "absent.onnx"))
