"""Project files: round trip, relative footage, atomic sidecar, clear errors, no pickles."""

from __future__ import annotations

import json
import os
import tracemalloc

import numpy as np
import pytest

from gaitcore.analysis.analyze import AnalysisSettings
from gaitcore.errors import GaitInputError
from gaitcore.project.document import AnimationOptions, FootageFit, Project, Silhouettes
from gaitcore.project.storage import (
    MAX_RECTS,
    MAX_STROKES,
    VERSION,
    load_project,
    missing_footage,
    save_project,
    sidecar_dir,
)
from gaitcore.rig.proportions import RigProportions
from gaitcore.silhouettes.annotations import Rect, Stroke
from gaitcore.silhouettes.settings import PropagationSettings, SegmentationSettings
from gaitcore.silhouettes.tracking import RoiClip


def make_project(footage) -> Project:
    rng = np.random.default_rng(0)
    centers = rng.random((6, 2)) * 100
    centers[2] = np.nan
    lost = np.isnan(centers[:, 0])
    roi = RoiClip(rng.random((6, 9, 7)) > 0.5, centers, lost, 0.5)
    return Project(
        footage=footage, frame_start=1, frame_stop=7, fps=24.0,
        subject_rects=(Rect(1, 2, 30, 40),), background_rects=(Rect(0, 0, 5, 5), Rect(9, 9, 3, 3)),
        strokes=(Stroke([[1.25, 2.5], [3.0, 4.125]], 3.5, 2), Stroke([[7.0, 7.0]], 2, 4)),
        settings=AnalysisSettings(pcs=3, keys=5, switching=True, pinned=(1,), forbidden=(4, 5)),
        alternates=(3, 5), key_poses={2: (1.0, -2.5)},
        silhouettes=Silhouettes(roi, "segmented"),
        animation=AnimationOptions(filtered=True, loop=True),
        footage_fit=FootageFit(scale=1.25, offset_x_m=-0.1, offset_y_m=0.05, flip=True),
        proportions=RigProportions(legs=1.15, neck=0.85, tail=0.9),
        segmentation=SegmentationSettings(propagation=PropagationSettings(saliency_every=2)),
    )


def test_round_trip_gives_the_same_project(tmp_path):
    (tmp_path / "clip").mkdir()
    project = make_project(tmp_path / "clip")
    save_project(project, tmp_path / "p.gaitproj")
    again = load_project(tmp_path / "p.gaitproj")
    assert again == project
    doc = json.loads((tmp_path / "p.gaitproj").read_text())
    assert doc["format"] == "gaitstudio-project" and doc["version"] == VERSION
    assert doc["footage"]["relative"] == "clip"
    assert doc["segmentation"]["propagation"]["saliency_every"] == 2
    del doc["segmentation"]  # a project of an earlier version: the default profile
    (tmp_path / "p.gaitproj").write_text(json.dumps(doc))
    assert load_project(tmp_path / "p.gaitproj").segmentation == SegmentationSettings()


def test_a_project_moved_with_its_footage_still_finds_it(tmp_path):
    (tmp_path / "a" / "clip").mkdir(parents=True)
    save_project(make_project(tmp_path / "a" / "clip"), tmp_path / "a" / "p.gaitproj")
    (tmp_path / "a").rename(tmp_path / "b")
    moved = load_project(tmp_path / "b" / "p.gaitproj")
    assert moved.footage == tmp_path / "b" / "clip"
    assert missing_footage(moved) is None


def test_missing_footage_is_reported(tmp_path):
    save_project(make_project(tmp_path / "gone"), tmp_path / "p.gaitproj")
    assert missing_footage(load_project(tmp_path / "p.gaitproj")) == tmp_path / "gone"


def test_saving_again_leaves_only_the_referenced_arrays_and_no_temp_files(tmp_path):
    path = tmp_path / "p.gaitproj"
    project = make_project(None)
    save_project(project, path)
    other = Silhouettes(RoiClip(np.ones((6, 4, 4), bool), np.zeros((6, 2)), np.zeros(6, bool)),
                        "sketched")
    save_project(Project(silhouettes=other), path)
    names = sorted(f.name for f in sidecar_dir(path).iterdir())
    assert len(names) == 3 and all(n.endswith(".npy") for n in names)
    assert not [f for f in tmp_path.rglob("*.tmp")]
    assert load_project(path).silhouettes == other


@pytest.mark.parametrize("text, words", [
    ("{not json", "damaged"),
    ('{"format": "gaitstudio-project", "version": 1}', "damaged"),
    ('{"format": "something-else", "version": 1}', "not a Gait Studio project"),
    ('{"format": "gaitstudio-project", "version": 99}', "newer Gait Studio"),
])
def test_bad_files_raise_one_clear_message_and_are_not_changed(tmp_path, text, words):
    path = tmp_path / "bad.gaitproj"
    path.write_text(text)
    with pytest.raises(GaitInputError, match=words):
        load_project(path)
    assert path.read_text() == text


def test_a_newer_project_is_never_overwritten(tmp_path):
    path = tmp_path / "new.gaitproj"
    text = '{"format": "gaitstudio-project", "version": 99}'
    path.write_text(text)
    with pytest.raises(GaitInputError, match="not overwritten"):
        save_project(Project(), path)
    assert path.read_text() == text


def test_pickled_arrays_are_refused(tmp_path):
    path = tmp_path / "p.gaitproj"
    save_project(make_project(None), path)
    crops = json.loads(path.read_text())["silhouettes"]["arrays"]["crops_packed"]
    np.save(sidecar_dir(path) / crops, np.array([{"evil": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(GaitInputError, match="damaged"):
        load_project(path)


def test_crops_are_packed_and_version_1_files_still_open(tmp_path):
    path = tmp_path / "p.gaitproj"
    project = make_project(None)
    save_project(project, path)
    doc = json.loads(path.read_text())
    assert doc["version"] == VERSION and doc["silhouettes"]["crops_shape"] == [6, 9, 7]
    packed = np.load(sidecar_dir(path) / doc["silhouettes"]["arrays"]["crops_packed"])
    assert packed.shape == (6, 9, 1) and packed.dtype == np.uint8
    # the same project as Gait Studio 1 wrote it: one byte per pixel
    old = dict(doc, version=1)
    old["silhouettes"] = {k: v for k, v in doc["silhouettes"].items() if k != "crops_shape"}
    old["silhouettes"]["arrays"] = dict(doc["silhouettes"]["arrays"])
    del old["silhouettes"]["arrays"]["crops_packed"]
    old["silhouettes"]["arrays"]["crops"] = "crops-0123456789abcdef.npy"
    np.save(sidecar_dir(path) / "crops-0123456789abcdef.npy", project.silhouettes.roi.crops)
    v1 = tmp_path / "v1.gaitproj"
    v1.write_text(json.dumps(old))
    sidecar_dir(path).rename(sidecar_dir(v1))
    np.testing.assert_array_equal(load_project(v1).silhouettes.roi.crops,
                                  project.silhouettes.roi.crops)


def test_packed_crops_of_the_wrong_size_are_refused(tmp_path):
    path = tmp_path / "p.gaitproj"
    save_project(make_project(None), path)
    doc = json.loads(path.read_text())
    doc["silhouettes"]["crops_shape"] = [6, 9, 17]
    path.write_text(json.dumps(doc))
    with pytest.raises(GaitInputError, match="does not hold 6 crops of 9 x 17 pixels"):
        load_project(path)


def test_a_missing_sidecar_folder_says_what_to_do(tmp_path):
    path = tmp_path / "p.gaitproj"
    save_project(make_project(None), path)
    for f in sidecar_dir(path).iterdir():
        f.unlink()
    with pytest.raises(GaitInputError, match="keep the folder"):
        load_project(path)


def test_erasing_hits_only_strokes_of_the_frame_near_the_point():
    project = make_project(None)
    assert project.strokes_hit(2, (2.0, 3.2), 1.0) == {0}
    assert project.strokes_hit(3, (2.0, 3.2), 1.0) == set()
    assert project.strokes_hit(2, (30.0, 30.0), 1.0) == set()


def test_pinning_a_dropped_frame_allows_it():
    project = Project().with_key_constraint(4, pinned=None, forbidden=True)
    pinned = project.with_key_constraint(4, pinned=True, forbidden=None)
    assert pinned.settings.pinned == (4,) and pinned.settings.forbidden == ()


def test_the_posed_skeleton_and_poses_survive_a_round_trip(tmp_path):
    from gaitcore.rig.templates import load_template

    skeleton = load_template("horse")
    pose = np.linspace(-5, 5, skeleton.n_channels)
    project = Project(skeleton=skeleton).with_pose(7, pose)
    save_project(project, tmp_path / "s.gaitproj")
    again = load_project(tmp_path / "s.gaitproj")
    assert again == project
    assert again.skeleton.channel_names == skeleton.channel_names
    np.testing.assert_array_equal(again.key_poses[7], pose)
    assert project.with_pose(7, None).key_poses == {}
    with pytest.raises(GaitInputError):
        project.with_pose(3, [1.0, float("nan")])


def test_animation_options_default_for_older_files_and_are_checked(tmp_path):
    save_project(Project(), tmp_path / "p.gaitproj")
    doc = json.loads((tmp_path / "p.gaitproj").read_text())
    assert doc["animation"] == {"filtered": False, "clamp": False, "loop": False,
                                "root_motion": "auto", "root_speed_m_s": 0.0,
                                "ground_contact": True,
                                "bone_names": "as-is"}
    del doc["animation"]  # saved before the options were kept
    (tmp_path / "p.gaitproj").write_text(json.dumps(doc))
    assert load_project(tmp_path / "p.gaitproj").animation == AnimationOptions()
    doc["animation"] = {"filtered": True, "clamp": False, "loop": True}  # before export options
    (tmp_path / "p.gaitproj").write_text(json.dumps(doc))
    assert load_project(tmp_path / "p.gaitproj").animation == AnimationOptions(filtered=True,
                                                                              loop=True)
    for bad in ({"loop": "yes"}, {"root_motion": "sideways"}, {"root_motion": 1},
                {"bone_names": True}):
        doc["animation"] = bad
        (tmp_path / "p.gaitproj").write_text(json.dumps(doc))
        with pytest.raises(GaitInputError, match="damaged"):
            load_project(tmp_path / "p.gaitproj")


def test_export_options_are_saved(tmp_path):
    options = AnimationOptions(loop=True, root_motion="forward", ground_contact=False,
                               bone_names="rigify")
    save_project(Project(animation=options), tmp_path / "p.gaitproj")
    assert load_project(tmp_path / "p.gaitproj").animation == options
    with pytest.raises(GaitInputError, match="root motion"):
        AnimationOptions(root_motion="backwards")


@pytest.mark.parametrize("entry", [{"scale": -1.0}, {"scale": "big"}, {"flip": 1}, [1, 2],
                                   {"offset_x_m": float("inf")}])
def test_a_bad_footage_fit_is_a_damaged_file(tmp_path, entry):
    save_project(Project(), tmp_path / "p.gaitproj")
    doc = json.loads((tmp_path / "p.gaitproj").read_text())
    assert doc["footage_fit"] == {"scale": 1.0, "offset_x_m": 0.0, "offset_y_m": 0.0,
                                  "flip": False}
    doc["footage_fit"] = entry
    (tmp_path / "p.gaitproj").write_text(json.dumps(doc))
    with pytest.raises(GaitInputError, match="is damaged"):
        load_project(tmp_path / "p.gaitproj")


def test_trim_and_frame_rate_survive_save_and_reopen_and_older_files_are_untrimmed(tmp_path):
    path = tmp_path / "p.gaitproj"
    save_project(Project(fps=29.97).with_trim(40, 136), path)
    again = load_project(path)
    assert again.trim == (40, 136) and again.fps == 29.97
    doc = json.loads(path.read_text())
    doc["version"] = 2  # written before the trim existed: its range cut the footage
    path.write_text(json.dumps(doc))
    assert load_project(path).trim == (0, None)


def _saved(tmp_path):
    path = tmp_path / "p.gaitproj"
    save_project(make_project(None), path)
    return path, json.loads(path.read_text())


def _npy_header(descr: str, shape: tuple) -> bytes:
    header = f"{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}"
    header += " " * (117 - len(header)) + "\n"
    return b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode()


@pytest.mark.parametrize("damage", ["empty", "truncated", "2 PiB", "object", "folder",
                                    "600 MB header"])
def test_a_damaged_sidecar_array_is_one_clear_error(tmp_path, damage):
    path, doc = _saved(tmp_path)
    f = sidecar_dir(path) / doc["silhouettes"]["arrays"]["centers_xy"]
    data = f.read_bytes()
    if damage == "folder":
        f.unlink()
        f.mkdir()
    else:
        f.write_bytes({"empty": b"", "truncated": data[:-9],
                       "2 PiB": _npy_header("|u1", (2**51,)) + b"\0" * 64,
                       "object": _npy_header("|O", (2,)) + b"\0" * 16,
                       "600 MB header": b"\x93NUMPY\x02\x00" + (600 << 20).to_bytes(4, "little")
                       + b"{" * 64}[damage])
    tracemalloc.start()
    try:
        with pytest.raises(GaitInputError, match=f.name) as info:
            load_project(path)
        assert tracemalloc.get_traced_memory()[1] < 20 << 20, "allocated what the header said"
    finally:
        tracemalloc.stop()
    assert "\n" not in str(info.value)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_a_pipe_in_the_sidecar_folder_is_refused_without_blocking(tmp_path):
    path, doc = _saved(tmp_path)
    f = sidecar_dir(path) / doc["silhouettes"]["arrays"]["lost"]
    f.unlink()
    os.mkfifo(f)
    with pytest.raises(GaitInputError, match="not a regular file"):
        load_project(path)


@pytest.mark.parametrize("field, value, words", [
    ("footage", 7, "footage must be an object"),
    ("frame_start", "1e400", "frame_start must be a whole number"),
    ("fps", "NaN", "fps must be a finite number from 0.001"),
    ("fps", -24, "fps must be a finite number from 0.001"),
    ("key_poses", [1, 2], "key_poses must be an object"),
    ("subject_rects", [[0, 0, "9" * 400, 5]], r"subject_rects\[0\]\[2\] must be a whole number"),
])
def test_values_that_would_break_the_app_later_are_refused_on_open(tmp_path, field, value, words):
    path, doc = _saved(tmp_path)
    text = json.dumps(dict(doc, **{field: "__RAW__"}))
    raw = value if isinstance(value, str) and value[0] in "1N9" else json.dumps(value)
    path.write_text(text.replace('"__RAW__"', raw))
    before = path.read_bytes()
    with pytest.raises(GaitInputError, match=words):
        load_project(path)
    assert path.read_bytes() == before


@pytest.mark.parametrize("scale", [0, "NaN", -1])
def test_a_silhouette_scale_that_is_not_positive_is_refused(tmp_path, scale):
    path, doc = _saved(tmp_path)
    doc["silhouettes"]["scale"] = "__RAW__"
    path.write_text(json.dumps(doc).replace('"__RAW__"', str(scale)))
    with pytest.raises(GaitInputError, match="silhouettes.scale must be a finite number above 0"):
        load_project(path)


def test_json_nested_100000_deep_is_one_line(tmp_path):
    path = tmp_path / "deep.gaitproj"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(GaitInputError, match="nests lists or objects too deeply"):
        load_project(path)


def test_too_many_rectangles_are_refused_with_the_limit(tmp_path):
    path, doc = _saved(tmp_path)
    doc["subject_rects"] = [[1, 1, 2, 2]] * (MAX_RECTS + 1)
    path.write_text(json.dumps(doc))
    with pytest.raises(GaitInputError, match=f"subject_rects must be a list of 0 to {MAX_RECTS}"):
        load_project(path)


def test_temporary_files_of_a_killed_save_are_removed_by_the_next_save(tmp_path):
    path, doc = _saved(tmp_path)
    side = sidecar_dir(path)
    stale = [tmp_path / ".p.gaitproj.4242.tmp",
             side / f".{doc['silhouettes']['arrays']['lost']}.4242.tmp"]
    other = tmp_path / ".q.gaitproj.4242.tmp"  # another project's: not ours to delete
    for f in stale + [other]:
        f.write_bytes(b"half written")
    save_project(make_project(None), path)
    assert not any(f.exists() for f in stale) and other.exists()


def test_too_many_strokes_are_refused_with_the_limit(tmp_path):
    path, doc = _saved(tmp_path)
    doc["strokes"] = [{"frame": 0, "width_px": 2.0, "points_xy": [[1, 2]]}] * (MAX_STROKES + 1)
    path.write_text(json.dumps(doc))
    with pytest.raises(GaitInputError, match=f"strokes must be a list of 0 to {MAX_STROKES}"):
        load_project(path)


def test_rig_proportions_default_for_older_files_and_are_checked(tmp_path):
    save_project(Project(proportions=RigProportions(legs=1.1)), tmp_path / "p.gaitproj")
    doc = json.loads((tmp_path / "p.gaitproj").read_text())
    assert doc["proportions"]["legs"] == 1.1
    del doc["proportions"]  # saved before proportions existed
    (tmp_path / "p.gaitproj").write_text(json.dumps(doc))
    assert load_project(tmp_path / "p.gaitproj").proportions == RigProportions()
    doc["proportions"] = {"neck": 0.0}
    (tmp_path / "p.gaitproj").write_text(json.dumps(doc))
    with pytest.raises(GaitInputError, match="damaged"):
        load_project(tmp_path / "p.gaitproj")


def test_the_box_around_the_animal_is_saved_and_older_files_have_none(tmp_path):
    path = tmp_path / "p.gaitproj"
    save_project(Project(box=Rect(10, 20, 300, 150)), path)
    assert load_project(path).box == Rect(10, 20, 300, 150)
    doc = json.loads(path.read_text())
    del doc["box"]  # saved before the box existed
    path.write_text(json.dumps(doc))
    assert load_project(path).box is None
    doc["box"] = [10, 20, 0, 150]
    path.write_text(json.dumps(doc))
    with pytest.raises(GaitInputError, match="box"):
        load_project(path)
