"""The segmentation engine of a project, kept alive between corrections (the Roto Brush model).

:func:`gaitcore.project.steps.segment` segments a clip and forgets how; an artist who paints a
correction on frame 57 wants only the frames around 57 cut again. A :class:`RotoSession`
keeps the :class:`~gaitcore.silhouettes.roto.RotoSegmentation` of the last run and every
frame's tight crop, so that a correction (or the erasing of one) re-propagates only up to the
neighbouring corrected frames and rebuilds the project's
:class:`~gaitcore.project.document.Silhouettes` from the crops it already has.

Undo puts back an older project; the session then no longer matches it. It keeps copies of
its last few states, one per set of inputs (box, rectangles, brush strokes), and goes back to
the one matching the project; when none does, the next correction segments the clip again
from the project's inputs, so a correction is always right for the project it is made on.
Qt-free: the app runs these methods in its jobs, a script can call them directly.

Saved beside the project (:mod:`gaitcore.project.engine_file`: :meth:`RotoSession.state_for`
gives what is saved, :meth:`RotoSession.from_state` puts it back), the engine comes back when
the project is reopened, so that the first correction then is as quick as the next ones.
"""

from __future__ import annotations

import copy
from collections import OrderedDict
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.footage.image_folder import MaskWriter
from gaitcore.footage.sources import FrameSource
from gaitcore.io.scribbles import write_segmentation_json
from gaitcore.progress import Progress, report
from gaitcore.project.document import Project, Silhouettes
from gaitcore.project.steps import check_segmentation_input
from gaitcore.silhouettes.annotations import Rect, Scribble, Stroke
from gaitcore.silhouettes.roto import FrameState, RotoSegmentation, frames_to_check
from gaitcore.silhouettes.roto_state import RotoState, restore_state, roto_state
from gaitcore.silhouettes.segmentation import (
    RotoCollector,
    collect_roto,
    full_frame_mask,
    roto_frame,
    roto_frames,
)
from gaitcore.silhouettes.sketch import rasterize_strokes
from gaitcore.silhouettes.tracking import WORK_SIDE_PX, RoiAccumulator

MAX_SAVED_STATES = 4
"""States kept for undo: each is a copy of the engine (bit-packed masks at the working size,
about 4 MB per thousand frames of a 960x540 clip) and shares the crops of the frames a
correction did not change."""
ROI_MARGIN = 0.05
"""Border of the ROI windows, as :func:`gaitcore.silhouettes.segmentation.segment_clip`."""


def segmentation_key(project: Project) -> tuple:
    """What the segmentation of ``project`` depends on: footage, box, rectangles, brush
    strokes in painting order and the settings (two projects with equal keys segment alike)."""
    return (project.footage, project.box, project.subject_rects, project.background_rects,
            tuple(_scribble_key(sc) for sc in project.scribbles), project.segmentation)


def _scribble_key(sc: Scribble) -> tuple:
    return sc.frame, sc.label, sc.width_px, sc.points_xy.tobytes()


@dataclass
class _EngineState:
    """The engine, every frame's crop for the ROI windows, and every frame's state."""

    engine: RotoSegmentation
    crops: RoiAccumulator
    states: list[FrameState]
    key: tuple

    def copied(self, source) -> _EngineState:
        """A copy: the engine deep-copied but for the footage (frames are decoded again,
        never copied), the crops shared until replaced (:meth:`RoiAccumulator.copy`)."""
        engine = copy.deepcopy(self.engine, memo={id(source): source})
        return _EngineState(engine, self.crops.copy(), list(self.states), self.key)


class RotoSession:
    """The segmentation of one project's clip, kept for corrections; see the module docstring.

    Make one with :meth:`start`; the app keeps it for the project it was made on.

    Attributes
    ----------
    source : FrameSource
        The footage segmented (the whole clip; frame numbers are source frame numbers).
    changed : tuple of (int, int)
        Frames ``first <= t < stop`` the last :meth:`start` or :meth:`correct` changed.
    """

    def __init__(self, source: FrameSource, state: _EngineState) -> None:
        self.source = source
        self._state: _EngineState | None = state
        self._saved: OrderedDict[tuple, _EngineState] = OrderedDict()
        self.changed = (0, state.engine.n)
        self._save()

    @classmethod
    def start(cls, source: FrameSource, project: Project,
              progress: Progress | None = None) -> RotoSession:
        """Segment the whole clip from the project's box (or rectangles) and brush strokes.

        The silhouettes are those of :func:`gaitcore.project.steps.segment` (and of
        ``gaitcore segment`` with the same inputs).

        Raises
        ------
        GaitInputError
            Nothing to start from (no box, rectangles or subject stroke on frame 0), bad
            input, or no subject found in any frame.
        Cancelled
            When ``progress`` returned False.
        """
        engine = _engine(source, project, project.scribbles)
        states: dict[int, FrameState] = {}
        with RotoCollector(engine, None, states.__setitem__) as collect:
            engine.run(progress, final=collect)
        return cls._session(source, engine, project, collect.acc, states)

    @classmethod
    def from_state(cls, source: FrameSource, project: Project,
                   state: RotoState) -> RotoSession | None:
        """The session of ``project`` put back from a state kept by :meth:`state_for`,
        without cutting the clip again (its frames are read once, for the masks' outlines);
        None when the state does not fit the project's clip, working size or corrected
        frames (then :meth:`start`)."""
        try:
            engine = _engine(source, project, project.scribbles)
        except GaitInputError:
            return None
        if not restore_state(engine, state):
            return None
        return cls._finished(source, engine, project)

    @classmethod
    def _finished(cls, source: FrameSource, engine: RotoSegmentation,
                  project: Project) -> RotoSession:
        """A session on ``engine``, run for ``project``: every frame's crop and state."""
        states: dict[int, FrameState] = {}
        crops = collect_roto(engine, None, states.__setitem__)
        return cls._session(source, engine, project, crops, states)

    @classmethod
    def _session(cls, source: FrameSource, engine: RotoSegmentation, project: Project,
                 crops: RoiAccumulator, states: dict[int, FrameState]) -> RotoSession:
        return cls(source, _EngineState(engine, crops, [states[t] for t in range(engine.n)],
                                        segmentation_key(project)))

    # -- reading ----------------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return len(self.source)

    def matches(self, project: Project) -> bool:
        """True when the session holds (or kept) the segmentation of ``project``'s inputs."""
        return self._matching(project) is not None

    def silhouettes(self) -> Silhouettes:
        """The project's silhouettes from the crops of every frame (cheap: no frame is decoded
        or cut again).

        Raises
        ------
        GaitInputError
            The subject is lost in every frame.
        """
        return Silhouettes(self._current().crops.finish(margin=ROI_MARGIN, max_side=WORK_SIDE_PX),
                           "segmented")

    def states(self) -> tuple[FrameState, ...]:
        """Lost, corrected and confidence of every frame."""
        return tuple(self._current().states)

    def state_for(self, project: Project) -> RotoState | None:
        """The engine's state for ``project`` (current or kept for undo) as plain data, to
        save, every frame's :class:`FrameState` with it; None when the session holds none."""
        state = self._matching(project)
        return None if state is None else replace(roto_state(state.engine),
                                                  frame_states=tuple(state.states))

    def to_check(self, project: Project) -> tuple[int, ...]:
        """The frames of ``project``'s segmentation worth the artist's look
        (:func:`frames_to_check`: lost, of a low confidence, or grown or shrunk suddenly, and
        not corrected); none when the session holds no segmentation of its inputs."""
        state = self._matching(project)
        if state is None:
            return ()
        silhouettes = project.silhouettes
        return frames_to_check(state.states,
                               None if silhouettes is None else silhouettes.areas())

    def _matching(self, project: Project) -> _EngineState | None:
        """The state (current or kept for undo) of ``project``'s inputs, or None."""
        key = segmentation_key(project)
        if self._state is not None and self._state.key == key:
            return self._state
        return self._saved.get(key)

    def mask(self, t: int) -> np.ndarray:
        """Frame ``t``'s full-frame mask as the command writes it, (rows, cols) uint8 0/255:
        zeros where the subject is lost."""
        found, _ = roto_frame(self._current().engine, t)
        return full_frame_mask(found, self.source.shape[:2])

    # -- corrections ------------------------------------------------------------------------
    def restore(self, project: Project) -> bool:
        """Go back to the state matching ``project`` (after an undo or a redo); False when
        the session kept none (segment again with :meth:`start`)."""
        state = self._matching(project)
        if state is None:
            return False
        if state is not self._state:
            self._state = state.copied(self.source)
            self._saved.move_to_end(state.key)
        return True

    def correct(self, project: Project, scribbles: Sequence[Scribble],
                progress: Progress | None = None) -> None:
        """Add brush strokes to ``project``'s segmentation and re-propagate only where they
        matter: the stroked frames are cut again with the strokes as hard labels, and the
        change travels both ways up to the neighbouring corrected frames.

        Parameters
        ----------
        project : Project
            The project the strokes are painted on (without them); the session must
            :meth:`matches` it.
        scribbles : sequence of Scribble
        progress : callable(done, total) -> bool, optional

        Raises
        ------
        GaitInputError
            The session does not match ``project``, or a stroke outside the clip or frame.
        Cancelled
            When ``progress`` returned False (the session goes back to ``project``'s state).
        """
        self._change(project, project.with_scribbles(tuple(scribbles)),
                     lambda engine: engine.correct(list(scribbles), progress))

    def erase(self, project: Project, indices: Collection[int],
              progress: Progress | None = None) -> None:
        """Take brush strokes out of ``project``'s segmentation and re-propagate only where it
        matters: a frame that keeps strokes is cut again, one left without strokes stops
        being a corrected frame, and the change travels both ways up to the neighbouring
        corrected frames.

        Parameters
        ----------
        project : Project
            The project with the strokes; the session must :meth:`matches` it.
        indices : collection of int
            Positions of the strokes in ``project.scribbles``.
        progress : callable(done, total) -> bool, optional

        Raises
        ------
        GaitInputError
            The session does not match ``project``, or frame 0 is left with nothing to be cut
            from.
        Cancelled
            When ``progress`` returned False (the session goes back to ``project``'s state).
        """
        after = project.without_scribbles(indices)
        check_segmentation_input(after)  # before the engine is touched
        self._change(project, after, lambda engine: engine.erase(indices, progress))

    def _change(self, project: Project, after: Project,
                edit: Callable[[RotoSegmentation], tuple[int, int]]) -> None:
        """Go to ``project``'s state, ``edit`` its engine into ``after``'s and cut the crops
        of the frames it changed again."""
        if not self.restore(project):
            raise GaitInputError("the segmentation no longer matches the project: segment the "
                                 "clip again")
        state = self._current()
        try:
            first, stop = edit(state.engine)
            for t, found, frame_state in roto_frames(state.engine, first, stop):
                state.states[t] = frame_state
                state.crops.replace(t, found)
        except BaseException:
            self._state = None  # half changed: the saved copy of ``project`` is the truth
            raise
        state.key = segmentation_key(after)
        self.changed = (first, stop)
        self._save()

    def _current(self) -> _EngineState:
        if self._state is None:
            raise GaitInputError("the segmentation was interrupted: segment the clip again")
        return self._state

    def _save(self) -> None:
        """Keep a copy of the current state for undo (an engine that cannot be copied is
        simply segmented again after an undo)."""
        state = self._current()
        try:
            self._saved[state.key] = state.copied(self.source)
        except (TypeError, copy.Error):
            return
        self._saved.move_to_end(state.key)
        while len(self._saved) > MAX_SAVED_STATES:
            self._saved.popitem(last=False)


def reusable(session: RotoSession | None, source: FrameSource,
             project: Project) -> RotoSession | None:
    """``session``, back in ``project``'s state, when it segmented ``source`` and holds (or
    kept) ``project``'s segmentation; None otherwise."""
    if session is not None and session.source is source and session.restore(project):
        return session
    return None


def corrected(session: RotoSession | None, source: FrameSource, project: Project,
              scribbles: Sequence[Scribble], progress: Progress | None = None) -> RotoSession:
    """``project``'s segmentation corrected by brush strokes ``scribbles``.

    Re-propagates with ``session`` when it holds (or kept) the segmentation of ``project``;
    otherwise segments the whole clip from the project's inputs and the new strokes.

    Returns
    -------
    RotoSession
        ``session`` itself or a new one; :meth:`RotoSession.silhouettes` gives the result.
    """
    return _changed(session, source, project, project.with_scribbles(tuple(scribbles)),
                    lambda use: use.correct(project, scribbles, progress), progress)


def erased(session: RotoSession | None, source: FrameSource, project: Project,
           indices: Collection[int], progress: Progress | None = None) -> RotoSession:
    """``project``'s segmentation without the brush strokes at positions ``indices`` of
    ``project.scribbles``.

    Re-propagates with ``session`` when it holds (or kept) the segmentation of ``project``;
    otherwise segments the whole clip from the project's inputs without those strokes.

    Returns
    -------
    RotoSession
        ``session`` itself or a new one; :meth:`RotoSession.silhouettes` gives the result.
    """
    return _changed(session, source, project, project.without_scribbles(indices),
                    lambda use: use.erase(project, indices, progress), progress)


def _changed(session: RotoSession | None, source: FrameSource, project: Project, after: Project,
             edit: Callable[[RotoSession], None], progress: Progress | None) -> RotoSession:
    """``edit`` ``session`` from ``project``'s segmentation into ``after``'s when it holds (or
    kept) the former; otherwise a new session segmenting the whole clip from ``after``."""
    use = reusable(session, source, project)
    if use is None:
        return RotoSession.start(source, after, progress)
    edit(use)
    return use


def preview_first_frame(source: FrameSource, project: Project,
                        progress: Progress | None = None) -> np.ndarray:
    """The first frame's cut-out from the project's box (or rectangles) and the brush
    strokes of frame 0, as the whole clip's segmentation will cut it, before it runs.

    Only the first frames the first cut looks at are read (it compares frame 0 with a few
    later ones to see what moves).

    Returns
    -------
    ndarray of shape (rows, cols), bool

    Raises
    ------
    GaitInputError
        Nothing to start from, or bad input.
    """
    check_segmentation_input(project)
    offsets = project.segmentation.propagation.motion_offsets
    n = min(len(source), 1 + max((*offsets, 0)))
    frames = [source.frame(t) for t in range(n)]
    report(progress, 1, 2, "first-frame cut-out cancelled")
    engine = _engine(frames, project, project.scribbles_on(0))
    engine.run()
    report(progress, 2, 2, "first-frame cut-out cancelled")
    return engine.mask(0)


def _engine(frames, project: Project, scribbles: Sequence[Scribble]) -> RotoSegmentation:
    """The segmentation engine of ``project``'s box (or rectangles) and ``scribbles``.

    Raises
    ------
    GaitInputError
        Nothing to start from (no box, rectangles or subject stroke on frame 0), bad input.
    """
    check_segmentation_input(project)
    rects = ((), ()) if project.box else (project.subject_rects, project.background_rects)
    return RotoSegmentation(frames, box=project.box, subject_rects=rects[0],
                            background_rects=rects[1], scribbles=scribbles,
                            settings=project.segmentation.propagation)


def sketch_as_scribbles(strokes: Sequence[Stroke], shape: tuple[int, int], *,
                        pad: float = 0.04) -> tuple[list[Scribble], Rect]:
    """Sketch strokes as subject brush strokes for the segmentation engine, and a box around
    them grown by ``pad`` of its size on each side (the scripted user's box).

    The sketched pixels become sure subject on their frame; with the box on the first frame,
    the engine cuts the animal there and carries it across the clip in one run, instead of a
    sketch per frame (paper Section 2.2's fallback).

    Parameters
    ----------
    strokes : sequence of Stroke
        Strokes of one frame.
    shape : (rows, cols)
        The frame's size.

    Raises
    ------
    GaitInputError
        No stroke, or the strokes lie outside the frame.
    """
    if not strokes:
        raise GaitInputError("sketch the animal on this frame first (D), then propagate")
    x, y, w, h = cv2.boundingRect(rasterize_strokes(strokes, shape))
    if w == 0:
        raise GaitInputError("the strokes lie outside the frame: sketch over the animal")
    dx, dy = round(pad * w) + 1, round(pad * h) + 1
    box = Rect(x - dx, y - dy, w + 2 * dx, h + 2 * dy).clipped_to(shape[1], shape[0])
    return [Scribble(s.points_xy, s.width_px, s.frame, "subject") for s in strokes], box


def export_masks(session: RotoSession, out_dir: Path, *, source_name: str = "",
                 progress: Progress | None = None) -> int:
    """Write ``out_dir/masks/00000.png``... (full frame, 0/255, one per source frame) and
    ``out_dir/segmentation.json``, as ``gaitcore segment`` does.

    Returns
    -------
    int
        The number of masks written.

    Raises
    ------
    GaitInputError
        The folder cannot be written.
    Cancelled
        When ``progress`` returned False.
    """
    n = session.n_frames
    with MaskWriter(Path(out_dir) / "masks") as write_mask:
        for t in range(n):
            write_mask(t, session.mask(t))
            report(progress, t + 1, n, "mask export cancelled")
    try:
        write_segmentation_json(Path(out_dir) / "segmentation.json", session.states(),
                                source=source_name)
    except OSError as exc:
        raise GaitInputError(f"cannot export the masks to {out_dir}: {exc}; choose a folder "
                             "you can write to") from None
    return n
