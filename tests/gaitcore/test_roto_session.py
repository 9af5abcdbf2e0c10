"""The project's segmentation kept alive between corrections, undone and redone."""

from __future__ import annotations

import json
from dataclasses import replace

import cv2
import numpy as np
import pytest

from gaitcore.bench.scripted_user import padded_box
from gaitcore.errors import GaitInputError
from gaitcore.footage.sources import open_frames
from gaitcore.progress import Cancelled
from gaitcore.project.document import Project
from gaitcore.project.roto_session import RotoSession, corrected, erased, export_masks
from gaitcore.project.steps import segment
from gaitcore.project.storage import load_project, save_project
from gaitcore.silhouettes.annotations import Rect, Scribble
from tests.gaitcore.conftest import SCENE_FRAMES

N = SCENE_FRAMES
WRONG = Scribble([[30.0, 50.0], [70.0, 50.0]], 6, 9, "background")  # across the body



def _project(scene_images, scribbles=()):
    folder, truth = scene_images
    return Project(footage=folder, box=padded_box(truth[0]), scribbles=tuple(scribbles))


def test_session_segments_as_the_project_step(scene_images):
    project = _project(scene_images, [Scribble([[40.0, 52.0]], 4, 5, "subject")])
    with open_frames(scene_images[0]) as source:
        assert RotoSession.start(source, project).silhouettes() == segment(source, project)


def test_the_session_and_the_step_segment_with_the_project_s_profile(scene_images,
                                                                     saliency_rates):
    """One profile for the app's engine and the command's step: the project's."""
    from dataclasses import replace

    import gaitcore.silhouettes.roto as roto
    from gaitcore.silhouettes.settings import PropagationSettings, SegmentationSettings

    asked = saliency_rates
    project = replace(_project(scene_images), segmentation=SegmentationSettings(
        propagation=PropagationSettings(saliency_every=3)))
    with open_frames(scene_images[0]) as source:
        assert RotoSession.start(source, project).silhouettes() == segment(source, project)
    if roto.saliency_model() is not None:
        assert asked and set(asked) == {3}


def test_a_correction_changes_only_its_range_and_undo_finds_the_older_state(scene_images):
    project = _project(scene_images)
    with open_frames(scene_images[0]) as source:
        session = RotoSession.start(source, project)
        before = session.silhouettes()
        after_project = project.with_scribbles((WRONG,))
        assert corrected(session, source, project, [WRONG]) is session
        first, stop = session.changed
        assert first <= WRONG.frame < stop
        after = session.silhouettes()
        assert not np.array_equal(after.roi.crops[WRONG.frame], before.roi.crops[WRONG.frame])
        assert session.states()[WRONG.frame].corrected
        assert session.matches(after_project) and session.matches(project)
        # Undo: the project without the stroke; a stroke on another frame is then made on
        # the state before the first one, never on top of it.
        other = Scribble([[80.0, 20.0]], 4, 13, "background")
        session.correct(project, [other])
        again = session.silhouettes()
        fresh = RotoSession.start(source, project.with_scribbles((other,))).silhouettes()
        assert again == fresh
        assert not session.states()[WRONG.frame].corrected


def shaded_scene(folder):
    """A brown body crossing green grass, 12 frames of 160x120 written to ``folder``: on
    frames 5-7 it walks through a shade that fades it half-way to the grass. Frame 5 is kept
    at a low confidence, 6 and 7 are lost, 8 is where it is found again. Returns the box of
    frame 0."""
    rng = np.random.default_rng(11)
    green, brown = np.array([60, 140, 70]), np.array([40, 80, 160])
    folder.mkdir(parents=True, exist_ok=True)
    for t in range(12):
        image = np.clip(rng.normal(green, 8, (120, 160, 3)), 0, 255).astype(np.uint8)
        body = np.zeros((120, 160), np.uint8)
        cv2.ellipse(body, (50 + 3 * t, 60), (30, 16), 0, 0, 360, 1, -1)
        shade = 0.55 if 5 <= t <= 7 else 0.0
        colour = (1 - shade) * brown + shade * green
        image[body > 0] = np.clip(rng.normal(colour, 8, (int(body.sum()), 3)), 0, 255)
        cv2.imwrite(str(folder / f"{t:05d}.png"), image)
    return Rect(14, 38, 72, 44)


def test_the_frames_to_check_are_the_lost_and_the_doubtful_not_the_corrected(tmp_path,
                                                                           without_saliency):
    from gaitcore.silhouettes.roto import DOUBTFUL_BELOW

    folder = tmp_path / "shade"
    project = Project(footage=folder, box=shaded_scene(folder))
    with open_frames(folder) as source:
        session = RotoSession.start(source, project)
        states = session.states()
        assert session.to_check(project) == (5, 6, 7, 8)
        assert not states[5].lost and states[5].confidence < DOUBTFUL_BELOW
        assert states[6].lost and states[7].lost and not states[8].lost
        assert min(st.confidence for t, st in enumerate(states) if t not in (5, 6, 7, 8)) > 0.9
        fix = Scribble([[55.0, 60.0], [75.0, 60.0]], 6, 6, "subject")
        session.correct(project, [fix])
        fixed = project.with_scribbles((fix,))
        assert 6 not in session.to_check(fixed) and session.states()[6].corrected
        assert session.to_check(fixed) == ()  # the stroke found the faded body, carried both ways
        assert 6 in session.to_check(project)  # the state before, kept for undo
        assert session.to_check(replace(project, box=Rect(10, 30, 80, 50))) == ()
    # A background stroke alone on the lost frame: its cut is empty, and the passes from it
    # search for the body with the nearest key's colours (found again on frame 8, as before).
    grass = Scribble([[20.0, 100.0], [60.0, 100.0]], 4, 6, "background")
    with open_frames(folder) as source:
        session = RotoSession.start(source, project)
        session.correct(project, [grass])
        assert session.to_check(project.with_scribbles((grass,))) == (5, 7, 8)


def test_cancelled_correction_leaves_the_session_usable(scene_images):
    project = _project(scene_images)
    with open_frames(scene_images[0]) as source:
        session = RotoSession.start(source, project)
        before = session.silhouettes()
        with pytest.raises(Cancelled):
            session.correct(project, [WRONG], lambda done, total: False)
        assert session.restore(project) and session.silhouettes() == before


def test_without_a_session_a_correction_segments_again(scene_images):
    project = _project(scene_images)
    with open_frames(scene_images[0]) as source:
        session = corrected(None, source, project, [WRONG])
        assert session.silhouettes() == segment(source, project.with_scribbles((WRONG,)))


def test_erasing_a_correction_gives_back_the_segmentation_before_it(scene_images):
    project = _project(scene_images)
    with open_frames(scene_images[0]) as source:
        session = RotoSession.start(source, project)
        before = session.silhouettes()
        painted = project.with_scribbles((WRONG,))
        session.correct(project, [WRONG])
        assert erased(session, source, painted, {0}) is session
        first, stop = session.changed
        assert first <= WRONG.frame < stop
        assert session.silhouettes() == before and not session.states()[WRONG.frame].corrected
        assert session.matches(project)
        # Undo of the erase: the painted project's state is still there.
        assert session.restore(painted) and session.states()[WRONG.frame].corrected


def test_a_cancelled_erase_leaves_the_session_usable(scene_images):
    project = _project(scene_images, [WRONG])
    with open_frames(scene_images[0]) as source:
        session = RotoSession.start(source, project)
        before = session.silhouettes()
        with pytest.raises(Cancelled):
            session.erase(project, {0}, lambda done, total: False)
        assert session.restore(project) and session.silhouettes() == before


def test_without_a_session_erasing_segments_again(scene_images):
    other = Scribble([[80.0, 20.0]], 4, 13, "background")
    project = _project(scene_images, [WRONG, other])
    with open_frames(scene_images[0]) as source:
        session = erased(None, source, project, {0})
        assert session.silhouettes() == segment(source, _project(scene_images, [other]))


def test_erasing_what_frame_0_starts_from_says_why_and_keeps_the_session(scene_images):
    folder, truth = scene_images
    ys, xs = np.nonzero(truth[0])
    project = Project(footage=folder, scribbles=(Scribble(np.c_[xs, ys][::60], 4, 0, "subject"),),
                      background_rects=(Rect(0, 0, 20, 20),))
    with open_frames(folder) as source:
        session = RotoSession.start(source, project)
        before = session.silhouettes()
        with pytest.raises(GaitInputError, match="draw a box"):
            session.erase(project, {0})
        assert session.silhouettes() == before


def test_erasing_hits_only_brush_strokes_of_the_frame_near_the_point():
    a = Scribble([[10.0, 10.0], [30.0, 10.0]], 4, 2, "subject")
    b = Scribble([[10.0, 10.0], [30.0, 10.0]], 4, 3, "subject")
    c = Scribble([[10.0, 20.0]], 4, 2, "background")
    project = Project(scribbles=(a, b, c))
    assert project.scribbles_hit(2, (20.0, 12.5), 1.0) == {0}  # 2.5 px from the line
    assert project.scribbles_hit(2, (20.0, 13.5), 1.0) == set()  # beyond the pen's edge
    assert project.scribbles_hit(2, (10.0, 15.0), 3.0) == {0, 2}
    assert project.strokes_hit(2, (20.0, 10.0), 1.0) == set()
    assert project.without_scribbles({0, 2}).scribbles == (b,)


def test_export_masks_as_the_command_writes_them(scene_images, tmp_path):
    project = _project(scene_images, [WRONG])
    with open_frames(scene_images[0]) as source:
        session = RotoSession.start(source, project)
        assert export_masks(session, tmp_path, source_name="scene") == N
    masks = sorted((tmp_path / "masks").glob("*.png"))
    assert [m.name for m in masks] == [f"{t:05d}.png" for t in range(N)]
    first = cv2.imread(str(masks[0]), cv2.IMREAD_UNCHANGED)
    assert first.shape == scene_images[1][0].shape and set(np.unique(first)) <= {0, 255}
    data = json.loads((tmp_path / "segmentation.json").read_text())
    assert data["n_frames"] == N and data["frames"][WRONG.frame]["corrected"]


def test_scribbles_are_saved_with_the_project(scene_images, tmp_path):
    project = _project(scene_images, [WRONG, Scribble([[40.0, 52.0], [45, 60]], 4.5, 5, "subject")])
    save_project(project, tmp_path / "p.gaitproj")
    loaded = load_project(tmp_path / "p.gaitproj")
    assert loaded.scribbles == project.scribbles and loaded.corrected_frames() == (5, 9)


def test_old_project_files_open_without_scribbles(scene_images, tmp_path):
    path = tmp_path / "old.gaitproj"
    save_project(_project(scene_images), path)
    doc = json.loads(path.read_text())
    del doc["scribbles"]
    path.write_text(json.dumps(doc))
    assert load_project(path).scribbles == ()
    doc["scribbles"] = [{"frame": 1, "label": "sky", "width_px": 3, "points_xy": [[1, 2]]}]
    path.write_text(json.dumps(doc))
    with pytest.raises(Exception, match=r"scribbles\[0\]\.label"):
        load_project(path)
