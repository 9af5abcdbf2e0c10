"""The segmentation engine of a project, saved beside it as a cache, and put back on reopening.

Segmenting a long clip takes minutes; a brush correction on a segmented clip re-propagates
only around its frame, but only while the engine of the segmentation
(:class:`~gaitcore.silhouettes.roto.RotoSegmentation`) is alive. Saving it with the project
lets the first correction after reopening be as quick as the next ones.

The engine is derived data, not the artist's work, so it lives apart from the project
document: ``horse.gaitproj.d/engine.json`` (format, version, a fingerprint of what the
segmentation depends on, the working size and the names of its arrays) and
``engine-table-<hash>.npy`` and ``engine-bits-<hash>.npy`` beside it: the key frames' cuts and
the masks of the forward and backward passes and what the key frames' strokes turned to the
subject, bit-packed around the subject (a
:class:`~gaitcore.silhouettes.roto_state.RotoState`; 1.8 to 3 MB for the 540 frames of
Muybridge's 960x540 race horse, more with more key frames), and ``engine-still-<hash>.npy``
when the camera held still (the background learnt behind the animal, at the working size:
B, G, R and whether it is known), and ``engine-states-<hash>.npy``: every frame's lost,
corrected and confidence (:class:`~gaitcore.silhouettes.roto.FrameState`), so that a reopened
project marks its frames to check on the timeline at once (:func:`saved_frames_to_check`),
though the engine itself is put back only by the first correction. A project file without an
engine (or without its states), or with one another version wrote, reads as before; reading
the engine never raises: a missing, damaged, stale or foreign file reads as None and the next
correction segments the clip again (nothing the artist made is in it). Writing is atomic
(arrays, then the JSON, then arrays no longer named are removed), as
:mod:`gaitcore.project.storage` writes projects; the project's own files are never touched.

Why a file of its own rather than an entry of the project JSON: the engine is a cache, so a
damaged one must never stop the project from loading (``load_project`` refuses damaged
files), it must not become part of the immutable :class:`~gaitcore.project.document.Project`
that undo swaps, and older Gait Studio versions ignore it with no format version bump.
"""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.footage.sources import FrameSource
from gaitcore.project.document import Project
from gaitcore.project.roto_session import RotoSession, reusable, segmentation_key
from gaitcore.project.storage import array_file, sidecar_dir, write_array, write_atomic
from gaitcore.schema import JsonValue, dump_json, read_json, read_npy
from gaitcore.silhouettes.ground import StillBackground
from gaitcore.silhouettes.packed_masks import PackedMasks
from gaitcore.silhouettes.propagate import WorkingSize
from gaitcore.silhouettes.roto import FrameState, frames_to_check
from gaitcore.silhouettes.roto_state import RotoState

ENGINE_FORMAT = "gaitstudio-engine"
ENGINE_VERSION = 7
"""Bump when the engine's arrays, or what the propagation makes of them, change: a file of
another version is ignored (the clip is segmented again)."""
ENGINE_FILE = "engine.json"
STORES = ("keys", "fwd", "bwd", "turned")
"""The engine's masks, in the order of the table's first column: key frames' cuts, forward
and backward passes, what the key frames' strokes turned to the subject."""
MAX_ENGINE_JSON_BYTES = 1 << 16
MAX_ENGINE_ARRAY_BYTES = 16 << 30
MAX_ENGINE_FRAMES = 10**8
MAX_SIDE_PX = 1 << 20
T = TypeVar("T")
_ENGINE_ARRAY = re.compile(r"^engine-(table|bits|still|states)-[0-9a-f]{16}\.npy$")


def engine_fingerprint(project: Project) -> str:
    """A hash of what ``project``'s segmentation engine depends on: its
    :func:`~gaitcore.project.roto_session.segmentation_key` (the footage path resolved, with
    the file's size and modification time, so that a replaced clip does not match), which
    holds the settings, and :data:`ENGINE_VERSION`."""
    footage, stat = project.footage, None
    if footage is not None:
        try:
            st = footage.stat()
            stat = (st.st_size, st.st_mtime_ns)
        except OSError:
            pass
        footage = footage.resolve()
    text = repr((ENGINE_VERSION, str(footage), stat, segmentation_key(project)[1:]))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def save_engine(path: str | os.PathLike, project: Project, session: RotoSession | None, *,
                opened_from: str | os.PathLike | None = None) -> bool:
    """Keep ``project``'s segmentation engine beside project file ``path`` (just saved), so
    that the first correction after reopening it re-propagates only around its frame.

    The engine is ``session``'s state for ``project``, else the one saved beside
    ``opened_from`` (the file the project was opened from: a "save as") when it matches;
    with neither, a matching engine already beside ``path`` is kept and any other removed.

    Returns
    -------
    bool
        True when ``path``'s folder now holds ``project``'s engine.

    Raises
    ------
    GaitInputError
        The folder cannot be written (the project's own files are not touched).
    """
    fingerprint = engine_fingerprint(project)
    state = session.state_for(project) if session is not None else None
    if state is None and opened_from is not None and Path(opened_from) != Path(path):
        state = read_engine(opened_from, fingerprint)
    if state is not None:
        write_engine(path, fingerprint, state)
        return True
    if engine_saved(path, fingerprint):
        return True
    remove_engine(path)
    return False


def resumed(session: RotoSession | None, source: FrameSource, project: Project, *,
            saved: str | os.PathLike | None = None) -> RotoSession | None:
    """A session on ``project``'s segmentation of ``source``, for
    :func:`~gaitcore.project.roto_session.corrected`: ``session`` back in the state matching
    ``project``, else the engine saved beside project file ``saved`` put back (the clip is not
    cut again); None when neither holds it (the clip must be segmented again)."""
    use = reusable(session, source, project)
    if use is not None:
        return use
    state = None if saved is None else read_engine(saved, engine_fingerprint(project))
    return None if state is None else RotoSession.from_state(source, project, state)


def write_engine(path: str | os.PathLike, fingerprint: str, state: RotoState) -> None:
    """Write ``state`` and its ``fingerprint`` into the sidecar folder of project file
    ``path``, atomically.

    Raises
    ------
    GaitInputError
        The folder cannot be written.
    """
    side = sidecar_dir(Path(path).absolute())
    tables, bits = [], []
    for i, masks in enumerate((state.keys, state.fwd, state.bwd, state.turned)):
        table, b = masks.to_arrays()
        tables.append(np.column_stack([np.full(len(table), float(i)), table]))
        bits.append(b)
    work = state.work
    try:
        side.mkdir(parents=True, exist_ok=True)
        arrays = {"table": write_array(side, "engine-table", np.concatenate(tables)),
                  "bits": write_array(side, "engine-bits", np.concatenate(bits))}
        if state.still is not None:
            arrays["still"] = write_array(side, "engine-still", np.dstack(
                [state.still.image, state.still.known.astype(np.uint8)]))
        if state.frame_states:
            arrays["states"] = write_array(side, "engine-states", np.array(
                [(st.lost, st.corrected, st.confidence) for st in state.frame_states]))
        doc = {"format": ENGINE_FORMAT, "version": ENGINE_VERSION, "fingerprint": fingerprint,
               "n_frames": state.n_frames,
               "work": {"scale": work.scale, "wh": list(work.wh), "shape": list(work.shape),
                        "subject_side": work.subject_side},
               "arrays": arrays}
        write_atomic(side / ENGINE_FILE, (dump_json(doc, indent=1, what="the segmentation state")
                                          + "\n").encode("utf-8"))
        _remove_arrays(side, keep=set(arrays.values()))
    except OSError as exc:
        raise GaitInputError(f"cannot save the segmentation engine to {side}: "
                             f"{exc.strerror or exc}; the project itself was saved") from None


def read_engine(path: str | os.PathLike, fingerprint: str) -> RotoState | None:
    """The engine state saved beside project file ``path`` when its fingerprint is
    ``fingerprint``; None when there is none, or it is of other inputs, another version, or
    damaged (never an error: the clip can always be segmented again)."""
    return _read_matching(path, fingerprint, _read)


def saved_frames_to_check(path: str | os.PathLike, project: Project) -> tuple[int, ...] | None:
    """The frames to check (:func:`~gaitcore.silhouettes.roto.frames_to_check`) of
    ``project``'s segmentation as saved beside project file ``path``, read without its masks;
    None when no engine of ``project``'s inputs with its frames' states is there (never an
    error, as :func:`read_engine`)."""

    def states(doc: JsonValue, side: Path) -> tuple[int, ...] | None:
        if not doc.key("arrays").has("states"):
            return None
        n = doc.key("n_frames").integer(lo=1, hi=MAX_ENGINE_FRAMES)
        return frames_to_check(_frame_states(_array(doc, side, "states", "f", 2), n),
                               None if project.silhouettes is None
                               else project.silhouettes.areas())

    return _read_matching(path, engine_fingerprint(project), states)


def _read_matching(path: str | os.PathLike, fingerprint: str,
                   read: Callable[[JsonValue, Path], T | None]) -> T | None:
    """``read(doc, folder)`` of the engine saved beside project file ``path`` when its
    fingerprint is ``fingerprint``; None when there is none, or it is of other inputs,
    another version, or damaged."""
    side = sidecar_dir(Path(path).absolute())
    try:
        doc = _engine_doc(side)
        if doc is None or doc.key("fingerprint").text(max_len=128) != fingerprint:
            return None
        return read(doc, side)
    except (GaitInputError, OSError, ValueError):
        return None


def engine_saved(path: str | os.PathLike, fingerprint: str) -> bool:
    """True when an engine of ``fingerprint`` is named beside project file ``path`` (its
    arrays are not read)."""
    return _read_matching(path, fingerprint, lambda _doc, _side: True) is not None


def remove_engine(path: str | os.PathLike) -> None:
    """Delete the engine saved beside project file ``path``, if any."""
    side = sidecar_dir(Path(path).absolute())
    if side.is_dir():
        (side / ENGINE_FILE).unlink(missing_ok=True)
        _remove_arrays(side, keep=set())


def _engine_doc(side: Path) -> JsonValue | None:
    if not (side / ENGINE_FILE).is_file():
        return None
    doc = read_json(side / ENGINE_FILE, what="segmentation engine",
                    max_bytes=MAX_ENGINE_JSON_BYTES)
    if not doc.has("format") or doc.key("format").value != ENGINE_FORMAT:
        return None
    return doc if doc.key("version").value == ENGINE_VERSION else None


def _read(doc: JsonValue, side: Path) -> RotoState:
    n = doc.key("n_frames").integer(lo=1, hi=MAX_ENGINE_FRAMES)
    w = doc.key("work")
    wh = w.key("wh").integers(length=2, lo=1, hi=MAX_SIDE_PX)
    shape = w.key("shape").integers(length=2, lo=1, hi=MAX_SIDE_PX)
    work = WorkingSize(w.key("scale").number(lo=0, lo_open=True, hi=1), (wh[0], wh[1]),
                       (shape[0], shape[1]), w.key("subject_side").number(lo=0, hi=MAX_SIDE_PX))
    names = [("table", "f", 2), ("bits", "u", 1)]
    names += [(name, kind, ndim) for name, kind, ndim in (("still", "u", 3), ("states", "f", 2))
              if doc.key("arrays").has(name)]
    arrays = {name: _array(doc, side, name, kind, ndim) for name, kind, ndim in names}
    table, bits = arrays["table"], arrays["bits"]
    if table.shape[1:] != (7,) or bits.dtype != np.uint8:
        raise GaitInputError("the engine's table has the wrong width")
    masks, start = {}, 0
    for i, name in enumerate(STORES):
        rows = table[table[:, 0] == i, 1:]
        w_h = np.nan_to_num(rows[:, 3:5]).astype(np.int64)  # from_arrays checks them
        used = int(((w_h[:, 0] * w_h[:, 1] + 7) // 8).sum())
        masks[name] = PackedMasks.from_arrays((wh[1], wh[0]), rows, bits[start : start + used],
                                              n_frames=n)
        start += used
    if start != len(bits) or sum(len(m.frames) for m in masks.values()) != len(table):
        raise GaitInputError("the engine's masks do not add up")
    still = None
    if "still" in arrays:
        both = arrays["still"]
        if both.shape != (wh[1], wh[0], 4) or both.dtype != np.uint8 or both[..., 3].max() > 1:
            raise GaitInputError("the engine's still background is not of its working size")
        still = StillBackground(np.ascontiguousarray(both[..., :3]), both[..., 3] > 0)
    states = _frame_states(arrays["states"], n) if "states" in arrays else ()
    return RotoState(n, work, masks["keys"], masks["fwd"], masks["bwd"], masks["turned"], still,
                     states)


def _array(doc: JsonValue, side: Path, name: str, kind: str, ndim: int) -> np.ndarray:
    """The engine array ``name`` that ``doc`` names, checked against its name's hash."""
    file = doc.key("arrays").key(name).text()
    if not _ENGINE_ARRAY.match(file):
        raise doc.key("arrays").key(name).fail("the name of an engine array")
    arr = read_npy(side / file, what="segmentation engine array", kind=kind, ndim=ndim,
                   max_bytes=MAX_ENGINE_ARRAY_BYTES)
    if array_file(f"engine-{name}", arr)[0] != file:
        raise GaitInputError(f"{file} does not hold what its name says: it is damaged")
    return arr


def _frame_states(arr: np.ndarray, n: int) -> tuple[FrameState, ...]:
    """Every frame's state from the (lost, corrected, confidence) rows of ``arr``."""
    if (arr.shape != (n, 3) or not np.isin(arr[:, :2], (0.0, 1.0)).all()
            or not ((arr[:, 2] >= 0) & (arr[:, 2] <= 1)).all()):
        raise GaitInputError("the engine's frame states are not one (lost, corrected, "
                             "confidence) row per frame")
    return tuple(FrameState(bool(lost), bool(fixed), float(conf)) for lost, fixed, conf in arr)


def _remove_arrays(side: Path, *, keep: set[str]) -> None:
    for f in side.iterdir():
        if _ENGINE_ARRAY.match(f.name) and f.name not in keep:
            f.unlink(missing_ok=True)
