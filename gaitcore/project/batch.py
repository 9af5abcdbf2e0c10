"""One clip of a batch: analyse it as ``gaitcore analyze`` does, and the batch's summary.

:func:`analyze_clip` is the whole task a batch worker runs for a clip: open the footage
over its trim, get the silhouettes (a folder of masks is tracked; colour footage is
segmented from the rectangles the box stands for), analyse them (PCA, diagnosis,
key-images), and write ``OUT/<clip>/``:

- ``clip.gaitproj`` (and ``clip.gaitproj.d/``): the project, with the footage, its trim,
  the rectangles and the tracked silhouettes, which the app opens as it is;
- ``analysis.json``: as ``gaitcore analyze`` writes it;
- ``result.json``: the clip's summary row, written last.

The folder is built under a temporary name beside its final place and renamed into place
when complete, so a clip folder is either whole or absent. A clip that cannot be analysed
(unreadable, no animal, too short) gets a folder too, whose summary row holds the one-line
error. The summary of the whole batch (``summary.csv`` and ``summary.json``) is a list of
:class:`ClipSummary` rows, in manifest order.

A manifest row's box drives the one-box segmentation and stays in the clip's project, so
that the app opens the clip with it. ``cycle_start``/``cycle_stop`` are the best stretch the
cycle finder ranks.
"""

from __future__ import annotations

import csv
import io
import math
import shutil
import uuid
from dataclasses import dataclass, replace
from pathlib import Path

from gaitcore.analysis.analyze import Analysis, AnalysisSettings
from gaitcore.errors import GaitInputError
from gaitcore.io.analysis_file import write_analysis_json
from gaitcore.project.document import Project
from gaitcore.project.manifest import ClipSpec, is_clip_id, spec_from_dict
from gaitcore.project.steps import analyze, open_source, segment, silhouettes_from_masks
from gaitcore.project.storage import save_project, write_atomic
from gaitcore.schema import MiB, describe, dump_json, parse_json, read_json, read_text
from gaitcore.silhouettes.extract import is_mask_folder
from gaitcore.silhouettes.settings import SegmentationSettings, settings_to_dict

PROJECT_NAME = "clip.gaitproj"
ANALYSIS_NAME = "analysis.json"
RESULT_NAME = "result.json"
SUMMARY_NAMES = ("summary.csv", "summary.json")
STATUSES = ("done", "failed", "pending", "bad row")
"""Analysed; could not be analysed (see ``error``); not run yet; a manifest row that cannot run."""
FORMAT = "gaitstudio-batch"
CLIP_FORMAT = "gaitstudio-batch-clip"
VERSION = 1
_PARTIAL = ".partial-"
SUMMARY_COLUMNS = ("clip", "status", "usable", "verdict", "period", "r1", "r2", "cycle_start",
                   "cycle_stop", "frames", "error", "path", "box", "subject", "background",
                   "start", "stop", "fps")
"""Columns of ``summary.csv`` (and keys of each clip of ``summary.json``)."""
MAX_CLIPS = 1_000_000
"""Most clips a summary may list."""
MAX_RESULT_BYTES = MiB
"""Largest ``result.json`` read back (one summary row)."""
MAX_SUMMARY_BYTES = 1024 * MiB
"""Largest summary read (a million clips)."""


@dataclass(frozen=True)
class ClipSummary:
    """The summary row of one clip of a batch.

    Attributes
    ----------
    clip : str
        Clip id (its output folder's name).
    status : {"done", "failed", "pending", "bad row"}
    source : str
        The footage path (as the manifest gave it for a bad row).
    spec : ClipSpec or None
        The manifest row (None for a bad row).
    frames : int or None
        Frames analysed.
    usable : bool or None
        The paper's verdict (Section 5.2): r1 and r2 at least 0.6.
    verdict : str
        ``usable``, ``try sketching`` or ``not usable``.
    period_frames : float or None
        Period of the silhouettes, frames (half the gait cycle for a symmetric walk).
    r1, r2 : float or None
        Correlations of PC1 and PC2 with their band-passed versions.
    cycle_start, cycle_stop : int or None
        Source frames of the best cycle (today the whole analysed range).
    error : str
        One line: why the clip failed or its row cannot run.
    """

    clip: str
    status: str
    source: str
    spec: ClipSpec | None = None
    frames: int | None = None
    usable: bool | None = None
    verdict: str = ""
    period_frames: float | None = None
    r1: float | None = None
    r2: float | None = None
    cycle_start: int | None = None
    cycle_stop: int | None = None
    error: str = ""

    @property
    def score(self) -> float:
        """The smaller of r1 and r2 (the verdict's weaker PC), -1 when not analysed."""
        return min(self.r1, self.r2) if self.r1 is not None and self.r2 is not None else -1.0

    def project_path(self, out_dir: Path) -> Path | None:
        """The clip's project file under the batch folder ``out_dir``, None if it has none."""
        path = Path(out_dir) / self.clip / PROJECT_NAME
        return path if self.status in ("done", "failed") and path.is_file() else None

    def to_row(self) -> dict:
        """The row as plain values, keyed by :data:`SUMMARY_COLUMNS`."""
        spec = self.spec.to_dict() if self.spec else {}
        row = {
            "clip": self.clip, "status": self.status, "usable": self.usable,
            "verdict": self.verdict, "period": self.period_frames, "r1": self.r1, "r2": self.r2,
            "cycle_start": self.cycle_start, "cycle_stop": self.cycle_stop,
            "frames": self.frames, "error": self.error, "path": self.source,
        }
        row.update({k: spec.get(k)
                    for k in ("box", "subject", "background", "start", "stop", "fps")})
        return row

    @classmethod
    def from_row(cls, row: object) -> ClipSummary:
        """Read back :meth:`to_row` (JSON values, or the strings of a CSV row).

        Raises
        ------
        GaitInputError
            For a row that is not a batch summary row: not a table of plain values, an
            unknown status, a clip id that cannot name a folder, a non-finite number.
        """
        if not isinstance(row, dict):
            raise GaitInputError(f"batch summary row {describe(row)} is not a row of values")
        shown = str(row.get("clip", "?"))[:40]
        try:
            for key, value in row.items():
                if not isinstance(value, (str, int, float, bool, type(None))):
                    raise ValueError(f"{str(key)[:40]} holds {describe(value)}")
            status = str(row["status"])
            if status not in STATUSES:
                raise ValueError(f"status {status[:40]!r}")
            clip = str(row["clip"])
            if not is_clip_id(clip):
                raise ValueError(f"clip id {clip[:40]!r} cannot name a folder")
            spec = None if status == "bad row" else spec_from_dict(row)
            return cls(
                clip=clip, status=status, source=str(row.get("path") or ""),
                spec=spec, frames=_opt(row.get("frames"), int),
                usable=_opt(row.get("usable"), lambda v: v if isinstance(v, bool) else v == "True"),
                verdict=str(row.get("verdict") or ""), period_frames=_opt(row.get("period"), float),
                r1=_opt(row.get("r1"), float), r2=_opt(row.get("r2"), float),
                cycle_start=_opt(row.get("cycle_start"), int),
                cycle_stop=_opt(row.get("cycle_stop"), int),
                error=str(row.get("error") or ""),
            )
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            if isinstance(exc, GaitInputError):
                raise
            raise GaitInputError(f"batch summary row {shown!r} is malformed ({exc})") from None


def pending(spec: ClipSpec) -> ClipSummary:
    """The row of a clip not analysed yet."""
    return ClipSummary(spec.clip, "pending", str(spec.path), spec)


def analyze_clip(spec: ClipSpec, out_dir: Path, *,
                 settings: AnalysisSettings = AnalysisSettings(),
                 segmentation: SegmentationSettings = SegmentationSettings()) -> ClipSummary:
    """Analyse one clip and write its outputs to ``out_dir/<clip>/`` atomically.

    Parameters
    ----------
    spec : ClipSpec
        The manifest row.
    out_dir : Path
        The batch's output folder.
    settings : AnalysisSettings
        As ``gaitcore analyze`` takes them.
    segmentation : SegmentationSettings
        The profile colour footage is segmented with (kept in the clip's project and result).

    Returns
    -------
    ClipSummary
        Status ``done``, or ``failed`` with the one-line error when the clip cannot be
        analysed (bad input is never raised: it is the clip's result).

    Notes
    -----
    Memory stays bounded as in ``gaitcore analyze``: frames are streamed, only the small
    tracked crops are kept.
    """
    out_dir = Path(out_dir)
    tmp = out_dir / f".{spec.clip}{_PARTIAL}{uuid.uuid4().hex[:8]}"
    tmp.mkdir(parents=True)
    try:
        project = Project(footage=spec.path, frame_start=spec.start, frame_stop=spec.stop,
                          fps=spec.fps, box=spec.box, subject_rects=spec.subject,
                          background_rects=spec.background, segmentation=segmentation)
        try:
            project = replace(project, silhouettes=_silhouettes(spec, project))
            analysis = analyze(project.silhouettes, settings, trim=project.trim)
            write_analysis_json(tmp / ANALYSIS_NAME, analysis, source=str(spec.path))
            summary = _done(spec, analysis)
        except (GaitInputError, OSError) as exc:
            summary = failed(spec, exc)
        save_project(project, tmp / PROJECT_NAME)
        _write_json(tmp / RESULT_NAME, {"format": CLIP_FORMAT, "version": VERSION,
                                        "clip": summary.to_row(),
                                        "segmentation": settings_to_dict(segmentation)})
        _publish(tmp, out_dir / spec.clip)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return summary


def failed(spec: ClipSpec, exc: BaseException) -> ClipSummary:
    """The row of a clip whose analysis raised ``exc`` (its message's first line)."""
    text = str(exc).strip()
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.strerror}: {exc.filename or ''}".rstrip(": ")
    elif not isinstance(exc, GaitInputError):
        text = f"{type(exc).__name__}: {text}"
    return ClipSummary(spec.clip, "failed", str(spec.path), spec,
                       error=(text.splitlines() or [type(exc).__name__])[0])


def finished_result(out_dir: Path, spec: ClipSpec,
                    segmentation: SegmentationSettings = SegmentationSettings(),
                    ) -> ClipSummary | None:
    """The stored row of a clip already analysed for this very manifest row, else None.

    A clip counts as finished when its folder holds a ``result.json`` whose status is
    ``done``, whose manifest row equals ``spec`` and whose segmentation profile is
    ``segmentation`` (a changed box, trim or profile runs again; so does a failed clip,
    whose file may have been fixed since).
    """
    try:
        data = read_json(Path(out_dir) / spec.clip / RESULT_NAME, what="clip result",
                         max_bytes=MAX_RESULT_BYTES).value
        if (not isinstance(data, dict) or data.get("format") != CLIP_FORMAT
                or data.get("version") != VERSION):
            return None
        stored = ClipSummary.from_row(data.get("clip"))
        if data.get("segmentation") != settings_to_dict(segmentation):
            return None
    except GaitInputError:  # missing, damaged or not a regular file: the clip runs again
        return None
    if stored.status != "done" or stored.spec != spec:
        return None
    return replace(stored, spec=spec)


def remove_partial_folders(out_dir: Path) -> None:
    """Delete the temporary clip folders that an interrupted batch left in ``out_dir``."""
    for entry in Path(out_dir).glob(f".*{_PARTIAL}*"):
        _remove(entry)


def write_summary(out_dir: Path, rows: list[ClipSummary], *, manifest: Path) -> None:
    """Write ``summary.csv`` and ``summary.json`` in ``out_dir``, each atomically.

    Raises
    ------
    GaitInputError
        A row holds a number that is not finite: neither file is written.
    """
    table = [r.to_row() for r in rows]
    summary = Path(out_dir) / SUMMARY_NAMES[1]
    doc = dump_json({"format": FORMAT, "version": VERSION, "manifest": str(manifest),
                     "clips": table}, indent=1, what=str(summary))
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows({k: "" if v is None else v for k, v in row.items()} for row in table)
    write_atomic(Path(out_dir) / SUMMARY_NAMES[0], text.getvalue().encode("utf-8"))
    write_atomic(summary, (doc + "\n").encode("utf-8"))


def read_summary(path: str | Path) -> tuple[ClipSummary, ...]:
    """Read ``summary.json`` or ``summary.csv`` written by :func:`write_summary`.

    Raises
    ------
    GaitInputError
        Unreadable file, not a batch summary, or malformed rows.
    """
    path = Path(path)
    advice = "open the summary.json or summary.csv that 'gaitcore batch' wrote"
    text = read_text(path, what="batch summary", max_bytes=MAX_SUMMARY_BYTES)
    try:
        if path.suffix.lower() == ".json":
            data = parse_json(text, what=f"batch summary {path}", advice=advice)
            if data.key("format", None).value != FORMAT:
                raise ValueError("not a Gait Studio batch summary")
            rows = [row.value for row in data.key("clips").items(max_len=MAX_CLIPS)]
        else:
            rows = list(csv.DictReader(io.StringIO(text)))
            if rows and "status" not in rows[0]:
                raise ValueError("no 'status' column")
            if len(rows) > MAX_CLIPS:
                raise ValueError(f"more than {MAX_CLIPS} clips")
    except (ValueError, csv.Error) as exc:
        if isinstance(exc, GaitInputError):
            raise
        raise GaitInputError(f"cannot read the batch summary {path}: {exc}; {advice}") from None
    return tuple(ClipSummary.from_row(row) for row in rows)


# -- helpers -----------------------------------------------------------------------------
def _silhouettes(spec: ClipSpec, project: Project):
    """Tracked silhouettes of the whole clip (the cycle search looks at all of it; the trim
    limits the analysis): a mask folder is tracked, colour is segmented."""
    with open_source(project) as source:  # checks the footage
        if is_mask_folder(spec.path):
            return silhouettes_from_masks(spec.path)
        return segment(source, project)


def _done(spec: ClipSpec, analysis: Analysis) -> ClipSummary:
    """The row of an analysed clip; its best cycle is the first stretch the cycle finder
    ranks (by r and length), else the analysed range."""
    d = analysis.diagnosis
    best = analysis.cycles[0].to_dict(analysis.cycle_offset) if analysis.cycles else None
    r = [_rounded(float(v), 4) for v in d.correlations] + [None, None]
    return ClipSummary(
        spec.clip, "done", str(spec.path), spec, frames=analysis.n_frames,
        usable=d.verdict.value == "usable", verdict=d.verdict.value,
        period_frames=_rounded(float(d.period_frames), 3), r1=r[0], r2=r[1],
        cycle_start=best["start"] if best else analysis.first_frame,
        cycle_stop=best["stop"] if best else analysis.first_frame + analysis.n_frames,
    )


def _publish(tmp: Path, final: Path) -> None:
    """Rename the complete folder ``tmp`` to ``final``, replacing an older one."""
    if final.exists():
        old = final.with_name(f".{final.name}{_PARTIAL}old-{uuid.uuid4().hex[:8]}")
        final.replace(old)
        tmp.replace(final)
        _remove(old)
    else:
        tmp.replace(final)


def _remove(path: Path) -> None:
    """Delete a folder, or whatever took a folder's name (a file, a pipe, a link)."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def _write_json(path: Path, data: dict) -> None:
    write_atomic(path, (dump_json(data, indent=1, what=str(path)) + "\n").encode("utf-8"))


def _rounded(value: float, digits: int) -> float | None:
    """``value`` rounded as the summary shows it (None when not finite)."""
    return round(value, digits) if math.isfinite(value) else None


def _opt(value, kind):
    """None for an empty cell, else ``kind(value)`` of a finite number (or its text)."""
    if value is None or value == "":
        return None
    if kind in (int, float) and not math.isfinite(float(value)):
        raise ValueError(f"{value!r} is not a finite number")
    return kind(value)


__all__ = [
    "ClipSummary", "SUMMARY_COLUMNS", "analyze_clip", "failed",
    "finished_result", "pending", "read_summary", "remove_partial_folders", "write_summary",
]
