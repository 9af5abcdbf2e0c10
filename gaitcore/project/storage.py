"""Read and write Gait Studio projects: one JSON file plus a sidecar folder of arrays.

``horse.gaitproj`` holds everything small (footage path, box, rectangles, strokes, brush
strokes, settings, keys)
as JSON with ``"format"`` and ``"version"``; ``horse.gaitproj.d/`` beside it holds the
silhouette arrays as ``.npy`` files named after their content (the crops packed 8 pixels to a
byte since version 2; version 1 files, with one byte per pixel, are still read). Since
version 3, ``frame_start`` and ``frame_stop`` are the trim over the whole footage; older files
are read with the full range. Saving is atomic: arrays are
written first (temporary file, fsync, rename), then the JSON the same way, then arrays no
longer referenced are removed, so a crash at any point leaves a readable project.

The footage path is stored relative to the project file (and absolute as a fallback), so a
project folder can be moved with its clip. Arrays are read with ``allow_pickle=False``: a
project file is data, never code.
"""

from __future__ import annotations

import hashlib
import io
import os
import re
from dataclasses import asdict
from pathlib import Path

import numpy as np

from gaitcore.analysis.analyze import AnalysisSettings
from gaitcore.errors import GaitInputError
from gaitcore.project.document import ORIGINS, AnimationOptions, FootageFit, Project, Silhouettes
from gaitcore.rig.proportions import RigProportions
from gaitcore.rig.skeleton import Skeleton
from gaitcore.schema import MAX_FPS, MIN_FPS, JsonValue, check_path, dump_json, read_json, read_npy
from gaitcore.silhouettes.annotations import SCRIBBLE_LABELS, Rect, Scribble, Stroke
from gaitcore.silhouettes.settings import (
    SegmentationSettings,
    settings_from_dict,
    settings_to_dict,
)
from gaitcore.silhouettes.tracking import RoiClip

FORMAT = "gaitstudio-project"
VERSION = 3
SUFFIX = ".gaitproj"
_ADVICE = ("the file is damaged: restore it from a backup or the recovery copy (Gait Studio "
           "did not change it)")
MAX_PROJECT_BYTES = 1 << 30
MAX_ARRAY_BYTES = 16 << 30
MAX_FRAME = 10**8
"""Largest frame number a project may name (a day of footage at 1,000 fps)."""
MAX_PIXELS = 1 << 20
MAX_RECTS = 1_000
"""Rectangles per kind: a few seed the colour models; thousands are a damaged file."""
MAX_STROKES = 20_000
"""Strokes in a project: a thousand sketched frames of twenty strokes. 200,000 took the
window 20 s to open; a file with more is refused with this limit named."""
MAX_STROKE_POINTS = 100_000
MAX_KEYS = 64
MAX_FRAME_LIST = 100_000
MAX_CHANNELS = 6 * 100_000
_TEMPORARY = re.compile(r"^\.(.+)\.[0-9]+\.tmp$")
_ARRAY_NAME = re.compile(r"^(crops|crops_packed|centers_xy|lost|edges)-[0-9a-f]{16}\.npy$")


def sidecar_dir(path: str | os.PathLike) -> Path:
    """The folder of arrays that goes with project file ``path`` (``<name>.d``)."""
    p = Path(path)
    return p.with_name(p.name + ".d")


def missing_footage(project: Project) -> Path | None:
    """The project's footage path when it does not exist (moved or deleted), else None."""
    if project.footage is None or project.footage.exists():
        return None
    return project.footage


def save_project(project: Project, path: str | os.PathLike) -> None:
    """Write ``project`` to ``path`` (JSON) and its sidecar folder, atomically.

    Parameters
    ----------
    project : Project
    path : str or PathLike
        Usually ending in ``.gaitproj``.

    Raises
    ------
    GaitInputError
        When ``path`` holds a project of a newer format version (it is never overwritten) or
        the folder cannot be written.

    Notes
    -----
    Temporary files left by a save that was killed (``.<name>.<pid>.tmp`` of another
    process) are removed first; two processes saving the same project at once are not
    supported.
    """
    p = Path(path).absolute()
    if p.exists():
        _refuse_newer(p)
    side = sidecar_dir(p)
    try:
        side.mkdir(parents=True, exist_ok=True)
        _remove_stale_temporaries(p, side)
        doc = _to_json(project, p.parent, side)
        write_atomic(p, (dump_json(doc, indent=1, what=f"project {p}") + "\n").encode("utf-8"))
        keep = set(doc["silhouettes"]["arrays"].values()) if doc["silhouettes"] else set()
        for f in side.iterdir():
            if _ARRAY_NAME.match(f.name) and f.name not in keep:
                f.unlink()
    except OSError as exc:
        raise GaitInputError(f"cannot save the project to {p}: {exc.strerror or exc}; "
                             "choose a folder you can write to") from None


def load_project(path: str | os.PathLike) -> Project:
    """Read a project written by :func:`save_project`.

    The footage path is resolved relative to the project file first, then as the absolute
    path it had when saved; when neither exists the relative one is kept and
    :func:`missing_footage` reports it (the GUI then asks where the clip went). Every value is
    checked (type, finiteness, range, size) before it is used, so a damaged file fails here
    rather than later in the window.

    Raises
    ------
    GaitInputError
        Missing file, not a Gait Studio project, a newer format version, damaged JSON or
        arrays, or a value out of place (the message names it, e.g. ``strokes[3].width_px``).
        The file is left untouched.
    """
    p = Path(path).absolute()
    doc = _read_doc(p)
    try:
        return _from_json(doc, p)
    except GaitInputError as exc:
        message = str(exc)
        if str(p) in message:
            raise
        raise GaitInputError(f"project file {p}: {message}; {_ADVICE}") from None


# -- JSON documents --------------------------------------------------------------------
def _to_json(project: Project, base: Path, side: Path) -> dict:
    footage = None
    if project.footage is not None:
        absolute = project.footage.absolute()
        try:
            relative = Path(os.path.relpath(absolute, base)).as_posix()
        except ValueError:  # another drive (Windows): only the absolute path works
            relative = None
        footage = {"relative": relative, "absolute": str(absolute)}
    sil = None
    if project.silhouettes is not None:
        roi = project.silhouettes.roi
        arrays = {
            "crops_packed": write_array(side, "crops_packed",
                                        np.packbits(np.asarray(roi.crops, dtype=bool), axis=-1)),
            "centers_xy": write_array(side, "centers_xy",
                                      np.asarray(roi.centers_xy, dtype=np.float64)),
            "lost": write_array(side, "lost", np.asarray(roi.lost, dtype=bool)),
        }
        if roi.edges is not None:
            arrays["edges"] = write_array(side, "edges", np.asarray(roi.edges, dtype=np.uint8))
        sil = {"origin": project.silhouettes.origin, "scale": float(roi.scale),
               "crops_shape": list(roi.crops.shape), "arrays": arrays}
    return {
        "format": FORMAT,
        "version": VERSION,
        "footage": footage,
        "frame_start": project.frame_start,
        "frame_stop": project.frame_stop,
        "fps": project.fps,
        "box": None if project.box is None else list(project.box.as_tuple()),
        "subject_rects": [list(r.as_tuple()) for r in project.subject_rects],
        "background_rects": [list(r.as_tuple()) for r in project.background_rects],
        "strokes": [
            {"frame": s.frame, "width_px": s.width_px, "points_xy": s.points_xy.tolist()}
            for s in project.strokes
        ],
        "scribbles": [
            {"frame": s.frame, "label": s.label, "width_px": s.width_px,
             "points_xy": s.points_xy.tolist()}
            for s in project.scribbles
        ],
        "settings": {k: list(v) if isinstance(v, tuple) else v
                     for k, v in asdict(project.settings).items()},
        "alternates": list(project.alternates),
        "key_poses": {str(k): list(v) for k, v in sorted(project.key_poses.items())},
        "skeleton": None if project.skeleton is None else project.skeleton.to_dict(),
        "silhouettes": sil,
        "animation": asdict(project.animation),
        "footage_fit": asdict(project.footage_fit),
        "proportions": asdict(project.proportions),
        "segmentation": settings_to_dict(project.segmentation),
    }


def _from_json(doc: JsonValue, p: Path) -> Project:
    sil = doc.key("silhouettes", None)
    skeleton = doc.key("skeleton", None)
    start = doc.key("frame_start").integer(lo=0, hi=MAX_FRAME)
    stop = doc.key("frame_stop").integer(lo=1, hi=MAX_FRAME, optional=True)
    if doc.key("version").value < 3:  # the range cut the footage itself and no editor set it
        start, stop = 0, None
    return Project(
        footage=_footage(doc.key("footage"), p),
        frame_start=start,
        frame_stop=stop,
        fps=doc.key("fps").number(lo=MIN_FPS, hi=MAX_FPS, optional=True),
        box=_box(doc.key("box", None)),
        subject_rects=_rects(doc.key("subject_rects")),
        background_rects=_rects(doc.key("background_rects")),
        strokes=tuple(_stroke(s) for s in doc.key("strokes").items(max_len=MAX_STROKES)),
        scribbles=tuple(_scribble(s) for s in doc.key("scribbles", []).items(max_len=MAX_STROKES)),
        settings=_settings(doc.key("settings")),
        alternates=doc.key("alternates").integers(max_len=MAX_KEYS, lo=0, hi=MAX_FRAME),
        key_poses=_key_poses(doc.key("key_poses")),
        silhouettes=None if sil.is_null() else _read_silhouettes(sil, sidecar_dir(p)),
        skeleton=None if skeleton.is_null() else Skeleton.from_json(skeleton),
        animation=_options(AnimationOptions, doc.key("animation", {})),
        footage_fit=_options(FootageFit, doc.key("footage_fit", {})),
        proportions=_options(RigProportions, doc.key("proportions", {})),
        segmentation=(settings_from_dict(doc.key("segmentation")) if doc.has("segmentation")
                      else SegmentationSettings()),
    )


def _footage(entry: JsonValue, p: Path) -> Path | None:
    if entry.is_null():
        return None
    rel = entry.key("relative", None).text(optional=True)
    absolute = entry.key("absolute", None).text(optional=True)
    if not (rel or absolute):
        raise entry.fail("an object with a relative or an absolute path")
    try:  # a NUL byte, a name not UTF-8, a loop of links: refused before any use
        if rel:
            check_path(rel, what="footage")
        candidates = [(p.parent / rel).resolve()] if rel else []
        candidates += [check_path(absolute, what="footage")] if absolute else []
        return next((c for c in candidates if check_path(c, what="footage").exists()),
                    candidates[0])
    except (GaitInputError, OSError, RuntimeError) as exc:
        raise entry.fail(f"a usable path ({exc})") from None


def _rects(entry: JsonValue) -> tuple[Rect, ...]:
    out = []
    for item in entry.items(max_len=MAX_RECTS):
        x, y, w, h = item.integers(length=4, lo=-MAX_PIXELS, hi=MAX_PIXELS)
        if w <= 0 or h <= 0:
            raise item.fail("a rectangle [x, y, w, h] of positive width and height")
        out.append(Rect(x, y, w, h))
    return tuple(out)


def _box(entry: JsonValue) -> Rect | None:
    """The box around the animal, or None (projects saved before it existed have none)."""
    if entry.is_null():
        return None
    x, y, w, h = entry.integers(length=4, lo=-MAX_PIXELS, hi=MAX_PIXELS)
    if w <= 0 or h <= 0:
        raise entry.fail("a box [x, y, w, h] of positive width and height, or null")
    return Rect(x, y, w, h)


def _stroke(entry: JsonValue) -> Stroke:
    points = entry.key("points_xy").array(columns=2, min_rows=1, max_rows=MAX_STROKE_POINTS)
    width = entry.key("width_px").number(lo=0, lo_open=True, hi=MAX_PIXELS)
    return Stroke(points, width, entry.key("frame").integer(lo=0, hi=MAX_FRAME))


def _scribble(entry: JsonValue) -> Scribble:
    """A brush stroke (projects saved before brushes existed have none)."""
    stroke = _stroke(entry)
    label = entry.key("label").text(choices=SCRIBBLE_LABELS)
    return Scribble(stroke.points_xy, stroke.width_px, stroke.frame, label)


def _settings(entry: JsonValue) -> AnalysisSettings:
    """Analysis settings; absent fields keep their defaults, unknown ones are ignored."""
    values = {}
    for name, read in _SETTINGS.items():
        if entry.has(name):
            values[name] = read(entry.key(name))
    return AnalysisSettings(**values)


def _frames(entry: JsonValue) -> tuple[int, ...]:
    return entry.integers(max_len=MAX_FRAME_LIST, lo=0, hi=MAX_FRAME)


_SETTINGS = {
    "pcs": lambda v: v.integer(lo=1, hi=MAX_KEYS),
    "keys": lambda v: v.integer(lo=1, hi=MAX_KEYS),
    "switching": JsonValue.boolean,
    "alpha": lambda v: v.number(lo=0, lo_open=True, hi=1e6),
    "max_side_px": lambda v: v.integer(lo=8, hi=MAX_PIXELS, optional=True),
    "stabilize_roi": JsonValue.boolean,
    "key_time_limit_s": lambda v: v.number(lo=0, lo_open=True, hi=1e9, optional=True),
    "pinned": _frames,
    "forbidden": _frames,
    "bring_back": _frames,
}
"""How each field of AnalysisSettings is read."""


def _key_poses(entry: JsonValue) -> dict[int, tuple[float, ...]]:
    poses = {}
    for key, pose in entry.entries(max_len=MAX_FRAME_LIST):
        if not (key.isascii() and key.isdigit() and len(key) <= 10):
            raise pose.fail("the pose of a frame keyed by its number (a whole number from 0)")
        poses[int(key)] = tuple(pose.array(max_rows=MAX_CHANNELS).tolist())
    return poses


def _options(cls: type, entry: JsonValue):
    """A small options dataclass (``cls``) from its JSON object.

    Fields absent from ``entry`` keep their defaults (projects saved before they existed);
    each present one must have the type of its default (true/false, a finite number, or a
    string).
    """
    defaults, values = cls(), {}
    for name, value in entry.entries(max_len=len(cls.__dataclass_fields__) + 64):
        if name in cls.__dataclass_fields__:
            default = getattr(defaults, name)
            if isinstance(default, bool):
                values[name] = value.boolean()
            elif isinstance(default, str):
                values[name] = value.text(max_len=64)
            else:
                values[name] = value.number()
    try:
        return cls(**values)
    except GaitInputError as exc:
        raise entry.fail(f"valid ({exc})") from None


def _read_doc(p: Path) -> JsonValue:
    doc = read_json(p, what="project file", max_bytes=MAX_PROJECT_BYTES, advice=_ADVICE)
    if not doc.has("format") or doc.key("format").value != FORMAT:
        raise GaitInputError(f"{p} is not a Gait Studio project (no \"format\": \"{FORMAT}\")")
    version = doc.key("version")
    if not isinstance(version.value, int) or isinstance(version.value, bool) or version.value < 1:
        raise version.fail("a positive integer")
    if version.value > VERSION:
        raise GaitInputError(
            f"project file {p} was written by a newer Gait Studio (format version "
            f"{version.value}; this one reads up to {VERSION}): update Gait Studio to open it. "
            "The file was not changed"
        )
    return doc


def _refuse_newer(p: Path) -> None:
    """Raise when ``p`` is a project of a newer version (anything else may be replaced)."""
    try:
        doc = read_json(p, what="project file", max_bytes=MAX_PROJECT_BYTES)
    except GaitInputError:  # unreadable, or not a regular file: replaced like any other
        return
    version = doc.value.get("version") if isinstance(doc.value, dict) else None
    if isinstance(version, int) and version > VERSION:
        raise GaitInputError(
            f"{p} holds a project of a newer Gait Studio (format version {version}): it is not "
            "overwritten; save under another name"
        )


# -- arrays ----------------------------------------------------------------------------
def write_array(side: Path, stem: str, arr: np.ndarray) -> str:
    """Write ``arr`` into folder ``side`` as ``<stem>-<hash of its content>.npy`` (atomically,
    unless a file of that name, hence that content, is there already); returns the name."""
    name, data = array_file(stem, arr)
    if not (side / name).exists():
        write_atomic(side / name, data)
    return name


def array_file(stem: str, arr: np.ndarray) -> tuple[str, bytes]:
    """The name :func:`write_array` gives ``arr`` and the bytes it writes (a reader that
    computes the name again from the array it read sees any damage that kept it readable)."""
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=False)
    data = buf.getvalue()
    return f"{stem}-{hashlib.sha256(data).hexdigest()[:16]}.npy", data


def _read_silhouettes(sil: JsonValue, side: Path) -> Silhouettes:
    arrays = sil.key("arrays")
    if arrays.has("crops_packed"):  # version 2
        n, rows, cols = sil.key("crops_shape").integers(length=3, lo=1, hi=MAX_PIXELS)
        packed = _read_array(side, arrays.key("crops_packed"), "u", 3)
        if packed.dtype != np.uint8 or packed.shape != (n, rows, -(-cols // 8)):
            raise GaitInputError(f"{side / arrays.key('crops_packed').value} does not hold {n} "
                                 f"crops of {rows} x {cols} pixels: the project is damaged")
        crops = np.unpackbits(packed, axis=-1, count=cols).view(bool)
    else:
        crops = _read_array(side, arrays.key("crops"), "b", 3)
    centers = _read_array(side, arrays.key("centers_xy"), "f", 2)
    lost = _read_array(side, arrays.key("lost"), "b", 1)
    if centers.shape == (len(lost), 2) and not np.all(np.isfinite(centers[~lost])):
        raise GaitInputError(f"{side / arrays.key('centers_xy').value} holds a centre that is not "
                             "a finite number on a frame where the subject was found: the "
                             "project is damaged")
    edges = None
    if arrays.has("edges"):  # projects saved before the frame's sides were kept have none
        edges = _read_array(side, arrays.key("edges"), "u", 1)
        if edges.dtype != np.uint8 or edges.max(initial=0) > 15:
            raise GaitInputError(f"{side / arrays.key('edges').value} does not hold one set of "
                                 "frame sides per frame: the project is damaged")
    scale = sil.key("scale").number(lo=0, lo_open=True, hi=MAX_PIXELS)
    origin = sil.key("origin").text(choices=ORIGINS)
    return Silhouettes(RoiClip(crops=crops, centers_xy=centers, lost=lost, scale=scale,
                               edges=edges), origin)


def _read_array(side: Path, name: JsonValue, kind: str, ndim: int) -> np.ndarray:
    text = name.text()
    if not _ARRAY_NAME.match(text):
        raise name.fail("the name of an array Gait Studio writes")
    if not side.is_dir():
        raise GaitInputError(f"{side / text} is missing: keep the folder {side.name} beside the "
                             "project file (or restore it from a backup)")
    try:
        return read_npy(side / text, what="project array", kind=kind, ndim=ndim,
                        max_bytes=MAX_ARRAY_BYTES)
    except GaitInputError as exc:
        if "not found" not in str(exc):
            raise
        raise GaitInputError(f"{side / text} is missing: keep the folder {side.name} beside the "
                             "project file (or restore it from a backup)") from None


def _remove_stale_temporaries(p: Path, side: Path) -> None:
    """Delete what killed saves of ``p`` left: temporary files of other processes."""
    ours = f".{os.getpid()}.tmp"
    for folder, names in ((p.parent, lambda n: n == p.name), (side, _ARRAY_NAME.match)):
        for f in folder.glob(".*.tmp"):
            m = _TEMPORARY.match(f.name)
            if m and names(m.group(1)) and not f.name.endswith(ours) and f.is_file():
                f.unlink(missing_ok=True)


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, fsync it, rename it over ``path``.

    The temporary file is ``.<name>.<pid>.tmp``; a crash leaves it behind, and the next
    :func:`save_project` of the same project removes it.
    """
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    try:
        fd = os.open(path.parent, os.O_RDONLY)
    except OSError:  # directories cannot be opened on some systems (Windows)
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
