"""Scribbles files: the artist's corrective strokes, and ``segmentation.json``, what the
segmentation says of each frame.

Scribbles: ``{"scribbles": [{"frame": 12, "label": "subject", "width": 8,
"points": [[x, y], ...]}, ...]}`` with ``label`` "subject" or "background", points in source
pixels, 0-based frames. ``segmentation.json``: ``{"format": "gaitstudio-segmentation",
"n_frames": n, "frames": [{"frame": 0, "lost": false, "corrected": false,
"confidence": 1.0}, ...]}`` (confidence: see
:class:`~gaitcore.silhouettes.roto.FrameState`). Both are plain JSON, written atomically.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from gaitcore.errors import GaitInputError
from gaitcore.schema import dump_json, read_json
from gaitcore.silhouettes.annotations import SCRIBBLE_LABELS, Scribble
from gaitcore.silhouettes.roto import FrameState

SEGMENTATION_FORMAT = "gaitstudio-segmentation"


def scribbles_from_dict(data: object, *, where: str = "scribbles",
                        n_frames: int | None = None) -> list[Scribble]:
    """Check parsed scribbles JSON and turn it into :class:`Scribble` values.

    Raises
    ------
    GaitInputError
        Not a ``{"scribbles": [...]}`` object, a missing or malformed field, an unknown label,
        a frame outside ``0 .. n_frames-1`` (when ``n_frames`` is given).
    """
    if not isinstance(data, dict) or not isinstance(data.get("scribbles"), list):
        raise GaitInputError(f"{where}: expected an object {{\"scribbles\": [...]}}")
    out = []
    for i, item in enumerate(data["scribbles"]):
        if not isinstance(item, dict):
            raise GaitInputError(f"{where}: scribble {i} is not an object")
        label = item.get("label")
        if label not in SCRIBBLE_LABELS:
            raise GaitInputError(f"{where}: scribble {i} has label {label!r}: use 'subject' or "
                                 "'background'")
        try:
            frame, width, points = item["frame"], item.get("width", 8), item["points"]
            if isinstance(frame, bool) or not isinstance(frame, int):
                raise TypeError(f"frame {frame!r} is not a whole number")
            scribble = Scribble(points, float(width), frame, label)
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            raise GaitInputError(f"{where}: scribble {i} is malformed ({exc}): give frame, "
                                 "label, width and points [[x, y], ...]") from None
        except GaitInputError as exc:
            raise GaitInputError(f"{where}: scribble {i}: {exc}") from None
        if n_frames is not None and not 0 <= scribble.frame < n_frames:
            raise GaitInputError(f"{where}: scribble {i} is on frame {scribble.frame} but the "
                                 f"clip has {n_frames} frames (0..{n_frames - 1})")
        out.append(scribble)
    return out


MAX_SCRIBBLES_BYTES = 256 << 20
"""The largest scribbles file read (a clip's worth of strokes is a few MiB)."""


def read_scribbles(path: str | Path, *, n_frames: int | None = None) -> list[Scribble]:
    """Read a scribbles file (see the module docstring).

    Raises
    ------
    GaitInputError
        Missing file, malformed JSON or content (one line saying what and where).
    """
    path = Path(path)
    doc = read_json(path, what="scribbles file", max_bytes=MAX_SCRIBBLES_BYTES,
                    advice="write it again, or export the strokes from the app")
    return scribbles_from_dict(doc.value, where=str(path), n_frames=n_frames)


def scribbles_to_dict(scribbles: Sequence[Scribble]) -> dict:
    """The JSON-ready content of a scribbles file."""
    return {"scribbles": [{"frame": sc.frame, "label": sc.label, "width": sc.width_px,
                           "points": sc.points_xy.tolist()} for sc in scribbles]}


def write_scribbles(path: str | Path, scribbles: Sequence[Scribble]) -> None:
    """Write a scribbles file atomically."""
    _write_json(Path(path), scribbles_to_dict(scribbles))


def write_segmentation_json(path: str | Path, states: Sequence[FrameState], *,
                            source: str = "", first_frame: int = 0) -> None:
    """Write ``segmentation.json``: per frame, lost, corrected and confidence.

    ``states[i]`` is of source frame ``first_frame + i``; the file numbers frames by source
    frame, as the masks and the scribbles are.
    """
    _write_json(Path(path), {
        "format": SEGMENTATION_FORMAT, "version": 1, "source": source,
        "n_frames": len(states),
        "frames": [{"frame": first_frame + t, "lost": st.lost, "corrected": st.corrected,
                    "confidence": st.confidence} for t, st in enumerate(states)],
    })


def _write_json(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(dump_json(data, indent=1, what=str(path)), encoding="utf-8")
    tmp.replace(path)
