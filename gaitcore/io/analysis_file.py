"""``analysis.json``: the result of ``gaitcore analyze``, read back by ``gaitcore animate``.

The file is plain JSON (never pickle). Frame numbers are 0-based in source order: a trimmed
analysis (``--start 100 --stop 400``) has ``n_frames`` 300 rows of ``projections`` for source
frames ``first_frame`` = 100 to 399, and its ``key_frames``, ``alternate_frames``,
``lost_frames`` and ``cycles`` are source frame numbers. ``fps`` is the clip's frame rate
(null when unknown), ``period_s`` the diagnosis' period in seconds. ``components`` names
the principal component behind each column of ``projections`` (the rhythm's pair first,
drift removed); ``partial_frames`` are the source frames left out because the animal is only
partly in view; ``scales`` the factor by which each silhouette given (from source frame
``silhouettes_first_frame`` on) was enlarged to compare them at a steady height; ``travel``
the animal's progress across the footage on each analysed frame, in its own heights from the
first (null when it does not cross the view: it stays, or the camera follows it), which
``animate`` turns into the root's travel.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gaitcore.analysis.analyze import Analysis
from gaitcore.animation.animate import AnalysisRecord, stored
from gaitcore.errors import GaitInputError
from gaitcore.schema import MAX_FPS, MIN_FPS, JsonValue, dump_json, read_json

FORMAT = "gaitstudio-analysis"
VERSION = 1
MAX_VERSION = 1_000_000
MAX_FRAMES = 10_000_000
MAX_PCS = 64
MAX_ANALYSIS_BYTES = 2 << 30
MAX_COORDINATE = 1e9
"""The largest projection or loop angle a file may hold: PCA coordinates of images stay far
below, and squares of larger ones overflow the interpolation's arithmetic."""


def analysis_to_dict(analysis: Analysis, *, source: str = "", fps: float | None = None) -> dict:
    """The JSON-ready content of ``analysis.json`` (the contract in docs/command.md)."""
    d = analysis.diagnosis
    s = analysis.settings
    pcs = s.pcs
    first = analysis.first_frame
    out = {
        "format": FORMAT,
        "version": VERSION,
        "source": source,
        "n_frames": analysis.n_frames,
        "first_frame": first,
        "fps": fps,
        "pcs": pcs,
        "keys": s.keys,
        "alpha": s.alpha,
        "roi_size": list(analysis.pca.image_shape),
        "variance_ratio": [float(v) for v in analysis.pca.variance_ratio],
        "correlations": [float(r) for r in d.correlations],
        "usable": d.verdict.value == "usable",
        "verdict": d.verdict.value,
        "reason": d.reason,
        "period_frames": _finite(d.period_frames),
        "period_s": _finite(d.period_frames / fps) if fps else None,
        "f0": _finite(d.f0),
        "band": [float(b) for b in d.band],
        "key_frames": [int(f) for f in analysis.key_frames],
        "condition_number": float(analysis.selection.condition_number),
        "exact": bool(analysis.selection.exact),
        "lost_frames": [int(f) for f in analysis.lost_frames],
        "components": list(analysis.component_names),
        "partial_frames": list(analysis.partial_frames),
        "cycle_frames": _finite(analysis.cycle_frames),
        "silhouettes_first_frame": analysis.cycle_offset,
        "scales": [] if analysis.framing is None
        else [round(float(v), 4) for v in analysis.framing.scales],
        "height_change": None if analysis.framing is None
        else round(float(analysis.framing.height_change), 4),
        "cycles": [c.to_dict(analysis.cycle_offset) for c in analysis.cycles],
        "advice": None if analysis.advice is None else analysis.advice.to_dict(),
        "projections": stored(analysis.coords).tolist(),
        "filtered_projections": stored(d.filtered[:, :pcs]).tolist(),
        "loop_angle": stored(analysis.loop_angle).tolist(),
        "travel": None if analysis.travel is None else stored(analysis.travel).tolist(),
    }
    if analysis.alternate_frames is not None:
        out["alternate_frames"] = [int(f) for f in analysis.alternate_frames]
    if analysis.alternates_note is not None:
        out["alternates_note"] = analysis.alternates_note
    return out


def _finite(value: float) -> float | None:
    """``value`` as a JSON number, or null when it is not finite (no peak, no period)."""
    value = float(value)
    return value if np.isfinite(value) else None


def write_analysis_json(path: str | Path, analysis: Analysis, *, source: str = "",
                        fps: float | None = None) -> None:
    """Write ``analysis.json`` atomically (a temporary file renamed over the target)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    text = dump_json(analysis_to_dict(analysis, source=source, fps=fps), indent=1,
                     what=f"the analysis {path}")
    tmp.write_text(text)
    tmp.replace(path)


def read_analysis_json(path: str | Path) -> AnalysisRecord:
    """Read and check an ``analysis.json``.

    Raises
    ------
    GaitInputError
        Missing or malformed file, or inconsistent content.
    """
    doc = read_json(path, what="analysis file", max_bytes=MAX_ANALYSIS_BYTES,
                    advice="run 'gaitcore analyze' again to rewrite it")
    return analysis_record_from_dict(doc)


def analysis_record_from_dict(data: object, *, where: str = "analysis") -> AnalysisRecord:
    """Check the parsed content of an ``analysis.json`` and turn it into a record.

    Parameters
    ----------
    data : dict or JsonValue
        The parsed document (a :class:`~gaitcore.schema.JsonValue` knows its file).
    where : str
        Names the document in messages when ``data`` is a plain dict.

    Raises
    ------
    GaitInputError
        Not an analysis, a newer version, missing or malformed fields (named with their
        path), inconsistent content.
    """
    doc = data if isinstance(data, JsonValue) else JsonValue(data, where)
    if not doc.has("format") or doc.value["format"] != FORMAT:
        raise GaitInputError(f"{doc.what} is not a Gait Studio analysis file")
    version = doc.key("version", 1).integer(lo=1, hi=MAX_VERSION)
    if version > VERSION:
        raise GaitInputError(
            f"{doc.what} was written by a newer Gait Studio (format version {version}); "
            "update Gait Studio to read it")
    n = doc.key("n_frames").integer(lo=1, hi=MAX_FRAMES)
    rows = doc.key("projections").items(min_len=n, max_len=n)
    pcs = len(rows[0].items(min_len=1, max_len=MAX_PCS))
    proj = doc.key("projections").array(columns=pcs, min_rows=n, max_rows=n)
    filt = doc.key("filtered_projections", doc.value["projections"]).array(
        columns=pcs, min_rows=n, max_rows=n)
    theta = doc.key("loop_angle").array(min_rows=n, max_rows=n)
    for name, values in (("projections", proj), ("filtered_projections", filt),
                         ("loop_angle", theta)):
        if np.abs(values).max(initial=0.0) > MAX_COORDINATE:
            raise doc.key(name).fail(f"numbers of at most {MAX_COORDINATE:g} in size (the "
                                     "analysis never writes larger ones)")
    first = doc.key("first_frame", 0).integer(lo=0, hi=MAX_FRAMES)
    last = first + n - 1
    keys = doc.key("key_frames").integers(max_len=MAX_PCS * MAX_PCS, lo=first, hi=last)
    alts = doc.key("alternate_frames", None)
    alts = None if alts.is_null() else alts.integers(max_len=len(keys), lo=first, hi=last)
    alpha = doc.key("alpha", float(np.log(2.0))).number(lo=0, lo_open=True, hi=1e6)
    period = doc.key("period_frames", None).number(lo=0, lo_open=True, hi=MAX_FRAMES,
                                                   optional=True)
    fps = doc.key("fps", None).number(lo=MIN_FPS, hi=MAX_FPS, optional=True)
    travel = doc.key("travel", None)
    travel = None if travel.is_null() else travel.array(min_rows=n, max_rows=n)
    if travel is not None and np.abs(travel).max(initial=0.0) > MAX_COORDINATE:
        raise doc.key("travel").fail(f"numbers of at most {MAX_COORDINATE:g} in size")
    if not keys:
        raise doc.key("key_frames").fail(f"a list of key frames in {first}..{last}")
    return AnalysisRecord(n, proj, filt, theta, keys, alts, alpha,
                          float("nan") if period is None else period, first_frame=first, fps=fps,
                          travel=travel)
