"""Fuzzed readers: whatever a file holds, only GaitInputError leaves a reader (issue #15).

Each reader gets DEFAULT_CASES seeded mutations of a valid file in the default run and
FUZZ_CASES under ``-m fuzz``; every case must finish within 2 s and 200 MiB (see
:mod:`tests.fuzzing`).
"""

from __future__ import annotations

import json
import os
import random
import shutil
from pathlib import Path

import numpy as np
import pytest

from gaitcore.analysis.analyze import AnalysisSettings
from gaitcore.bench.gaits import generate_gait
from gaitcore.io.analysis_file import read_analysis_json
from gaitcore.io.bvh.reader import read_bvh
from gaitcore.io.bvh.writer import write_bvh
from gaitcore.io.pose_table import PoseTable, read_pose_table, write_pose_table
from gaitcore.project.document import Project, Silhouettes
from gaitcore.project.storage import load_project, save_project, sidecar_dir
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template
from gaitcore.schema import MAX_FPS
from gaitcore.silhouettes.annotations import Rect, Scribble, Stroke
from gaitcore.silhouettes.tracking import RoiClip
from tests.fuzzing import (
    DEFAULT_CASES,
    FUZZ_CASES,
    SPECIAL_NUMBERS,
    check_reader,
    mutate_json,
    mutate_text,
)

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


def _sizes(request) -> int:
    return FUZZ_CASES if request.node.get_closest_marker("fuzz") else DEFAULT_CASES


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


def test_fuzzed_projects_raise_only_gait_input_errors(valid_project, tmp_path, request):
    doc = json.loads((valid_project / "p.gaitproj").read_text())

    def write_case(rng: random.Random, folder: Path) -> Path:
        path = folder / "p.gaitproj"
        shutil.copytree(sidecar_dir(valid_project / "p.gaitproj"), sidecar_dir(path))
        (folder / "clip").mkdir()
        if rng.random() < 0.2:
            path.write_text(json.dumps(doc))
            _damage_array(rng.choice(sorted(sidecar_dir(path).iterdir())), rng)
        else:
            path.write_text(mutate_json(doc, rng))
        return path

    check_reader(write_case, load_project, tmp_path, n_cases=_sizes(request), seed=1,
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


def test_fuzzed_skeleton_files_raise_only_gait_input_errors(tmp_path, request):
    doc = HORSE.to_dict()

    def write_case(rng: random.Random, folder: Path) -> Path:
        (folder / "s.json").write_text(mutate_json(doc, rng))
        return folder / "s.json"

    check_reader(write_case, Skeleton.from_json, tmp_path, n_cases=_sizes(request), seed=2)


def test_fuzzed_analysis_files_raise_only_gait_input_errors(tmp_path, request):
    n = 6
    doc = {"format": "gaitstudio-analysis", "version": 1, "source": "", "n_frames": n,
           "pcs": 2, "keys": 2, "alpha": 0.69, "roi_size": [9, 7], "usable": True,
           "key_frames": [1, 4], "alternate_frames": [2, 5], "exact": True,
           "projections": [[0.1 * i, -0.2 * i] for i in range(n)],
           "filtered_projections": [[0.1 * i, -0.2 * i] for i in range(n)],
           "loop_angle": [0.1 * i for i in range(n)]}

    def write_case(rng: random.Random, folder: Path) -> Path:
        (folder / "analysis.json").write_text(mutate_json(doc, rng))
        return folder / "analysis.json"

    check_reader(write_case, read_analysis_json, tmp_path, n_cases=_sizes(request), seed=3)


def test_fuzzed_pose_tables_raise_only_gait_input_errors(tmp_path, request):
    write_pose_table(tmp_path / "good.csv", PoseTable(np.arange(4), HORSE.channel_names, POSES))
    good = (tmp_path / "good.csv").read_text()

    def write_case(rng: random.Random, folder: Path) -> Path:
        (folder / "p.csv").write_text(mutate_text(good, rng, CSV_PIECES), encoding="utf-8")
        return folder / "p.csv"

    check_reader(write_case, read_pose_table, tmp_path / "cases", n_cases=_sizes(request), seed=4)


def test_fuzzed_bvh_files_raise_only_gait_input_errors(tmp_path, request):
    write_bvh(tmp_path / "good.bvh", HORSE, PoseTable(np.arange(4), HORSE.channel_names, POSES))
    good = (tmp_path / "good.bvh").read_text()

    def write_case(rng: random.Random, folder: Path) -> Path:
        (folder / "m.bvh").write_text(mutate_text(good, rng, BVH_PIECES), encoding="utf-8")
        return folder / "m.bvh"

    check_reader(write_case, read_bvh, tmp_path / "cases", n_cases=_sizes(request), seed=5)


@pytest.mark.fuzz
def test_4000_fuzzed_projects(valid_project, tmp_path, request):
    test_fuzzed_projects_raise_only_gait_input_errors(valid_project, tmp_path, request)


@pytest.mark.fuzz
def test_4000_fuzzed_skeleton_files(tmp_path, request):
    test_fuzzed_skeleton_files_raise_only_gait_input_errors(tmp_path, request)


@pytest.mark.fuzz
def test_4000_fuzzed_analysis_files(tmp_path, request):
    test_fuzzed_analysis_files_raise_only_gait_input_errors(tmp_path, request)


@pytest.mark.fuzz
def test_4000_fuzzed_pose_tables(tmp_path, request):
    test_fuzzed_pose_tables_raise_only_gait_input_errors(tmp_path, request)


@pytest.mark.fuzz
def test_4000_fuzzed_bvh_files(tmp_path, request):
    test_fuzzed_bvh_files_raise_only_gait_input_errors(tmp_path, request)
