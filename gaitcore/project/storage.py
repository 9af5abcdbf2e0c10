"""Read and write Gait Studio projects: one JSON file plus a sidecar folder of arrays.

``horse.gaitproj`` holds everything small (footage path, rectangles, strokes, settings, keys)
as JSON with ``"format"`` and ``"version"``; ``horse.gaitproj.d/`` beside it holds the
silhouette arrays as ``.npy`` files named after their content (the crops packed 8 pixels to a
byte since version 2; version 1 files, with one byte per pixel, are still read). Saving is atomic: arrays are
written first (temporary file, fsync, rename), then the JSON the same way, then arrays no
longer referenced are removed, so a crash at any point leaves a readable project.

The footage path is stored relative to the project file (and absolute as a fallback), so a
project folder can be moved with its clip. Arrays are read with ``allow_pickle=False``: a
project file is data, never code.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
from dataclasses import asdict
from pathlib import Path

import numpy as np

from gaitcore.analysis.analyze import AnalysisSettings
from gaitcore.errors import GaitInputError
from gaitcore.project.document import AnimationOptions, FootageFit, Project, Silhouettes
from gaitcore.rig.proportions import RigProportions
from gaitcore.rig.skeleton import Skeleton
from gaitcore.silhouettes.annotations import Rect, Stroke
from gaitcore.silhouettes.tracking import RoiClip

FORMAT = "gaitstudio-project"
VERSION = 2
SUFFIX = ".gaitproj"
_ARRAY_NAME = re.compile(r"^(crops|crops_packed|centers_xy|lost)-[0-9a-f]{16}\.npy$")


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
    """
    p = Path(path).absolute()
    if p.exists():
        _refuse_newer(p)
    side = sidecar_dir(p)
    try:
        side.mkdir(parents=True, exist_ok=True)
        doc = _to_json(project, p.parent, side)
        _write_atomic(p, (json.dumps(doc, indent=1) + "\n").encode("utf-8"))
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
    :func:`missing_footage` reports it (the GUI then asks where the clip went).

    Raises
    ------
    GaitInputError
        Missing file, not a Gait Studio project, a newer format version, damaged JSON or
        arrays. The file is left untouched.
    """
    p = Path(path).absolute()
    doc = _read_doc(p)
    try:
        return _from_json(doc, p)
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        if isinstance(exc, GaitInputError):
            raise
        raise GaitInputError(
            f"project file {p} is damaged ({type(exc).__name__}: {exc}); restore it from a "
            "backup or the recovery copy: Gait Studio did not change it"
        ) from None


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
            "crops_packed": _write_array(side, "crops_packed",
                                         np.packbits(np.asarray(roi.crops, dtype=bool), axis=-1)),
            "centers_xy": _write_array(side, "centers_xy", np.asarray(roi.centers_xy, dtype=np.float64)),
            "lost": _write_array(side, "lost", np.asarray(roi.lost, dtype=bool)),
        }
        sil = {"origin": project.silhouettes.origin, "scale": float(roi.scale),
               "crops_shape": list(roi.crops.shape), "arrays": arrays}
    return {
        "format": FORMAT,
        "version": VERSION,
        "footage": footage,
        "frame_start": project.frame_start,
        "frame_stop": project.frame_stop,
        "fps": project.fps,
        "subject_rects": [list(r.as_tuple()) for r in project.subject_rects],
        "background_rects": [list(r.as_tuple()) for r in project.background_rects],
        "strokes": [
            {"frame": s.frame, "width_px": s.width_px, "points_xy": s.points_xy.tolist()}
            for s in project.strokes
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
    }


def _from_json(doc: dict, p: Path) -> Project:
    footage = None
    if doc["footage"] is not None:
        rel, absolute = doc["footage"].get("relative"), doc["footage"].get("absolute")
        candidates = [(p.parent / rel).resolve()] if rel else []
        candidates += [Path(absolute)] if absolute else []
        if not candidates:
            raise KeyError("footage has neither a relative nor an absolute path")
        footage = next((c for c in candidates if c.exists()), candidates[0])
    settings = dict(doc["settings"])
    for name in ("pinned", "forbidden"):
        settings[name] = tuple(int(f) for f in settings.get(name, ()))
    known = AnalysisSettings.__dataclass_fields__
    sil = doc["silhouettes"]
    return Project(
        footage=footage,
        frame_start=int(doc["frame_start"]),
        frame_stop=None if doc["frame_stop"] is None else int(doc["frame_stop"]),
        fps=None if doc["fps"] is None else float(doc["fps"]),
        subject_rects=tuple(Rect(*r) for r in doc["subject_rects"]),
        background_rects=tuple(Rect(*r) for r in doc["background_rects"]),
        strokes=tuple(Stroke(np.array(s["points_xy"], dtype=np.float64).reshape(-1, 2),
                             s["width_px"], s["frame"]) for s in doc["strokes"]),
        settings=AnalysisSettings(**{k: v for k, v in settings.items() if k in known}),
        alternates=tuple(int(f) for f in doc["alternates"]),
        key_poses={int(k): tuple(v) for k, v in doc["key_poses"].items()},
        silhouettes=None if sil is None else _read_silhouettes(sil, sidecar_dir(p)),
        skeleton=None if doc.get("skeleton") is None else Skeleton.from_json(doc["skeleton"]),
        animation=_options(AnimationOptions, doc.get("animation", {}), "animation options"),
        footage_fit=_options(FootageFit, doc.get("footage_fit", {}), "footage fit"),
        proportions=_options(RigProportions, doc.get("proportions", {}), "rig proportions"),
    )


def _options(cls: type, entry: object, what: str):
    """A small options dataclass (``cls``) from its JSON object.

    Fields absent from ``entry`` keep their defaults (projects saved before they existed);
    each present one must have the type of its default (true/false, or a number).
    """
    if not isinstance(entry, dict):
        raise TypeError(f"{what} must be an object, got {entry!r}")
    defaults, values = cls(), {}
    for name in cls.__dataclass_fields__.keys() & entry.keys():
        value, flag = entry[name], isinstance(getattr(defaults, name), bool)
        if isinstance(value, bool) != flag or not isinstance(value, (bool, int, float)):
            kind = "true or false" if flag else "a number"
            raise TypeError(f"{what}: {name} must be {kind}, got {value!r}")
        values[name] = value
    try:
        return cls(**values)
    except GaitInputError as exc:  # reported as a damaged file, like every bad entry
        raise ValueError(str(exc)) from None


def _read_doc(p: Path) -> dict:
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise GaitInputError(f"project file {p} does not exist: choose another file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise GaitInputError(f"project file {p} cannot be read ({exc}): it is damaged or not "
                             "a Gait Studio project") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise GaitInputError(
            f"project file {p} is damaged (invalid JSON at line {exc.lineno}); restore it from "
            "a backup or the recovery copy: Gait Studio did not change it"
        ) from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise GaitInputError(f"{p} is not a Gait Studio project (no \"format\": \"{FORMAT}\")")
    version = doc.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise GaitInputError(f"project file {p} is damaged: its version {version!r} is not a "
                             "positive integer")
    if version > VERSION:
        raise GaitInputError(
            f"project file {p} was written by a newer Gait Studio (format version {version}; "
            f"this one reads up to {VERSION}): update Gait Studio to open it. The file was not "
            "changed"
        )
    return doc


def _refuse_newer(p: Path) -> None:
    """Raise when ``p`` is a project of a newer version (anything else may be replaced)."""
    try:
        version = json.loads(p.read_text(encoding="utf-8")).get("version")
    except (OSError, UnicodeDecodeError, ValueError, AttributeError):
        return
    if isinstance(version, int) and version > VERSION:
        raise GaitInputError(
            f"{p} holds a project of a newer Gait Studio (format version {version}): it is not "
            "overwritten; save under another name"
        )


# -- arrays ----------------------------------------------------------------------------
def _write_array(side: Path, stem: str, arr: np.ndarray) -> str:
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=False)
    data = buf.getvalue()
    name = f"{stem}-{hashlib.sha256(data).hexdigest()[:16]}.npy"
    if not (side / name).exists():
        _write_atomic(side / name, data)
    return name


def _read_silhouettes(sil: dict, side: Path) -> Silhouettes:
    arrays = sil["arrays"]
    if "crops_packed" in arrays:  # version 2
        n, rows, cols = (int(v) for v in sil["crops_shape"])
        packed = _read_array(side, arrays["crops_packed"], "u", 3)
        if packed.dtype != np.uint8 or packed.shape != (n, rows, -(-cols // 8)):
            raise GaitInputError(f"{side / arrays['crops_packed']} does not hold {n} crops of "
                                 f"{rows} x {cols} pixels: the project is damaged")
        crops = np.unpackbits(packed, axis=-1, count=cols).view(bool)
    else:
        crops = _read_array(side, arrays["crops"], "b", 3)
    centers = _read_array(side, arrays["centers_xy"], "f", 2)
    lost = _read_array(side, arrays["lost"], "b", 1)
    roi = RoiClip(crops=crops, centers_xy=centers, lost=lost, scale=float(sil["scale"]))
    return Silhouettes(roi, str(sil["origin"]))


def _read_array(side: Path, name: str, kind: str, ndim: int) -> np.ndarray:
    if not isinstance(name, str) or not _ARRAY_NAME.match(name):
        raise GaitInputError(f"project array name {name!r} is not one Gait Studio writes: the "
                             "project file is damaged")
    f = side / name
    try:
        arr = np.load(f, allow_pickle=False)
    except FileNotFoundError:
        raise GaitInputError(f"{f} is missing: keep the folder {side.name} beside the project "
                             "file (or restore it from a backup)") from None
    except (OSError, ValueError) as exc:
        raise GaitInputError(f"{f} is damaged ({exc}); restore it from a backup") from None
    if arr.dtype.kind != kind or arr.ndim != ndim:
        raise GaitInputError(f"{f} holds a {arr.ndim}-D {arr.dtype} array, not the expected "
                             "silhouette data: the project is damaged")
    return arr


def _write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, fsync it, rename it over ``path``."""
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
