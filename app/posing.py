"""Posing the skeleton on the key-images: which frames, which pose, and every pose edit.

The frames to pose are the analysis's key-images and, with "alternates (walk)" on, the
alternates the artist accepted (paper Section 3.2), one per key. :class:`PosingController`
turns the artist's actions (a spin box, a drag, copy/paste, mirror, reset, imports, a new rig)
into commands of :mod:`app.pose_commands`; questions go to the :class:`~app.dialogs.Asker`.
Files are read as jobs, off the window's thread; an import that fails changes nothing and
says why.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from itertools import count
from pathlib import Path

import numpy as np
from PySide6.QtCore import QObject, Signal
from PySide6.QtWidgets import QWidget

from app.dialogs import Asker
from app.pose_commands import (
    FitRigCommand,
    ProportionsCommand,
    SetPoseCommand,
    SetSkeletonCommand,
)
from app.state import AppState
from app.workers import Job, JobRunner, ProgressDialog
from gaitcore.errors import GaitInputError
from gaitcore.io.bvh.reader import read_bvh
from gaitcore.io.pose_table import PoseTable, joints_of, map_channels, read_pose_table
from gaitcore.project.footage_fit import RigFit, fit_rig
from gaitcore.project.steps import (
    alternates_in_use,
    drag_library,
    frames_to_pose,
    missing_poses,
    read_rig,
)
from gaitcore.rig.orient import reoriented
from gaitcore.rig.pose_library import PoseLibrary
from gaitcore.rig.posing import drag_end, effector_chain_top, turn_joint
from gaitcore.rig.proportions import RigProportions
from gaitcore.rig.skeleton import Skeleton


class PosingController(QObject):
    """The artist's pose edits on the current frame, as undoable commands.

    Signals
    -------
    messageRaised(str)
        A line for the status bar.
    """

    messageRaised = Signal(str)

    def __init__(self, state: AppState, asker: Asker, runner: JobRunner,
                 parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self.asker = asker
        self._runner = runner
        self._clipboard: np.ndarray | None = None
        self._drags = count()
        self._drag_id = 0
        self._drag_library: PoseLibrary | None = None
        self.drags_use_library = True
        """Whether an end drag folds its chain as the examples of :meth:`drag_library` do."""

    # -- queries -----------------------------------------------------------------------------
    def frames(self) -> tuple[int, ...]:
        return frames_to_pose(self._state.project, self._state.analysis)

    def alternates(self) -> tuple[int, ...]:
        return alternates_in_use(self._state.project, self._state.analysis)

    def missing(self) -> tuple[int, ...]:
        return missing_poses(self._state.project, self._state.analysis,
                             self._state.skeleton.n_channels)

    def editable_frame(self) -> int | None:
        """The current frame when it is a frame to pose, else None."""
        frame = self._state.frame
        return frame if frame in self.frames() else None

    def pose_of(self, frame: int) -> np.ndarray:
        """The stored pose of ``frame``, or the rest pose when it has none (yet)."""
        skeleton = self._state.skeleton
        pose = self._state.project.key_poses.get(frame)
        if pose is None or len(pose) != skeleton.n_channels:
            return skeleton.rest_pose()
        return np.array(pose, dtype=float)

    def has_clipboard(self) -> bool:
        return (self._clipboard is not None
                and len(self._clipboard) == self._state.skeleton.n_channels)

    # -- edits -------------------------------------------------------------------------------
    def set_channel(self, channel: str, value: float) -> None:
        """Set one channel of the current key's pose (consecutive changes of a joint merge)."""
        frame = self._require_frame()
        if frame is None:
            return
        skeleton = self._state.skeleton
        i = skeleton.channel_index(channel)
        pose = self.pose_of(frame)
        pose[i] = float(np.clip(value, *skeleton.limits_array()[i]))
        joint = channel.rsplit(".", 1)[0]
        self._push(frame, pose, f"pose {joint} on frame {frame}", ("spin", frame, joint))

    def set_drags_use_library(self, on: bool) -> None:
        """Let end drags fold their chain as the library's examples do (or plain IK)."""
        self.drags_use_library = bool(on)

    def begin_drag(self) -> None:
        """Start a new viewport drag: its changes merge into one undo step; an end drag
        folds its chain as the examples of the gait library and the other keys do (unless
        :attr:`drags_use_library` is off)."""
        self._drag_id = next(self._drags)
        self._drag_library = None
        frame = self.editable_frame()
        if self.drags_use_library and frame is not None:
            self._drag_library = drag_library(self._state.project, self._state.skeleton, frame)

    def rotate_joint(self, joint: int, base_pose: np.ndarray, axis: np.ndarray,
                     angle_deg: float) -> None:
        """Set the current key's pose to ``base_pose`` with ``joint`` turned about world ``axis``.

        The turned local rotation is decomposed as R = Rz Rx Ry; channels the joint lacks are
        dropped and the others clamped to its limits.
        """
        frame = self._require_frame()
        skeleton = self._state.skeleton
        pose = turn_joint(skeleton, base_pose, joint, axis, angle_deg)
        if frame is None or pose is None:
            return
        name = skeleton.joints[joint].name
        self._push(frame, pose, f"rotate {name} on frame {frame}",
                   ("drag", frame, name, self._drag_id))

    def is_draggable_end(self, joint: int) -> bool:
        """True when dragging ``joint`` moves it by IK (a toe, the head's end, the tail's tip)."""
        return effector_chain_top(self._state.skeleton, joint) is not None

    def drag_end(self, joint: int, base_pose: np.ndarray, target_xyz: np.ndarray) -> None:
        """Set the current key's pose to ``base_pose`` with end ``joint`` moved to ``target_xyz``
        by IK on the chain above it (leg, neck or tail), within the joint limits, folded as the
        examples of the drag's library (see :meth:`begin_drag`)."""
        frame = self._require_frame()
        skeleton = self._state.skeleton
        pose = drag_end(skeleton, base_pose, joint, target_xyz, library=self._drag_library)
        if frame is None or pose is None:
            return
        name = skeleton.joints[joint].name
        self._push(frame, pose, f"move {name} on frame {frame}",
                   ("drag", frame, name, self._drag_id))

    def set_pose(self, pose: np.ndarray, text: str) -> bool:
        """Replace the current key's whole pose (clamped to the joint limits)."""
        frame = self._require_frame()
        if frame is None:
            return False
        clamped = np.clip(pose, *self._state.skeleton.limits_array().T)
        n = int(np.count_nonzero(clamped != pose))
        self._push(frame, clamped, f"{text} on frame {frame}")
        if n:
            self.messageRaised.emit(f"{n} channel(s) clamped to the joint limits of the rig")
        return True

    def copy(self) -> None:
        frame = self._require_frame()
        if frame is not None:
            self._clipboard = self.pose_of(frame)
            self.messageRaised.emit(f"copied the pose of frame {frame}")

    def paste(self, *, mirrored: bool = False) -> None:
        if not self.has_clipboard():
            self.messageRaised.emit("nothing to paste: copy the pose of a key first")
            return
        pose = self._state.skeleton.mirror_pose(self._clipboard) if mirrored else self._clipboard
        self.set_pose(pose, "paste mirrored pose" if mirrored else "paste pose")

    def mirror(self) -> None:
        """Swap left and right of the current key's pose (gaitcore's mirror_pose)."""
        frame = self._require_frame()
        if frame is not None:
            self.set_pose(self._state.skeleton.mirror_pose(self.pose_of(frame)), "mirror pose")

    def mirror_of_key(self) -> None:
        """Pose an alternate as the mirror of the key it pairs with (a walk's other half)."""
        frame = self._require_frame()
        alts = self.alternates()
        if frame is None or frame not in alts:
            self.messageRaised.emit("go to an alternate frame to copy the mirrored pose of its key")
            return
        key = self._state.analysis.key_frames[alts.index(frame)]
        self.set_pose(self._state.skeleton.mirror_pose(self.pose_of(key)), f"mirror key {key}")

    def reset(self, *, joint_only: bool) -> None:
        """Put the selected joint (or the whole pose) back to rest."""
        frame = self._require_frame()
        if frame is None:
            return
        skeleton, joint = self._state.skeleton, self._state.selected_joint
        pose = self.pose_of(frame)
        if joint_only:
            if not joint:
                self.messageRaised.emit("select a joint to reset")
                return
            for i, c in enumerate(skeleton.channel_names):
                if c.rsplit(".", 1)[0] == joint:
                    pose[i] = 0.0
            self._push(frame, pose, f"reset {joint} on frame {frame}")
        else:
            self._push(frame, skeleton.rest_pose(), f"reset pose on frame {frame}")

    # -- the rig's proportions ----------------------------------------------------------------
    def set_proportion(self, part: str, scale: float) -> None:
        """Scale one part of the rig (legs, neck, body, head, tail); one undo step per part."""
        props = replace(self._state.project.proportions, **{part: float(scale)})
        if props != self._state.project.proportions:
            self._state.undo_stack.push(ProportionsCommand(self._state, props, part))

    def fit_rig(self) -> Job | None:
        """Fit the rig's proportions and the footage's place to this key's silhouette, in the
        background; one undo step. The fit starts from the template's proportions, so that
        it does not depend on earlier fits; a poor fit is refused with its reasons."""
        frame, project = self._require_frame(), self._state.project
        if frame is None:
            return None
        if project.silhouettes is None:
            self.messageRaised.emit("no silhouettes yet: segment or sketch the clip first")
            return None
        template, pose = self._state.template_skeleton, self.pose_of(frame)

        def work(progress) -> RigFit:  # from the template: the same key, the same fit
            return fit_rig(template, pose, project.silhouettes, frame,
                           flip=project.footage_fit.flip, progress=progress)

        def apply(result: RigFit) -> None:
            self._state.undo_stack.push(
                FitRigCommand(self._state, result.proportions, result.footage_fit, frame))
            m = result.measures
            self.messageRaised.emit(
                f"rig fitted to frame {frame} ({100 * m.overlap:.0f}% overlap): body "
                f"{m.body_length_m:.2f} m, withers {m.withers_height_m:.2f} m, leg "
                f"{m.leg_length_m:.2f} m; correct the scales if needed")

        return self._start(Job(work, f"Fit the rig to frame {frame}", unit=None), apply,
                           "Cannot fit the rig")

    # -- imports and rigs --------------------------------------------------------------------
    def import_csv(self, path: Path | None = None) -> bool:
        """Pose the current key from a row of a pose CSV (channels matched by name).

        The file is read off the window's thread; returns True when the reading started.
        """
        return self._import_pose(path, "Import a pose from CSV", "Pose tables (*.csv)",
                                 read_pose_table, self._csv_row)

    def import_bvh(self, path: Path | None = None) -> bool:
        """Pose the current key from one frame of a BVH file (joints matched by name).

        The file is read off the window's thread; returns True when the reading started.
        """
        return self._import_pose(path, "Import a pose from a BVH frame", "BVH motion (*.bvh)",
                                 lambda p: read_bvh(p)[1], self._bvh_row)

    def _csv_row(self, table: PoseTable, path: Path) -> int | None:
        """One row: that one; more: the artist is asked (the row of the same frame is only
        suggested: a table's frame numbers need not be the clip's)."""
        frames = [int(f) for f in table.frames]
        if not frames:
            raise GaitInputError("it has no rows")
        return 0 if len(frames) == 1 else self._choose_row(path, frames)

    def _bvh_row(self, table: PoseTable, path: Path) -> int | None:
        n = len(table.frames)
        if n == 0:
            raise GaitInputError("it has no motion frames")
        frame = self._state.frame if self._state.frame < n else None
        return 0 if n == 1 else self.asker.choose_frame(
            f"Which frame of {path.name} poses frame {self._state.frame}?", list(range(n)),
            suggested=frame)

    def _import_pose(self, path: Path | None, title: str, filter_: str,
                     read: Callable[[Path], PoseTable],
                     choose: Callable[[PoseTable, Path], int | None]) -> bool:
        """Ask for a file, ``read`` it in a job, then let ``choose`` pick a row and pose the
        current key with it; any GaitInputError becomes a message and changes nothing."""
        frame = self._require_frame()
        if frame is None:
            return False
        path = path or self.asker.open_file(title, filter_)
        if path is None:
            return False
        path = Path(path)

        def apply(table: PoseTable) -> None:
            if self.editable_frame() != frame:
                self.messageRaised.emit(f"{path.name}: not imported, frame {frame} is no longer "
                                        "shown")
                return
            try:
                row = choose(table, path)
                if row is None:
                    return
                pose, ignored = map_channels(table.columns, table.values[row], self._state.skeleton)
            except GaitInputError as exc:
                self.asker.error("Cannot import the pose", f"{path.name}: {exc}")
                return
            self._apply_import(pose, ignored,
                               f"import pose from {path.name} (frame {int(table.frames[row])})")

        self._read(path, read, apply, "Cannot import the pose", f"{path.name}: ")
        return True

    def load_rig(self, path: Path | None = None) -> bool:
        """Replace the skeleton by the rig of a BVH file; poses are dropped unless the channels
        are the same (the artist is asked first).

        The file is read off the window's thread; returns True when the reading started.
        """
        path = path or self.asker.open_file("Load rig from BVH", "BVH motion (*.bvh)")
        if path is None:
            return False
        path = Path(path)

        def apply(read: tuple[Skeleton, str]) -> None:
            skeleton, note = read
            if note:
                self.messageRaised.emit(note)
            self._replace_skeleton(skeleton, f"load rig {skeleton.name}", new_rig=True)

        self._read(path, read_rig, apply, "Cannot load the rig", "")
        return True

    def turn_rig(self, up: str, forward: str) -> bool:
        """Turn the rig so that its axis ``up`` (as now shown: "+X" ... "-Z") points up and
        ``forward`` forward, standing on the ground (when an imported rig's axes were read
        wrong); the poses are kept."""
        try:
            rig = reoriented(self._state.template_skeleton, up=up, forward=forward)
        except GaitInputError as exc:
            self.asker.error("Cannot turn the rig", str(exc))
            return False
        return self._replace_skeleton(rig, f"turn the rig ({up} up, facing {forward})")

    def _read(self, path: Path, read: Callable[[Path], object], then: Callable[[object], None],
              error_title: str, prefix: str) -> Job:
        """``read(path)`` as a job (see :meth:`_start`)."""
        return self._start(Job(lambda progress: read(path), f"Reading {path.name}", unit=None),
                           then, error_title, prefix)

    def _start(self, job: Job, then: Callable[[object], None], error_title: str,
               prefix: str = "") -> Job:
        """Run ``job`` with a progress dialog; ``then`` gets what it returned, a failure
        becomes an error dialog (``prefix`` + the message)."""
        job.succeeded.connect(then)
        job.failed.connect(lambda message: self.asker.error(error_title, prefix + message))
        window = self.parent()
        ProgressDialog(job, window if isinstance(window, QWidget) else None)
        return self._runner.start(job)

    def use_template(self) -> bool:
        """Go back to the bundled horse template."""
        return self._replace_skeleton(None, "use the horse template", new_rig=True)

    def _replace_skeleton(self, skeleton: Skeleton | None, text: str, *,
                          new_rig: bool = False) -> bool:
        """Pose ``skeleton`` (None: the template) instead; a ``new_rig`` starts from its own
        proportions (those fitted to the old one do not apply)."""
        from app.state import default_skeleton

        project, old = self._state.project, self._state.skeleton
        new = skeleton or default_skeleton()
        keep = set(new.channel_names) == set(old.channel_names)
        posed = len(project.key_poses)
        if posed and not keep and not self.asker.confirm(
                "Replace the rig?",
                f"The channels of {new.name!r} differ from those of the rig being posed: the "
                f"{posed} pose(s) made so far will be dropped (Undo brings them back). Continue?"):
            return False
        poses = {}
        if keep:  # same channels, maybe in another order: carry every pose over by name
            order = [old.channel_index(c) for c in new.channel_names]
            poses = {f: tuple(np.asarray(p)[order]) for f, p in project.key_poses.items()
                     if len(p) == old.n_channels}
        self._state.undo_stack.push(SetSkeletonCommand(
            self._state, skeleton, poses, text, proportions=RigProportions() if new_rig else None))
        self._state.set_selected_joint("")
        return True

    # -- helpers -----------------------------------------------------------------------------
    def _choose_row(self, path: Path, frames: list[int]) -> int | None:
        """Ask which row poses the current key (the row of the same frame number, if any, is
        only suggested: a table's frame numbers need not be the clip's)."""
        chosen = self.asker.choose_frame(
            f"Which row of {path.name} poses frame {self._state.frame}?", frames,
            suggested=self._state.frame if self._state.frame in frames else None)
        return None if chosen is None else frames.index(chosen)

    def _apply_import(self, pose: np.ndarray, ignored: list[str], text: str) -> bool:
        if not self.set_pose(pose, text):
            return False
        if ignored:
            self.messageRaised.emit(f"imported; ignored {len(ignored)} channel(s) the rig does not "
                                    f"have, on {joints_of(ignored)}")
        return True

    def _require_frame(self) -> int | None:
        frame = self.editable_frame()
        if frame is None:
            frames = self.frames()
            self.messageRaised.emit(
                f"frame {self._state.frame} is not a key-image: go to one of {list(frames)} to "
                "pose it"
                if frames else "no key-images yet: analyse the clip first")
        return frame

    def _push(self, frame: int, pose: np.ndarray, text: str, merge_key=None) -> None:
        self._state.undo_stack.push(SetPoseCommand(self._state, frame, pose, text, merge_key))
