"""The segmentation engine saved beside a project: reopened, the first correction
re-propagates only around its frame; damaged, stale or missing, the project still opens."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from gaitcore.bench.scripted_user import padded_box
from gaitcore.errors import GaitInputError
from gaitcore.footage.sources import open_frames
from gaitcore.project.document import Project
from gaitcore.project.engine_file import (
    ENGINE_FILE,
    engine_fingerprint,
    read_engine,
    resumed,
    save_engine,
    saved_frames_to_check,
    write_engine,
)
from gaitcore.project.roto_session import RotoSession, corrected, erased
from gaitcore.project.storage import load_project, save_project, sidecar_dir, write_array
from gaitcore.silhouettes.annotations import Rect, Scribble
from gaitcore.silhouettes.ground import StillBackground
from gaitcore.silhouettes.packed_masks import PackedMasks
from gaitcore.silhouettes.propagate import Cut, WorkingSize
from gaitcore.silhouettes.roto import FrameState
from gaitcore.silhouettes.roto_state import RotoState
from tests.fuzzing import DEFAULT_CASES, fuzz
from tests.gaitcore.conftest import SCENE_FRAMES
from tests.gaitcore.test_fuzz_readers import sidecar_cases
from tests.gaitcore.test_roto_session import shaded_scene

N = SCENE_FRAMES
KEY = Scribble([[40.0, 52.0]], 4, 5, "subject")
"""A stroke on frame 5: a key frame that bounds the range a later correction changes."""
WRONG = Scribble([[30.0, 50.0], [70.0, 50.0]], 6, 11, "background")  # across the body
ABOVE = Scribble([[44.0, 36.0], [54.0, 36.0]], 4, 5, "subject")
"""A subject stroke on the grass above the back on frame 5: its cut turns pixels to the
subject, which the passes from frame 5 carry."""



def _saved_project(scene_images, path, scribbles=(KEY,)):
    """A segmented project saved with its engine at ``path``; returns the session."""
    folder, truth = scene_images
    project = Project(footage=folder, box=padded_box(truth[0]), scribbles=tuple(scribbles))
    with open_frames(folder) as source:
        session = RotoSession.start(source, project)
        project = replace(project, silhouettes=session.silhouettes())
        save_project(project, path)
        assert save_engine(path, project, session)
    return project, session


def _no_full_segmentation(monkeypatch):
    def refuse(*_args, **_kwargs):
        raise AssertionError("the whole clip was segmented again")
    monkeypatch.setattr(RotoSession, "start", refuse)


def test_a_reopened_project_corrects_as_the_session_that_stayed_open(scene_images, tmp_path,
                                                                     monkeypatch):
    path = tmp_path / "horse.gaitproj"
    project, _ = _saved_project(scene_images, path)
    with open_frames(scene_images[0]) as source:
        kept = RotoSession.start(source, project)
        kept.correct(project, [WRONG])
        loaded = load_project(path)
        _no_full_segmentation(monkeypatch)
        session = corrected(resumed(None, source, loaded, saved=path), source, loaded, [WRONG])
        assert session.silhouettes() == kept.silhouettes()
        assert session.states() == kept.states()
        # Only the frames after the key frame on 5 were cut again, not the whole clip.
        assert session.changed == kept.changed == (KEY.frame + 1, N)
        # Undo in the reopened session: back to the state saved with the project.
        assert session.restore(loaded) and session.silhouettes() == project.silhouettes


def test_a_reopened_project_erases_as_the_session_that_stayed_open(scene_images, tmp_path,
                                                                    monkeypatch):
    """Erasing the stroke on frame 11 carries frame 5's passes across it again, with what the
    strokes on frame 5 turned to the subject: the reopened engine holds that too (here it
    changes no mask: the camera holds still, and what lies behind the animal outweighs it)."""
    path = tmp_path / "horse.gaitproj"
    project, _ = _saved_project(scene_images, path, (KEY, ABOVE, WRONG))
    with open_frames(scene_images[0]) as source:
        kept = erased(RotoSession.start(source, project), source, project, {2})
        loaded = load_project(path)
        _no_full_segmentation(monkeypatch)
        session = erased(resumed(None, source, loaded, saved=path), source, loaded, {2})
        assert session.silhouettes() == kept.silhouettes()
        assert session.changed == kept.changed == (KEY.frame + 1, N)
        after = loaded.without_scribbles({2})
        turned, want = session.state_for(after).turned, kept.state_for(after).turned
        assert turned.frames == want.frames == (KEY.frame,)
        assert np.array_equal(turned.get(KEY.frame).mask, want.get(KEY.frame).mask)


def test_the_engine_is_small_and_holds_the_masks_exactly(scene_images, tmp_path):
    path = tmp_path / "horse.gaitproj"
    project, session = _saved_project(scene_images, path, (KEY, ABOVE))
    side = sidecar_dir(path)
    engine_bytes = sum(f.stat().st_size for f in side.glob("engine*"))
    assert 0 < engine_bytes < 64 * 1024
    state = read_engine(path, engine_fingerprint(load_project(path)))
    assert state is not None
    original = session.state_for(project)
    assert original.turned.frames == (KEY.frame,)
    for got, want in ((state.keys, original.keys), (state.fwd, original.fwd),
                      (state.bwd, original.bwd), (state.turned, original.turned)):
        assert got.frames == want.frames
        for t in want.frames:
            a, b = got.get(t), want.get(t)
            assert np.array_equal(a.mask, b.mask) and a.confidence == b.confidence
    # The scene's camera holds still: what lies behind the animal is kept as learnt.
    assert original.still is not None and state.still is not None
    assert np.array_equal(state.still.image, original.still.image)
    assert np.array_equal(state.still.known, original.still.known)


def _truncate(side):
    table = next(side.glob("engine-table-*.npy"))
    table.write_bytes(table.read_bytes()[:-40])


def _garble(side):
    """Flip bytes in the middle of the masks: the file still reads as an array."""
    bits = next(side.glob("engine-bits-*.npy"))
    data = bytearray(bits.read_bytes())
    for i in range(len(data) // 2, len(data) // 2 + 16):
        data[i] ^= 0xFF
    bits.write_bytes(bytes(data))


def _bad_json(side):
    (side / ENGINE_FILE).write_text("{not json")


def _swap_boxes(side):
    """A table of boxes past the working size, saved under its own (right) name."""
    doc = json.loads((side / ENGINE_FILE).read_text())
    table_file = side / doc["arrays"]["table"]
    table = np.load(table_file, allow_pickle=False)
    table[:, 2] += 10_000
    doc["arrays"]["table"] = write_array(side, "engine-table", table)
    (side / ENGINE_FILE).write_text(json.dumps(doc))


def _missing(side):
    for f in side.glob("engine-bits-*.npy"):
        f.unlink()


def _other_version(side):
    doc = json.loads((side / ENGINE_FILE).read_text())
    doc["version"] = 99
    (side / ENGINE_FILE).write_text(json.dumps(doc))


@pytest.mark.parametrize("damage", [_truncate, _garble, _bad_json, _swap_boxes, _missing,
                                    _other_version])
def test_a_damaged_engine_is_ignored_and_the_correction_segments_again(scene_images, tmp_path,
                                                                        damage):
    path = tmp_path / "horse.gaitproj"
    _saved_project(scene_images, path)
    damage(sidecar_dir(path))
    loaded = load_project(path)  # the project opens
    with open_frames(scene_images[0]) as source:
        assert resumed(None, source, loaded, saved=path) is None
        session = corrected(resumed(None, source, loaded, saved=path), source, loaded, [WRONG])
        fresh = RotoSession.start(source, loaded.with_scribbles((WRONG,)))
        assert session.changed == (0, N) and session.silhouettes() == fresh.silhouettes()


def test_an_engine_of_other_inputs_is_never_used(scene_images, tmp_path):
    path = tmp_path / "horse.gaitproj"
    project, _ = _saved_project(scene_images, path)
    moved = project.with_scribbles((Scribble([[60.0, 40.0]], 4, 3, "background"),))
    with open_frames(scene_images[0]) as source:
        assert resumed(None, source, moved, saved=path) is None
    # Saved without a session, the stale engine is removed; a matching one is kept.
    save_project(moved, path)
    assert not save_engine(path, moved, None)
    assert not list(sidecar_dir(path).glob("engine*"))


def test_save_as_carries_the_engine_and_undo_states_are_saved(scene_images, tmp_path):
    path = tmp_path / "horse.gaitproj"
    project, session = _saved_project(scene_images, path)
    other = tmp_path / "copy" / "horse.gaitproj"
    save_project(project, other)
    assert save_engine(other, project, None, opened_from=path)
    assert read_engine(other, engine_fingerprint(project)) is not None
    with open_frames(scene_images[0]) as source:
        session = RotoSession.start(source, project)
        session.correct(project, [WRONG])
        # After an undo the project is the one without WRONG: its kept state is saved.
        assert save_engine(path, project, session)
        assert resumed(None, source, project, saved=path) is not None


def test_a_reopened_project_names_its_frames_to_check_without_reading_its_masks(
        tmp_path, without_saliency):
    folder, path = tmp_path / "shade", tmp_path / "shade.gaitproj"
    project = Project(footage=folder, box=shaded_scene(folder))
    with open_frames(folder) as source:
        session = RotoSession.start(source, project)
    project = replace(project, silhouettes=session.silhouettes())
    save_project(project, path)
    assert save_engine(path, project, session)
    loaded = load_project(path)
    assert saved_frames_to_check(path, loaded) == session.to_check(project) == (5, 6, 7, 8)
    assert read_engine(path, engine_fingerprint(loaded)).frame_states == session.states()
    copy = tmp_path / "copy" / "shade.gaitproj"  # "save as" without a session carries them
    save_project(loaded, copy)
    assert save_engine(copy, loaded, None, opened_from=path)
    assert saved_frames_to_check(copy, loaded) == (5, 6, 7, 8)
    for f in sidecar_dir(path).glob("engine-bits-*.npy"):
        f.unlink()  # the masks are not read
    assert saved_frames_to_check(path, loaded) == (5, 6, 7, 8)
    assert read_engine(path, engine_fingerprint(loaded)) is None
    assert saved_frames_to_check(path, replace(loaded, box=Rect(10, 30, 80, 50))) is None
    doc = json.loads((sidecar_dir(copy) / ENGINE_FILE).read_text())
    del doc["arrays"]["states"]  # an engine saved before the states were
    (sidecar_dir(copy) / ENGINE_FILE).write_text(json.dumps(doc))
    assert saved_frames_to_check(copy, loaded) is None
    assert read_engine(copy, engine_fingerprint(loaded)).frame_states == ()


def test_packed_masks_round_trip_and_refuse_bad_arrays():
    rng = np.random.default_rng(1)
    masks = PackedMasks((20, 30))
    for t in (0, 3, 7):
        m = np.zeros((20, 30), np.uint8)
        m[2 + t : 9 + t, 4:17] = rng.integers(0, 2, (7, 13))
        masks.put(t, Cut(m, t / 10))
    masks.put(9, Cut(np.zeros((20, 30), np.uint8), 0.0))  # empty: lost
    table, bits = masks.to_arrays()
    back = PackedMasks.from_arrays((20, 30), table, bits, n_frames=10)
    assert back.frames == (0, 3, 7, 9)
    for t in back.frames:
        assert np.array_equal(back.get(t).mask, masks.get(t).mask)
        assert back.get(t).confidence == masks.get(t).confidence
    for bad_table, bad_bits, n in ((table, bits[:-1], 10), (table, bits, 8),
                                   (table + [[0, 0, 0, 30, 0, 0]], bits, 10),
                                   (table + [[0, 1e18, 0, 0, 0, 0]], bits, 10),
                                   (table[:, :5], bits, 10)):
        with pytest.raises(GaitInputError, match="damaged"):
            PackedMasks.from_arrays((20, 30), bad_table, bad_bits, n_frames=n)


def test_fuzzed_engine_files_read_as_none_or_as_masks_that_fit(tmp_path):
    """Whatever the sidecar holds, reading the engine raises nothing (issue #15's fuzzing)."""
    rng = np.random.default_rng(2)
    stores = []
    for frames in ((0, 4), (1, 2, 3, 5), (1, 2, 3), (4,)):
        masks = PackedMasks((12, 16))
        for t in frames:
            masks.put(t, Cut((rng.random((12, 16)) > 0.5).astype(np.uint8), 0.5))
        stores.append(masks)
    still = StillBackground(rng.integers(0, 256, (12, 16, 3), dtype=np.uint8),
                            rng.random((12, 16)) > 0.2)
    states = tuple(FrameState(t in (2, 3), t == 4, round(t / 5, 3)) for t in range(6))
    state = RotoState(6, WorkingSize(0.5, (16, 12), (24, 32), 20.0), *stores, still,
                      states)
    valid = tmp_path / "valid" / "p.gaitproj"
    write_engine(valid, "f" * 64, state)
    cases, write_case = sidecar_cases(valid, lambda path: sidecar_dir(path) / ENGINE_FILE,
                                      sorted(f.name for f in sidecar_dir(valid).glob("engine-*")))

    def fits(read):
        if read is None:
            return
        for masks in (read.keys, read.fwd, read.bwd, read.turned):
            for t in masks.frames:
                assert 0 <= t < read.n_frames
                assert masks.get(t).mask.shape == read.work.wh[::-1]
        if read.still is not None:
            assert read.still.image.shape == (*read.work.wh[::-1], 3)
            assert read.still.known.shape == read.work.wh[::-1]
        assert len(read.frame_states) in (0, read.n_frames)
        assert all(0 <= st.confidence <= 1 for st in read.frame_states)

    fuzz(cases, write_case, lambda p: read_engine(p, "f" * 64), tmp_path / "cases",
         n_cases=DEFAULT_CASES, check=fits)
    assert read_engine(valid, "f" * 64).frame_states == states
