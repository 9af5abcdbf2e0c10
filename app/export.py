"""The Export menu: curves CSV, BVH, glTF and a preview video, through gaitcore.io.export.

The animation is computed afresh from the project (:func:`gaitcore.project.steps.animate_project`,
with the preview's options), so what is written is exactly what ``gaitcore animate`` writes
for the same analysis and key poses. Exporting before every key is posed says which frames
are missing and writes nothing. Files are written off the GUI thread with progress + Cancel.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PySide6.QtCore import QObject

from app.animation import AnimationController
from app.document import DocumentController
from app.state import AppState
from app.workers import Job
from gaitcore.errors import GaitInputError
from gaitcore.io.export import EXPORTERS, export_animation, write_preview_video
from gaitcore.io.pose_table import PoseTable
from gaitcore.project.footage_fit import footage_maps
from gaitcore.project.steps import (
    Animation,
    animate_project,
    footage_speed,
    frame_rate,
    open_source,
)

VIDEO = ".mp4"
KINDS = {".csv": "Curves CSV", ".bvh": "BVH", ".glb": "glTF (.glb)", VIDEO: "Preview video"}


def export_fps(state: AppState) -> float:
    """Frame rate of the clip (:func:`gaitcore.project.steps.frame_rate`)."""
    return frame_rate(state.project, state.source)


class ExportController(QObject):
    """Ask where, check that every key is posed, then write the file in a background job."""

    def __init__(self, state: AppState, animation: AnimationController,
                 documents: DocumentController, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._animation = animation
        self._documents = documents

    def export(self, suffix: str, path: Path | None = None) -> Job | None:
        """Export to ``path`` (asked when None) as ``suffix`` (a key of :data:`KINDS`).

        Curves, BVH and glTF first ask for the export options (root motion, ground contact,
        loop, bone names; saved with the project as one undo step), then write what
        :meth:`Animation.export_motion` makes of the animation. Returns the running job, or
        None when nothing is written (a message says why).
        """
        state, asker = self._state, self._documents.asker
        title = f"Export {KINDS[suffix]}"
        if suffix != VIDEO:
            speed = footage_speed(state.project, state.analysis, state.skeleton, export_fps(state))
            options = asker.export_options(title, self._animation.options, speed)
            if options is None:
                return None
            self._animation.set_options(options)
        try:
            animation = animate_project(state.project, state.analysis, state.skeleton,
                                        self._animation.options, fps=export_fps(state))
        except GaitInputError as exc:
            asker.error(title, f"{exc}; nothing was exported")
            return None
        if path is None:
            base = state.path or state.project.footage or Path.cwd() / "untitled"
            suggested = Path(base).with_name(Path(base).stem + "_animation" + suffix)
            description = (EXPORTERS[suffix].description if suffix in EXPORTERS
                           else "MPEG-4 video (*.mp4)")
            path = asker.export_path(title, suggested, description)
            if path is None:
                return None
        skeleton, fps = animation.skeleton, export_fps(state)
        if suffix == VIDEO:
            curves = animation.exported()[1]
            footage, maps = self._footage_frames(animation), self._footage_maps(animation)
            job = Job(lambda progress: write_preview_video(path, footage, skeleton, curves, fps,
                                                           footage_from_world=maps,
                                                           progress=progress), title)
        else:
            job = Job(lambda progress: _write(path, animation, fps, progress), title)
        return self._documents.run(job, lambda result: self._done(path, result), tied=False)

    def _footage_maps(self, animation):
        """Where the skeleton goes over each exported frame: the artist's footage fit."""
        project, state = self._state.project, self._state
        start = animation.first_frame + (animation.cycle_start if animation.cycle is not None
                                         else 0)
        frames = range(start, start + len(animation.exported()[0]))
        if state.source is None:  # masks only: the video shows the crops, skeleton centred
            crops = project.silhouettes.roi.crops
            return footage_maps(frames, animation.skeleton, None, (crops.shape[2], crops.shape[1]),
                                project.footage_fit)
        return footage_maps(frames, animation.skeleton, project.silhouettes, state.source.size,
                            project.footage_fit)

    def _footage_frames(self, animation):
        """An iterator over the frames the exported poses go with, read on the job's thread."""
        project = self._state.project
        start = animation.first_frame + (animation.cycle_start if animation.cycle is not None
                                         else 0)
        count = len(animation.exported()[0])

        def frames():
            source = open_source(project)
            try:
                for i in range(start, start + count):
                    if source is not None:
                        yield source.frame(i)
                    else:  # a project of masks only: show the silhouettes
                        yield np.asarray(project.silhouettes.roi.crops[i])
            finally:
                if source is not None:
                    source.close()

        return frames()

    def _done(self, asked: Path, result) -> None:
        written = getattr(result, "path", result) or asked
        note = getattr(result, "note", None) or getattr(result, "summary", None)
        self._documents.messageRaised.emit(f"exported {written}" + (f" ({note})" if note else ""))


@dataclass(frozen=True)
class Written:
    """What an export job wrote: the file and a one-line summary of the motion."""

    path: Path
    summary: str


def _write(path: Path, animation: Animation, fps: float, progress) -> Written:
    """Make the exported motion (ground contact included) and write it: on the job's thread."""
    motion = animation.export_motion(progress)
    table = PoseTable(motion.frames, animation.skeleton.channel_names, motion.poses)
    written = export_animation(path, animation.skeleton, table, fps,
                               naming=animation.options.bone_names)
    summary = motion.summary() + (f"; {motion.warning}" if motion.warning else "")
    return Written(written, summary)
