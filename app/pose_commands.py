"""Undoable pose edits: one QUndoCommand per change of a key pose or of the rig.

Consecutive changes of one joint from its spin boxes merge into one step, and so does one
drag in the 3D viewport, so that Undo takes back what the artist sees as one gesture.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping
from dataclasses import replace

import numpy as np
from PySide6.QtGui import QUndoCommand

from app.commands import MergeId, ProjectCommand, _FieldCommand
from app.state import AppState
from gaitcore.project.document import FootageFit
from gaitcore.rig.proportions import RigProportions
from gaitcore.rig.skeleton import Skeleton


class SetPoseCommand(ProjectCommand):
    """Give ``frame`` the pose vector ``pose`` (None: remove its pose).

    Parameters
    ----------
    merge_key : hashable, optional
        Consecutive commands with the same key merge into one undo step (e.g.
        ``("spin", frame, joint)`` or ``("drag", frame, joint, n)``); None never merges.
    """

    def __init__(self, state: AppState, frame: int, pose: np.ndarray | None, text: str,
                 merge_key: Hashable | None = None) -> None:
        super().__init__(state, state.project.with_pose(frame, pose), text, frame=frame)
        self._merge_key = merge_key

    def id(self) -> int:
        return MergeId.POSE if self._merge_key is not None else -1

    def mergeWith(self, other: QUndoCommand) -> bool:
        if not isinstance(other, SetPoseCommand) or other._merge_key != self._merge_key:
            return False
        self._after = other._after
        return True


class SetSkeletonCommand(ProjectCommand):
    """Pose another rig (None: the horse template) with ``key_poses`` laid out for it, in
    ``proportions`` (None: keep the project's)."""

    def __init__(self, state: AppState, skeleton: Skeleton | None,
                 key_poses: Mapping[int, tuple[float, ...]], text: str, *,
                 proportions: RigProportions | None = None) -> None:
        after = replace(state.project, skeleton=skeleton, key_poses=key_poses,
                        proportions=proportions or state.project.proportions)
        super().__init__(state, after, text)


class ProportionsCommand(_FieldCommand):
    """Scale one part of the rig (legs, neck, body, head, tail); a held spin box merges."""

    _ID = MergeId.PROPORTIONS

    def __init__(self, state: AppState, proportions: RigProportions, part: str) -> None:
        super().__init__(state, replace(state.project, proportions=proportions), part,
                         f"scale the rig's {part}")


class FitRigCommand(ProjectCommand):
    """The rig's proportions and the footage's placement from a fit, in one step."""

    def __init__(self, state: AppState, proportions: RigProportions, fit: FootageFit,
                 frame: int) -> None:
        super().__init__(state, replace(state.project, proportions=proportions, footage_fit=fit),
                         f"fit the rig to frame {frame}")
