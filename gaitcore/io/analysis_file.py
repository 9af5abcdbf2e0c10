"""``analysis.json``: the result of ``gaitcore analyze``, read back by ``gaitcore animate``.

The file is plain JSON (never pickle). Frame numbers are 0-based in source order.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gaitcore.analysis.analyze import Analysis
from gaitcore.errors import GaitInputError
from gaitcore.schema import JsonValue, read_json

FORMAT = "gaitstudio-analysis"
VERSION = 1
MAX_VERSION = 1_000_000
MAX_FRAMES = 10_000_000
MAX_PCS = 64
MAX_ANALYSIS_BYTES = 2 << 30


def analysis_to_dict(analysis: Analysis, *, source: str = "") -> dict:
    """The JSON-ready content of ``analysis.json`` (see DESIGN.md, Contracts)."""
    d = analysis.diagnosis
    s = analysis.settings
    pcs = s.pcs
    out = {
        "format": FORMAT,
        "version": VERSION,
        "source": source,
        "n_frames": analysis.n_frames,
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
        "f0": float(d.f0),
        "band": [float(b) for b in d.band],
        "key_frames": [int(f) for f in analysis.key_frames],
        "condition_number": float(analysis.selection.condition_number),
        "exact": bool(analysis.selection.exact),
        "lost_frames": list(analysis.lost_frames),
        "projections": np.round(analysis.coords, 10).tolist(),
        "filtered_projections": np.round(d.filtered[:, :pcs], 10).tolist(),
        "loop_angle": np.round(analysis.loop_angle, 10).tolist(),
    }
    if analysis.alternate_frames is not None:
        out["alternate_frames"] = [int(f) for f in analysis.alternate_frames]
    return out


def write_analysis_json(path: str | Path, analysis: Analysis, *, source: str = "") -> None:
    """Write ``analysis.json`` atomically (a temporary file renamed over the target)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(analysis_to_dict(analysis, source=source), indent=1))
    tmp.replace(path)


@dataclass(frozen=True, eq=False)
class AnalysisRecord:
    """What ``gaitcore animate`` needs from an ``analysis.json``."""

    n_frames: int
    projections: np.ndarray
    filtered_projections: np.ndarray
    loop_angle: np.ndarray
    key_frames: tuple[int, ...]
    alternate_frames: tuple[int, ...] | None
    alpha: float


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


def analysis_record(analysis: Analysis) -> AnalysisRecord:
    """The :class:`AnalysisRecord` that ``analysis.json`` of ``analysis`` would give back.

    The numbers are exactly those :func:`read_analysis_json` reads from the file written by
    :func:`write_analysis_json` (JSON keeps every float exactly), so the GUI and
    ``gaitcore animate`` compute bit-identical curves from one analysis.
    """
    return analysis_record_from_dict(analysis_to_dict(analysis), where="analysis")


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
    keys = doc.key("key_frames").integers(max_len=MAX_PCS * MAX_PCS, lo=0, hi=n - 1)
    alts = doc.key("alternate_frames", None)
    alts = None if alts.is_null() else alts.integers(max_len=len(keys), lo=0, hi=n - 1)
    alpha = doc.key("alpha", float(np.log(2.0))).number(lo=0, lo_open=True, hi=1e6)
    if not keys:
        raise doc.key("key_frames").fail(f"a list of key frames in 0..{n - 1}")
    return AnalysisRecord(n, proj, filt, theta, keys, alts, alpha)
