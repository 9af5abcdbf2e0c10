"""The state of a finished :class:`~gaitcore.silhouettes.roto.RotoSegmentation` as plain data,
to keep it in a file and put it back without cutting the clip again (its frames are only
read, to lay the masks' outlines on their edges).

What a correction needs of the engine is its working size, the key frames' cuts, what the
strokes there turned to the subject, and the masks the forward and backward passes carried;
everything else (the inputs: box, rectangles, brush strokes) comes from the project it is put
back for.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.silhouettes.ground import StillBackground
from gaitcore.silhouettes.packed_masks import PackedMasks
from gaitcore.silhouettes.propagate import Cut, WorkingSize
from gaitcore.silhouettes.roto import FrameState, RotoSegmentation


@dataclass(frozen=True)
class RotoState:
    """The masks and sizes of a finished segmentation.

    Attributes
    ----------
    n_frames : int
        Frames of the clip.
    work : WorkingSize
        The engine's working size (scale, wh, shape, subject_side).
    keys, fwd, bwd : PackedMasks
        The key frames' cuts, and the masks of the forward and backward passes, at the
        working size.
    turned : PackedMasks
        :attr:`RotoSegmentation.turned`, by key frame.
    still : StillBackground or None
        :attr:`RotoSegmentation.still`.
    frame_states : tuple of FrameState
        Every frame's :class:`~gaitcore.silhouettes.roto.FrameState` when the state was
        taken from a session that had them (empty otherwise), so that a reopened project
        shows its frames to check before the engine is put back.
    """

    n_frames: int
    work: WorkingSize
    keys: PackedMasks
    fwd: PackedMasks
    bwd: PackedMasks
    turned: PackedMasks
    still: StillBackground | None = None
    frame_states: tuple[FrameState, ...] = ()


def roto_state(seg: RotoSegmentation) -> RotoState:
    """The state of ``seg`` (after :meth:`~RotoSegmentation.run`); the passes' masks are
    shared with it, not copied."""
    keys, turned = PackedMasks(seg.fwd.shape), PackedMasks(seg.fwd.shape)
    for t, cut in seg.keys.items():
        keys.put(t, cut)
    for t, pixels in seg.turned.items():
        turned.put(t, Cut(pixels.astype(np.uint8), 0.0))
    return RotoState(seg.n, seg.work, keys, seg.fwd, seg.bwd, turned, seg.still)


def restore_state(seg: RotoSegmentation, state: RotoState) -> bool:
    """Put ``state`` into ``seg``, a new engine made from the same inputs, as if it had run;
    False (``seg`` untouched) when the state is of another clip, working size or set of key
    frames."""
    keys = state.keys.frames
    if (state.n_frames != seg.n or state.work != seg.work
            or set(keys) != {0, *seg.corrected_frames}
            or not set(state.turned.frames) <= set(keys)):
        return False
    seg.keys = {t: cut for t in keys if (cut := state.keys.get(t)) is not None}
    seg.turned = {t: cut.mask > 0 for t in state.turned.frames
                  if (cut := state.turned.get(t)) is not None}
    seg.fwd, seg.bwd = state.fwd, state.bwd
    seg.still = state.still
    return True
