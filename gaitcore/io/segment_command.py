"""The ``gaitcore segment`` subcommand, and the segmentation options ``analyze`` shares.

``gaitcore segment INPUT --out DIR [--box X,Y,W,H] [--subject X,Y,W,H]...
[--background X,Y,W,H]... [--scribbles FILE.json]`` writes ``DIR/masks/00000.png``... (full
frame, 0/255, one per source frame) and ``DIR/segmentation.json`` (per frame: lost,
corrected, confidence).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from gaitcore.errors import GaitInputError
from gaitcore.silhouettes.annotations import Rect

if TYPE_CHECKING:
    from gaitcore.silhouettes.roto import FrameState
    from gaitcore.silhouettes.settings import SegmentationSettings

SALIENCY_EVERY = 4
"""The default of ``--saliency-every``: ``PropagationSettings.saliency_every`` (not imported
here, so that building the parser does not load OpenCV; a test holds the two together)."""

MAX_PIXELS = 1 << 20
"""Largest coordinate a rectangle may have, in pixels."""


def _rect(text: str) -> Rect:
    try:
        values = [float(v) for v in text.split(",")]
        if len(values) != 4 or not all(abs(v) <= MAX_PIXELS for v in values):
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a rectangle x,y,w,h in pixels "
                                         f"(four numbers within +-{MAX_PIXELS})") from None
    x, y, w, h = (int(round(v)) for v in values)
    try:
        return Rect(x, y, w, h)
    except GaitInputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _every(text: str) -> int:
    try:
        value = int(text)
        if value < 1:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number of frames, 1 or "
                                         "more") from None
    return value


def add_segmentation_options(p: argparse.ArgumentParser) -> None:
    """``--box``, ``--subject``, ``--background``, ``--scribbles``, ``--method`` and
    ``--saliency-every``."""
    p.add_argument("--box", type=_rect, default=None, metavar="X,Y,W,H",
                   help="box around the whole subject on the first frame")
    p.add_argument("--subject", type=_rect, action="append", default=[], metavar="X,Y,W,H",
                   help="rectangle on the subject in the first frame (repeatable)")
    p.add_argument("--background", type=_rect, action="append", default=[], metavar="X,Y,W,H",
                   help="rectangle on the background in the first frame (repeatable)")
    p.add_argument("--scribbles", type=Path, default=None, metavar="FILE.json",
                   help="strokes on any frames (subject strokes on the first frame can start "
                   "without a box): {\"scribbles\": [{\"frame\": 12, \"label\": \"subject\", "
                   "\"width\": 8, \"points\": [[x, y], ...]}]}")
    p.add_argument("--method", choices=("propagate", "gmm"), default=None,
                   help="propagate (default: optical flow from the box, corrections both "
                   "ways) or gmm (the paper's colour mixture, rectangles only)")
    p.add_argument("--saliency-every", type=_every, default=None, metavar="N",
                   help="run the salient-object network every N frames, its map carried by "
                   f"the optical flow between (default {SALIENCY_EVERY}); 1 takes about 1.7 "
                   "times as long and cuts a little better from a box alone")
    p.add_argument("--settings", type=Path, default=None, metavar="FILE.json",
                   help="a segmentation profile: the settings it gives replace the defaults "
                   "(--method and --saliency-every replace its own); see --save-settings")


def segmentation_options(args: argparse.Namespace) -> dict:
    """The keyword options of ``load_silhouettes`` given on the command line."""
    from gaitcore.io.scribbles import read_scribbles

    scribbles = [] if args.scribbles is None else read_scribbles(args.scribbles)
    settings = segmentation_settings(args)
    return {"subject": args.subject, "background": args.background, "box": args.box,
            "scribbles": scribbles, "method": settings.method, "note_sink": print_note,
            "settings": settings}


def segmentation_settings(args: argparse.Namespace) -> SegmentationSettings:
    """The profile of ``--settings`` (else the defaults), with ``--method`` and
    ``--saliency-every`` over it."""
    from dataclasses import replace

    from gaitcore.silhouettes.settings import SegmentationSettings, read_settings

    settings = SegmentationSettings() if args.settings is None else read_settings(args.settings)
    if args.method is not None:
        settings = replace(settings, method=args.method)
    if args.saliency_every is not None:
        settings = replace(settings, propagation=replace(settings.propagation,
                                                         saliency_every=args.saliency_every))
    return settings


def print_note(text: str) -> None:
    """Tell the user something of the input on stderr (stdout may carry JSON)."""
    print(f"note: {text}", file=sys.stderr)


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``segment`` on an argparse subparsers object."""
    p = subparsers.add_parser(
        "segment",
        help="silhouettes of a clip from one box, with corrective strokes",
        description="Segment the subject in every frame of a video or image folder and write "
        "the full-frame masks and what is known of each frame (lost, corrected, confidence).",
    )
    p.add_argument("input", type=Path, help="video file or image folder")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    add_segmentation_options(p)
    p.add_argument("--save-settings", type=Path, default=None, metavar="FILE.json",
                   help="write the segmentation profile used (every setting) to FILE.json, "
                   "to edit and give back with --settings")
    p.set_defaults(run=run)


def print_frames_to_check(states: Sequence[FrameState], first_frame: int = 0) -> None:
    """One line naming the frames worth a look (:attr:`FrameState.to_check`) as source frame
    numbers, ``states[i]`` being of frame ``first_frame + i``."""
    from gaitcore.runs import true_runs
    from gaitcore.silhouettes.roto import DOUBTFUL_BELOW

    runs = [(first_frame + a, first_frame + b - 1)
            for a, b in true_runs([st.to_check for st in states])]
    named = ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs) or "none"
    print(f"frames to check: {named} (lost, or of a confidence under {DOUBTFUL_BELOW} in "
          "segmentation.json; correct them with --scribbles)")


def run(args: argparse.Namespace) -> int:
    """Run ``gaitcore segment``; returns the exit status."""
    from gaitcore.io.scribbles import write_segmentation_json
    from gaitcore.silhouettes.extract import is_mask_folder, load_silhouettes
    from gaitcore.silhouettes.settings import write_settings
    from gaitcore.silhouettes.tracking import WORK_SIDE_PX

    if Path(args.input).is_dir() and is_mask_folder(Path(args.input)):
        raise GaitInputError(f"{args.input} already holds binary masks: nothing to segment")
    states: dict = {}
    options = segmentation_options(args)
    if args.save_settings is not None:
        write_settings(args.save_settings, options["settings"])
    roi = load_silhouettes(args.input, args.out, max_side=WORK_SIDE_PX,
                           state_sink=states.__setitem__, **options)
    ordered = [states[t] for t in range(len(roi.lost))] if states else []
    if ordered:
        write_segmentation_json(args.out / "segmentation.json", ordered, source=str(args.input))
    lost = int(roi.lost.sum())
    corrected = sum(st.corrected for st in ordered)
    print(f"frames: {len(roi.lost)} (subject lost in {lost} of them, corrected {corrected})")
    if ordered:
        print_frames_to_check(ordered)
    print(f"wrote {args.out / 'masks'}" + (f" and {args.out / 'segmentation.json'}"
                                           if ordered else ""))
    return 0
