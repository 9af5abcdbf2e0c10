"""Fuzzed readers: whatever a file holds or a path names, only one-line GaitInputError
leaves a reader (issues #15 and #64).

Each reader gets DEFAULT_CASES cases drawn by Hypothesis from a valid file in the default run
and FUZZ_CASES under ``-m fuzz``, each in a forked child with a time and memory limit (see
:mod:`tests.fuzzing`): projects, skeletons, analyses, pose tables, BVH, scribbles, batch
manifests, a batch's clip results read back on a re-run, and batch summaries.
"""

from __future__ import annotations

import json
import os
import random
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import strategies as st

from gaitcore.analysis.analyze import AnalysisSettings
from gaitcore.bench.gaits import generate_gait
from gaitcore.io.analysis_file import read_analysis_json
from gaitcore.io.bvh.reader import read_bvh
from gaitcore.io.bvh.writer import write_bvh
from gaitcore.io.pose_table import PoseTable, read_pose_table, write_pose_table
from gaitcore.io.scribbles import read_scribbles, scribbles_to_dict
from gaitcore.project.batch import (
    ClipSummary,
    analyze_clip,
    finished_result,
    read_summary,
    write_summary,
)
from gaitcore.project.document import Project, Silhouettes
from gaitcore.project.manifest import ClipSpec, read_manifest
from gaitcore.project.storage import load_project, save_project, sidecar_dir
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template
from gaitcore.schema import MAX_FPS
from gaitcore.silhouettes.annotations import Rect, Scribble, Stroke
from gaitcore.silhouettes.tracking import RoiClip
from tests.fuzzing import (
    CASE_COUNTS,
    SPECIAL_NUMBERS,
    fuzz,
    json_cases,
    text_cases,
)
from tests.gaitcore.walker import walker_clip, write_mask_folder

HORSE = load_template("horse")
POSES = generate_gait(HORSE, "walk", 4, seed=0)
BVH_PIECES = SPECIAL_NUMBERS + (
    "inf", "nan", "-0", "{", "}", "JOINT x", "End Site", "End", "ROOT r", "MOTION", "HIERARCHY",
    "Frames: inf", "Frames: nan", "Frames: 1e400", "Frame Time: 1e-400", "Frame Time: inf",
    "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", "CHANNELS 7",
    "OFFSET 1e400 0 0", "CHANNELS 1e400", "CHANNELS nan", "x" * 200_000, "\t", "\x00")
CSV_PIECES = SPECIAL_NUMBERS + (
    "inf", "nan", "", ",", ",,", "frame", '"', '"a\nb"', "x" * 200_000, "1" * 200_000, "-1",
    "1.5", "1e20", "\x00", "frame,frame")


@pytest.fixture(scope="module")
def valid_project(tmp_path_factory) -> Path:
    """A project with every kind of entry: footage, rectangles, strokes, poses, rig, arrays."""
    folder = tmp_path_factory.mktemp("project")
    (folder / "clip").mkdir()
    rng = np.random.default_rng(0)
    roi = RoiClip(rng.random((6, 9, 7)) > 0.5, rng.random((6, 2)) * 100, np.zeros(6, bool), 0.5)
    project = Project(
        footage=folder / "clip", frame_start=1, frame_stop=7, fps=24.0,
        subject_rects=(Rect(1, 2, 30, 40),), background_rects=(Rect(0, 0, 5, 5),),
        strokes=(Stroke([[1.25, 2.5], [3.0, 4.125]], 3.5, 2),),
        scribbles=(Scribble([[4.5, 6.0], [8.0, 9.25]], 6.0, 3, "background"),),
        settings=AnalysisSettings(pcs=3, keys=5, switching=True, pinned=(1,), forbidden=(4,)),
        alternates=(3, 5), key_poses={2: tuple(POSES[0])}, skeleton=HORSE,
        silhouettes=Silhouettes(roi, "segmented"))
    save_project(project, folder / "p.gaitproj")
    return folder


def _damage_array(f: Path, rng: random.Random) -> None:
    data = f.read_bytes()
    kind = rng.choice(["empty", "truncated", "bit", "huge", "short", "folder", "pipe"])
    header = "{'descr': '%s', 'fortran_order': False, 'shape': %s, }"
    if kind == "folder" or (kind == "pipe" and not hasattr(os, "mkfifo")):
        f.unlink()
        f.mkdir()
    elif kind == "pipe":
        f.unlink()
        os.mkfifo(f)
    elif kind in ("huge", "short"):
        text = header % (("|u1", "(2251799813685248,)") if kind == "huge" else ("<f8", "(6, 2)"))
        text += " " * (117 - len(text)) + "\n"
        f.write_bytes(b"\x93NUMPY\x01\x00" + len(text).to_bytes(2, "little") + text.encode()
                      + b"\0" * 64)
    else:
        cut = {"empty": b"", "truncated": data[:rng.randrange(len(data))]}
        if kind == "bit":
            flipped = bytearray(data)
            flipped[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
            cut["bit"] = bytes(flipped)
        f.write_bytes(cut[kind])


def _write_text(name: str):
    def write(text: str, folder: Path) -> Path:
        (folder / name).write_text(text, encoding="utf-8", errors="surrogateescape")
        return folder / name
    return write


def sidecar_cases(valid: Path, document: Callable[[Path], Path], arrays: list[str]):
    """Cases of a project file ``valid`` and its sidecar folder: the JSON ``document(path)``
    mutated, or one of the sidecar's ``arrays`` damaged. Returns (strategy, write)."""
    doc = json.loads(document(valid).read_text())
    cases = st.one_of(
        json_cases(doc).map(lambda text: (text, None, 0)),
        st.tuples(st.just(json.dumps(doc)), st.sampled_from(arrays), st.integers(0, 2**32)))

    def write(case, folder: Path) -> Path:
        text, array, seed = case
        path = folder / valid.name
        shutil.copytree(sidecar_dir(valid), sidecar_dir(path))
        (folder / "clip").mkdir(exist_ok=True)
        document(path).write_text(text)
        if array is not None:
            _damage_array(sidecar_dir(path) / array, random.Random(seed))
        return path

    return cases, write


def project_cases(valid_project: Path):
    """:func:`sidecar_cases` of the project file itself and any of its arrays."""
    project = valid_project / "p.gaitproj"
    return sidecar_cases(project, lambda path: path,
                         sorted(f.name for f in sidecar_dir(project).iterdir()))


@CASE_COUNTS
def test_fuzzed_projects_raise_only_gait_input_errors(valid_project, tmp_path, n_cases):
    fuzz(*project_cases(valid_project), load_project, tmp_path, n_cases=n_cases,
         check=_usable)


def _usable(project: Project) -> None:
    """What the window relies on in an opened project."""
    assert project.fps is None or 0 < project.fps <= MAX_FPS
    assert project.frame_stop is None or project.frame_stop > project.frame_start >= 0
    assert all(np.all(np.isfinite(pose)) for pose in project.key_poses.values())
    assert all(np.all(np.isfinite(s.points_xy)) and s.width_px > 0 for s in project.strokes)
    if project.silhouettes is not None:
        roi = project.silhouettes.roi
        assert np.isfinite(roi.scale) and roi.scale > 0
        found = np.flatnonzero(~roi.lost)
        if len(found):
            assert np.all(np.isfinite(project.silhouettes.window_xywh(int(found[0])) or ()))


@CASE_COUNTS
def test_fuzzed_skeleton_files_raise_only_gait_input_errors(tmp_path, n_cases):
    doc = HORSE.to_dict()

    fuzz(json_cases(doc), _write_text("s.json"), Skeleton.from_json, tmp_path,
         n_cases=n_cases)


@CASE_COUNTS
def test_fuzzed_analysis_files_raise_only_gait_input_errors(tmp_path, n_cases):
    n = 6
    doc = {"format": "gaitstudio-analysis", "version": 1, "source": "", "n_frames": n,
           "pcs": 2, "keys": 2, "alpha": 0.69, "roi_size": [9, 7], "usable": True,
           "key_frames": [1, 4], "alternate_frames": [2, 5], "exact": True,
           "projections": [[0.1 * i, -0.2 * i] for i in range(n)],
           "filtered_projections": [[0.1 * i, -0.2 * i] for i in range(n)],
           "loop_angle": [0.1 * i for i in range(n)]}

    fuzz(json_cases(doc), _write_text("analysis.json"), read_analysis_json, tmp_path,
         n_cases=n_cases, check=_finite_record)


@CASE_COUNTS
def test_fuzzed_pose_tables_raise_only_gait_input_errors(tmp_path, n_cases):
    write_pose_table(tmp_path / "good.csv", PoseTable(np.arange(4), HORSE.channel_names, POSES))
    good = (tmp_path / "good.csv").read_text()

    fuzz(text_cases(good, CSV_PIECES), _write_text("p.csv"), read_pose_table, tmp_path / "cases",
         n_cases=n_cases)


@CASE_COUNTS
def test_fuzzed_bvh_files_raise_only_gait_input_errors(tmp_path, n_cases):
    write_bvh(tmp_path / "good.bvh", HORSE, PoseTable(np.arange(4), HORSE.channel_names, POSES))
    good = (tmp_path / "good.bvh").read_text()

    fuzz(text_cases(good, BVH_PIECES), _write_text("m.bvh"), read_bvh, tmp_path / "cases",
         n_cases=n_cases)


def _finite_record(record) -> None:
    """An accepted analysis holds only finite numbers (they flow into the curves)."""
    for name in ("projections", "filtered_projections", "loop_angle"):
        value = getattr(record, name, None)
        if value is not None:
            assert np.all(np.isfinite(np.asarray(value, float))), name


@CASE_COUNTS
def test_fuzzed_scribbles_raise_only_gait_input_errors(tmp_path, n_cases):
    doc = scribbles_to_dict([Scribble([[1.5, 2.0], [30.0, 40.5]], 8.0, 0, "subject"),
                             Scribble([[5.0, 5.0]], 3.0, 4, "background")])

    def usable(scribbles) -> None:
        for sc in scribbles:
            assert np.all(np.isfinite(sc.points_xy)) and 0 < sc.width_px < 1e6

    fuzz(json_cases(doc), _write_text("s.json"), lambda p: read_scribbles(p, n_frames=10),
         tmp_path, n_cases=n_cases, check=usable)


MANIFEST_PIECES = SPECIAL_NUMBERS + (
    "clip,path", "summary.json,walker", "x" * 300 + ",walker", '"1,2,3,4"', '"-1,2,3,4"',
    "../..", "/dev/zero", "walker;walker", ",,,,,,,,,,", "\x00", '"', "a\nb", "fps")


@CASE_COUNTS
def test_fuzzed_manifests_raise_only_gait_input_errors(tmp_path, n_cases):
    good = ('clip,path,box,subject,background,start,stop,fps\n'
            'a,walker,"1,2,30,40",,,0,3,12.5\n,walker,,"1,1,5,5","0,0,2,2",,,\n')

    def write(text: str, folder: Path) -> Path:
        write_mask_folder(folder / "walker", walker_clip(4))
        (folder / "m.csv").write_text(text, encoding="utf-8", errors="surrogateescape")
        return folder / "m.csv"

    fuzz(text_cases(good, MANIFEST_PIECES), write, read_manifest, tmp_path / "cases",
         n_cases=n_cases)


@pytest.fixture(scope="module")
def clip_result(tmp_path_factory) -> tuple[ClipSpec, Path]:
    """A clip analysed by a batch: its spec and its output folder."""
    root = tmp_path_factory.mktemp("batch")
    spec = ClipSpec("w", write_mask_folder(root / "walker", walker_clip(60)).absolute())
    analyze_clip(spec, root / "out")
    return spec, root / "out" / "w"


@CASE_COUNTS
def test_fuzzed_clip_results_make_a_re_run_run_the_clip_again(clip_result, tmp_path, n_cases):
    """A batch re-run reads each clip's result.json back: damage means 'run it again'."""
    spec, folder = clip_result
    doc = json.loads((folder / "result.json").read_text())

    def write(text: str, out: Path) -> Path:
        (out / "w").mkdir()
        (out / "w" / "result.json").write_text(text, encoding="utf-8", errors="surrogateescape")
        return out / "w" / "result.json"

    def read(path: Path):
        stored = finished_result(path.parent.parent, spec)
        assert stored is None or stored.spec == spec
        return stored

    fuzz(json_cases(doc), write, read, tmp_path, n_cases=n_cases)


def _summary_doc(tmp_path: Path) -> dict:
    spec = ClipSpec("a", tmp_path / "walker", box=Rect(1, 2, 3, 4), start=2, stop=50, fps=25.0)
    rows = [ClipSummary("a", "done", str(spec.path), spec, frames=48, usable=True,
                        verdict="usable", period_frames=12.25, r1=0.9, r2=0.8, cycle_start=2,
                        cycle_stop=50),
            ClipSummary("b", "failed", "x", ClipSpec("b", Path("x")), error="cannot open"),
            ClipSummary("line-4", "bad row", "", error="line 4: bad box")]
    write_summary(tmp_path, rows, manifest=tmp_path / "m.csv")
    return json.loads((tmp_path / "summary.json").read_text())


def _summary_usable(rows) -> None:
    for row in rows:
        for value in (row.period_frames, row.r1, row.r2):
            assert value is None or np.isfinite(value)


@CASE_COUNTS
def test_fuzzed_batch_summaries_raise_only_gait_input_errors(tmp_path, n_cases):
    doc = _summary_doc(tmp_path)
    fuzz(json_cases(doc), _write_text("summary.json"), read_summary, tmp_path / "cases",
         n_cases=n_cases, check=_summary_usable)


@CASE_COUNTS
def test_fuzzed_batch_summary_tables_raise_only_gait_input_errors(tmp_path, n_cases):
    _summary_doc(tmp_path)
    good = (tmp_path / "summary.csv").read_text()
    fuzz(text_cases(good, CSV_PIECES), _write_text("summary.csv"), read_summary,
         tmp_path / "cases", n_cases=n_cases, check=_summary_usable)


@CASE_COUNTS
def test_fuzzed_segmentation_profiles_raise_only_gait_input_errors(tmp_path, n_cases):
    from gaitcore.silhouettes.settings import (
        SegmentationSettings,
        read_settings,
        settings_to_dict,
    )

    fuzz(json_cases(settings_to_dict(SegmentationSettings())), _write_text("p.json"),
         read_settings, tmp_path, n_cases=n_cases)
