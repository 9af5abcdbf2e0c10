"""From an input path to tracked silhouettes: the first step of ``gaitcore analyze``.

A folder of binary masks skips segmentation; colour footage (a video file or a folder of
images) is segmented from rectangles drawn on its first frame (paper Section 2.2).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.footage.image_folder import (
    MaskWriter,
    decoded,
    iter_mask_folder,
    list_image_files,
)
from gaitcore.progress import Progress
from gaitcore.silhouettes.annotations import Rect, Scribble
from gaitcore.silhouettes.roto import FrameState
from gaitcore.silhouettes.tracking import WORK_SIDE_PX, RoiClip, crop_rois

if TYPE_CHECKING:
    from gaitcore.silhouettes.settings import SegmentationSettings


def is_mask_folder(path: Path) -> bool:
    """True when ``path`` is a folder whose first image is binary (only 0 and 255 or 0 and 1).

    Raises
    ------
    GaitInputError
        For an empty folder, one with non-image files, or an unreadable first image.
    """
    if not path.is_dir():
        return False
    first = list_image_files(path)[0]
    img = decoded(first, cv2.IMREAD_UNCHANGED)
    if img is None:
        raise GaitInputError(f"cannot read image {first}: the file is damaged or not an image")
    if img.ndim == 3:
        if img.shape[2] == 4:
            img = img[:, :, :3]
        if not (np.array_equal(img[:, :, 0], img[:, :, 1])
                and np.array_equal(img[:, :, 0], img[:, :, 2])):
            return False
        img = img[:, :, 0]
    values = np.unique(img)
    return values.size <= 2 and set(values.tolist()) <= {0, 1, 255}


def load_silhouettes(
    source: Path,
    out_dir: Path,
    *,
    subject: Sequence[Rect] = (),
    background: Sequence[Rect] = (),
    box: Rect | None = None,
    scribbles: Sequence[Scribble] = (),
    method: str | None = None,
    settings: SegmentationSettings | None = None,
    max_side: int | None = WORK_SIDE_PX,
    start: int = 0,
    stop: int | None = None,
    progress: Progress | None = None,
    state_sink: Callable[[int, FrameState], None] | None = None,
    note_sink: Callable[[str], None] | None = None,
) -> RoiClip:
    """Tracked, fixed-size silhouettes of the subject in frames ``start <= f < stop`` of ``source``.

    Parameters
    ----------
    source : Path
        Folder of binary masks, folder of colour images, or video file.
    out_dir : Path
        For colour footage, the computed masks are written to ``out_dir/masks/00000.png``...,
        named by source frame.
    subject, background : sequence of Rect
        Rectangles on the first frame of the range (colour footage starts from them, from
        ``box``, or from a subject stroke on that frame in ``scribbles``).
    box : Rect, optional
        Around the subject on the first frame of the range.
    scribbles : sequence of Scribble
        Strokes on any frames (source frame numbers); subject strokes on the first frame of
        the range can start the segmentation without a box, as in the app.
    method : {"propagate", "gmm"}, optional
        Segmentation method (see :mod:`gaitcore.silhouettes.segmentation`).
    settings : SegmentationSettings, optional
        How the clip is segmented (its ``method`` overridden by ``method`` when given).
    max_side : int or None
        Longer side of the ROI crops (they are shrunk to it), which bounds memory on long
        clips; None keeps the source resolution.
    start, stop : int
        Source frames to read (``stop=None``: to the end).
    progress : callable(done, total) -> bool, optional
    state_sink : callable(frame, FrameState), optional
        Receives what the segmentation says of each frame of colour footage.
    note_sink : callable(str), optional
        Receives what the user should know of a video that decodes with a difference (its
        header's frame count wrong, for example).

    Raises
    ------
    GaitInputError
        Unreadable input, colour footage with nothing to start from, a bad range, or no
        subject found.
    """
    source = Path(source)
    if not source.exists():
        raise GaitInputError(f"{source} does not exist: give a video file, an image folder or "
                             "a mask folder")
    if is_mask_folder(source):
        n = len(list_image_files(source))
        last = n if stop is None else stop
        if not 0 <= start < last <= n:
            raise GaitInputError(f"frames {start}:{stop} do not fit {source}, which has {n} masks: "
                                 f"choose 0 <= start < stop <= {n}")
        masks = itertools.islice(iter_mask_folder(source), start, last)
        return crop_rois(masks, max_side=max_side, progress=progress)
    if start or stop is not None:  # scribbles are numbered by source frame, the clip by row
        end = float("inf") if stop is None else stop
        scribbles = [replace(s, frame=s.frame - start) for s in scribbles if start <= s.frame < end]
    painted = any(s.frame == 0 and s.label == "subject" for s in scribbles)
    if box is None and not (subject and background) and not painted:
        raise GaitInputError(
            f"{source} is colour footage: give a --box x,y,w,h around the subject on its first "
            "frame, --subject and --background rectangles, or a subject stroke on it in "
            "--scribbles (or pass a folder of binary masks)"
        )
    from gaitcore.footage.sources import open_frames
    from gaitcore.silhouettes.saliency import saliency_missing
    from gaitcore.silhouettes.segmentation import segment_clip

    with (open_frames(source, start=start, stop=stop) as frames,
          MaskWriter(Path(out_dir) / "masks") as write_mask):
        if frames.note and note_sink is not None:
            note_sink(frames.note)
        clip = segment_clip(frames, list(subject), list(background), box=box,
                            scribbles=scribbles, method=method, settings=settings,
                            progress=progress,
                            mask_sink=lambda index, mask: write_mask(start + index, mask),
                            state_sink=state_sink, max_side=max_side)
    missing = None if method == "gmm" else saliency_missing()
    if missing and note_sink is not None:
        note_sink(missing)  # after the cut: an error stays the one line the user reads
    return clip
