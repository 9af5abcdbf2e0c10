"""The manifest of a batch: one CSV row per clip to analyse (``gaitcore batch``).

A manifest is a CSV file with a header row. Columns (only ``path`` is required; the order
is free)::

    clip,path,box,subject,background,start,stop,fps
    horse-01,clips/horse01.mp4,"120,80,200,140",,,0,240,
    ,masks/walk,,,,,,

- ``path``: a video file, a folder of images or a folder of binary masks, relative to the
  manifest's folder or absolute.
- ``clip``: the clip's id, which names its output folder; by default the path relative to
  the manifest's folder with ``/`` turned into ``-`` and the suffix dropped.
- ``box``: ``x,y,w,h`` around the animal on the first frame of the clip (colour footage).
- ``subject``, ``background``: the artist's rectangles instead of a box, ``x,y,w,h``
  separated by ``;``.
- ``start``, ``stop``: source frames ``start <= f < stop`` (the trim); ``fps``: the frame
  rate when the file has none.

A row that cannot be used (missing file, malformed box, a value in an unknown column...)
is reported with one line naming its line number; the other rows run.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

from gaitcore.errors import GaitInputError
from gaitcore.schema import MiB, check_fps, check_path, read_text
from gaitcore.silhouettes.annotations import Rect

COLUMNS = ("clip", "path", "box", "subject", "background", "start", "stop", "fps")
"""The columns a manifest may have; ``path`` is required."""
MAX_MANIFEST_BYTES = 256 * MiB
"""Largest manifest read (a million clips with their rectangles)."""
_SAFE_ID = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.@+-]*$")


@dataclass(frozen=True)
class ClipSpec:
    """One clip of a batch, as its manifest row asks.

    Attributes
    ----------
    clip : str
        Id of the clip, unique in the batch; its outputs go to ``OUT/<clip>/``.
    path : Path
        Absolute path of the video file, image folder or mask folder.
    box : Rect or None
        Box around the animal on the first frame of the clip (colour footage).
    subject, background : tuple of Rect
        Rectangles on the first frame instead of a box (paper Section 2.2).
    start, stop : int, int or None
        The trim: source frames ``start <= f < stop`` (None: to the end).
    fps : float or None
        Frame rate to use instead of the file's.
    line : int
        Line of the manifest the clip comes from (for messages; not part of its identity).
    """

    clip: str
    path: Path
    box: Rect | None = None
    subject: tuple[Rect, ...] = ()
    background: tuple[Rect, ...] = ()
    start: int = 0
    stop: int | None = None
    fps: float | None = None
    line: int = field(default=0, compare=False)

    def to_dict(self) -> dict:
        """The row as plain JSON values (what :func:`spec_from_dict` reads back)."""
        return {
            "clip": self.clip, "path": str(self.path),
            "box": _rects_text((self.box,) if self.box else ()),
            "subject": _rects_text(self.subject), "background": _rects_text(self.background),
            "start": self.start, "stop": self.stop, "fps": self.fps,
        }


@dataclass(frozen=True)
class RowProblem:
    """A manifest row that cannot run: its line number, one line saying why, its path cell."""

    line: int
    message: str
    path: str = ""

    def __str__(self) -> str:
        return f"line {self.line}: {self.message}"


@dataclass(frozen=True)
class Manifest:
    """The clips of a manifest and its rows that cannot run.

    Attributes
    ----------
    path : Path
    clips : tuple of ClipSpec
        In manifest order.
    problems : tuple of RowProblem
    """

    path: Path
    clips: tuple[ClipSpec, ...]
    problems: tuple[RowProblem, ...]


def read_manifest(path: str | Path) -> Manifest:
    """Read a batch manifest (see the module docstring for its columns).

    Rows are checked one by one: a bad row becomes a :class:`RowProblem` and the others
    are kept.

    Raises
    ------
    GaitInputError
        The file cannot be read as CSV, has no ``path`` column, or has no rows.
    """
    path = Path(path)
    text = read_text(path, what="manifest", max_bytes=MAX_MANIFEST_BYTES, encoding="utf-8-sig")
    try:
        rows = list(csv.reader(io.StringIO(text, newline="")))
    except csv.Error as exc:
        raise GaitInputError(f"cannot read the manifest {path}: {exc}; give a CSV file "
                             "with a header row (path,box,start,stop,fps)") from None
    header = [h.strip().lower() for h in rows[0]] if rows else []
    if "path" not in header:
        raise GaitInputError(f"manifest {path} has no 'path' column: its first row must name "
                             f"the columns, among {', '.join(COLUMNS)}")
    body = [(n, r) for n, r in enumerate(rows[1:], start=2)
            if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not body:
        raise GaitInputError(f"manifest {path} has no clips: add one row per clip under the header")
    clips: list[ClipSpec] = []
    problems: list[RowProblem] = []
    seen: dict[str, int] = {}
    for line, cells in body:
        try:
            spec = _parse_row(header, cells, line, path.parent)
            if spec.clip in seen:
                raise GaitInputError(f"clip id {spec.clip!r} repeats line {seen[spec.clip]}: "
                                     "give the rows distinct values in a 'clip' column")
        except GaitInputError as exc:
            cell = cells[header.index("path")].strip() if len(cells) > header.index("path") else ""
            problems.append(RowProblem(line, str(exc), cell))
            continue
        seen[spec.clip] = line
        clips.append(spec)
    return Manifest(path, tuple(clips), tuple(problems))


def _parse_row(header: list[str], cells: list[str], line: int, base: Path) -> ClipSpec:
    if len(cells) > len(header) and any(c.strip() for c in cells[len(header):]):
        raise GaitInputError(f"{len(cells)} cells but the header has {len(header)} columns")
    row = {h: c.strip() for h, c in zip(header, cells)}
    unknown = [h for h, v in row.items() if v and h not in COLUMNS]
    if unknown:
        raise GaitInputError(f"unknown column {unknown[0]!r} (a manifest has {', '.join(COLUMNS)})")
    if not row.get("path"):
        raise GaitInputError("no path: give the video file or image folder of the clip")
    try:
        given = Path(row["path"]).expanduser()
    except RuntimeError:  # ~user of no such user: the name as it is
        given = Path(row["path"])
    clip_path = check_path(given if given.is_absolute() else base / given, what="clip path")
    if not clip_path.exists():
        raise GaitInputError(f"{row['path']} does not exist (looked for {clip_path})")
    box = _rects(row.get("box", ""), "box")
    if len(box) > 1:
        raise GaitInputError(f"box {row['box']!r} holds {len(box)} rectangles: give one x,y,w,h")
    subject, background = (_rects(row.get("subject", ""), "subject"),
                           _rects(row.get("background", ""), "background"))
    if box and (subject or background):
        raise GaitInputError("give a box or subject/background rectangles, not both")
    start, stop = _int(row.get("start", ""), "start", 0), _int(row.get("stop", ""), "stop", None)
    if stop is not None and stop <= start:
        raise GaitInputError(f"stop {stop} is not after start {start}: the trim is empty")
    return ClipSpec(
        clip=_clip_id(row.get("clip", ""), clip_path, base), path=clip_path.absolute(),
        box=box[0] if box else None, subject=subject, background=background,
        start=start or 0, stop=stop, fps=_fps(row.get("fps", "")), line=line,
    )


def _rects(text: str, what: str) -> tuple[Rect, ...]:
    if not isinstance(text, str):
        raise GaitInputError(f"{what} {text!r} is not text of rectangles x,y,w,h")
    rects = []
    for part in (p for p in text.split(";") if p.strip()):
        values = part.replace(",", " ").split()
        try:
            rects.append(Rect(*(int(v) for v in values)) if len(values) == 4 else None)
        except (ValueError, TypeError):
            rects.append(None)
        if rects[-1] is None:
            raise GaitInputError(f"{what} {part.strip()!r} is not four integers x,y,w,h in pixels")
    return tuple(rects)


def _rects_text(rects: tuple[Rect, ...]) -> str:
    return ";".join(",".join(map(str, r.as_tuple())) for r in rects)


def _int(text: str, what: str, default: int | None) -> int | None:
    if not text:
        return default
    try:
        value = int(text)
    except ValueError:
        raise GaitInputError(f"{what} {text!r} is not a frame number") from None
    if value < 0:
        raise GaitInputError(f"{what} {value} is negative: frames count from 0")
    return value


def _fps(text: str) -> float | None:
    if not text:
        return None
    try:
        value = float(text)
    except ValueError:
        raise GaitInputError(f"fps {text!r} is not a number of frames per second") from None
    return check_fps(value, what="fps")


LOCK_NAME = "batch.lock"
"""The file a running batch holds locked in its output folder."""
RESERVED_IDS = ("summary.csv", "summary.json", LOCK_NAME)
"""Names the batch gives its own files in the output folder: no clip folder may take them."""
MAX_ID_CHARS = 200
"""The longest clip id (a folder name, with room for the batch's suffixes)."""


def is_clip_id(text: str) -> bool:
    """True when ``text`` can name a clip's folder in a batch's output folder."""
    return (bool(_SAFE_ID.match(text)) and len(text) <= MAX_ID_CHARS + len("-clip")
            and text.lower() not in RESERVED_IDS)


def _clip_id(given: str, clip_path: Path, base: Path) -> str:
    if given:
        if not _SAFE_ID.match(given) or len(given) > MAX_ID_CHARS:
            raise GaitInputError(f"clip id {given[:40]!r} cannot name a folder: use up to "
                                 f"{MAX_ID_CHARS} letters, digits, and . _ - + @ (not first)")
        if given.lower() in RESERVED_IDS:
            raise GaitInputError(f"clip id {given!r} is the name of the batch's own file: "
                                 "choose another")
        return given
    try:
        rel = clip_path.absolute().relative_to(base.absolute())
    except ValueError:
        rel = Path(clip_path.name)
    stem = rel.with_suffix("") if rel.suffix and not clip_path.is_dir() else rel
    text = re.sub(r"[^A-Za-z0-9_.@+-]+", "-", stem.as_posix()).strip("-.")[-MAX_ID_CHARS:]
    text = text.strip("-.") or "clip"
    return f"{text}-clip" if text.lower() in RESERVED_IDS else text


def spec_from_dict(d: dict) -> ClipSpec:
    """The :class:`ClipSpec` of :meth:`ClipSpec.to_dict` (or of a summary row).

    Raises
    ------
    GaitInputError
        For a malformed entry.
    """
    try:
        box = _rects(d.get("box") or "", "box")
        stop = d.get("stop")
        fps = d.get("fps")
        return ClipSpec(
            clip=str(d["clip"]), path=Path(d["path"]), box=box[0] if box else None,
            subject=_rects(d.get("subject") or "", "subject"),
            background=_rects(d.get("background") or "", "background"),
            start=int(d.get("start") or 0), stop=None if stop in (None, "") else int(stop),
            fps=None if fps in (None, "") else float(fps),
        )
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, GaitInputError):
            raise
        raise GaitInputError(f"clip entry {d!r} is malformed ({exc})") from None
