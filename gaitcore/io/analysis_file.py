"""``analysis.json``: the result of ``gaitcore analyze``, read back by ``gaitcore animate``.

The file is plain JSON (never pickle). Frame numbers are 0-based in source order: a trimmed
analysis (``--start 100 --stop 400``) has ``n_frames`` 300 rows of ``projections`` for source
frames ``first_frame`` = 100 to 399, and its ``key_frames``, ``alternate_frames``,
``lost_frames`` and ``cycles`` are source frame numbers. ``fps`` is the clip's frame rate
(null when unknown), ``period_s`` the diagnosis' period in seconds.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from gaitcore.analysis.analyze import Analysis
from gaitcore.animation.animate import AnalysisRecord, stored
from gaitcore.errors import GaitInputError

FORMAT = "gaitstudio-analysis"
VERSION = 1


def analysis_to_dict(analysis: Analysis, *, source: str = "", fps: float | None = None) -> dict:
    """The JSON-ready content of ``analysis.json`` (the contract in README.md, The gaitcore command)."""
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
        "period_frames": float(d.period_frames),
        "period_s": None if not fps else float(d.period_frames / fps),
        "f0": float(d.f0),
        "band": [float(b) for b in d.band],
        "key_frames": [int(f) for f in analysis.key_frames],
        "condition_number": float(analysis.selection.condition_number),
        "exact": bool(analysis.selection.exact),
        "lost_frames": [int(f) for f in analysis.lost_frames],
        "cycles": [c.to_dict(analysis.cycle_offset) for c in analysis.cycles],
        "advice": None if analysis.advice is None else analysis.advice.to_dict(),
        "projections": stored(analysis.coords).tolist(),
        "filtered_projections": stored(d.filtered[:, :pcs]).tolist(),
        "loop_angle": stored(analysis.loop_angle).tolist(),
    }
    if analysis.alternate_frames is not None:
        out["alternate_frames"] = [int(f) for f in analysis.alternate_frames]
    if analysis.alternates_note is not None:
        out["alternates_note"] = analysis.alternates_note
    return out


def write_analysis_json(path: str | Path, analysis: Analysis, *, source: str = "",
                        fps: float | None = None) -> None:
    """Write ``analysis.json`` atomically (a temporary file renamed over the target)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(analysis_to_dict(analysis, source=source, fps=fps), indent=1))
    tmp.replace(path)


def read_analysis_json(path: str | Path) -> AnalysisRecord:
    """Read and check an ``analysis.json``.

    Raises
    ------
    GaitInputError
        Missing or malformed file, or inconsistent content.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise GaitInputError(f"analysis file not found: {path}; run 'gaitcore analyze' first") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise GaitInputError(f"{path} is not a readable analysis file ({exc})") from None
    return analysis_record_from_dict(data, where=str(path))


def analysis_record_from_dict(data: object, *, where: str = "analysis") -> AnalysisRecord:
    """Check the parsed content of an ``analysis.json`` and turn it into a record.

    Raises
    ------
    GaitInputError
        Not an analysis, a newer version, missing or malformed fields, inconsistent content.
    """
    path = where
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise GaitInputError(f"{path} is not a Gait Studio analysis file")
    if data.get("version", 0) > VERSION:
        raise GaitInputError(
            f"{path} was written by a newer Gait Studio (format version {data['version']}); "
            "update Gait Studio to read it"
        )
    try:
        n = int(data["n_frames"])
        proj = np.asarray(data["projections"], dtype=float)
        filt = np.asarray(data.get("filtered_projections", data["projections"]), dtype=float)
        theta = np.asarray(data["loop_angle"], dtype=float)
        first = int(data.get("first_frame", 0))
        keys = tuple(int(f) for f in data["key_frames"])
        alts = data.get("alternate_frames")
        alts = None if alts is None else tuple(int(f) for f in alts)
        alpha = float(data.get("alpha", np.log(2.0)))
        period = float(data.get("period_frames") or "nan")
        fps = data.get("fps")
        fps = None if fps is None else float(fps)
    except (KeyError, TypeError, ValueError) as exc:
        raise GaitInputError(f"{path} is missing or has a malformed field: {exc}") from None
    if proj.ndim != 2 or proj.shape[0] != n or filt.shape != proj.shape or theta.shape != (n,):
        raise GaitInputError(f"{path}: projections do not match n_frames = {n}")
    if not keys or any(not first <= f < first + n for f in keys + (alts or ())):
        raise GaitInputError(f"{path}: key frames must lie in {first}..{first + n - 1}")
    if fps is not None and not (np.isfinite(fps) and fps > 0):
        raise GaitInputError(f"{path}: fps must be a positive number, got {fps}")
    return AnalysisRecord(n, proj, filt, theta, keys, alts, alpha, period, first_frame=first,
                          fps=fps)
