"""The ``gaitcore synth`` subcommand: render a synthetic horse clip with its true poses.

Writes ``DIR/images/00000.png...`` (shaded renders), ``DIR/masks/00000.png...`` (single
channel, 0 or 255), ``DIR/poses.csv`` (``frame`` then one column per channel; metres and
degrees) and ``DIR/skeleton.json``: the input and the ground truth of the paper's Section 4.
A folder that is not empty is written into only with ``--overwrite`` (its numbered frames are
then replaced), so a wrong ``--out`` never touches the user's own images.
"""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path

import numpy as np

from gaitcore.errors import GaitInputError

_FRAME_PNG = re.compile(r"^\d{5}\.png$")
MAX_FRAMES = 99_999
"""Frames are named 00000.png to 99999.png."""
MAX_SIDE_PX = 8192


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``synth`` on an argparse subparsers object (``set_defaults(run=...)``)."""
    from gaitcore.bench.gaits import GAITS

    p = subparsers.add_parser(
        "synth",
        help="render a synthetic horse gait clip with its true poses",
        description="Render a horse skeleton of ellipsoids in a periodic gait from the side "
        "(paper Section 4) and write the images, binary masks, true poses and skeleton.",
    )
    p.add_argument("--gait", choices=list(GAITS), required=True, help="gait to generate")
    p.add_argument("--frames", type=int, required=True, metavar="N", help="number of frames")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.add_argument("--width", type=int, default=320, metavar="W", help="image width (320)")
    p.add_argument("--height", type=int, default=240, metavar="H", help="image height (240)")
    p.add_argument("--period", type=float, default=None, metavar="P",
                   help="frames per gait cycle (walk 40, trot 30, canter 28, gallop 24)")
    p.add_argument("--noise", type=float, default=0.0, metavar="DEG",
                   help="std of Gaussian noise added to every joint angle, degrees (0)")
    p.add_argument("--seed", type=_seed, default=None, metavar="S", help="noise seed (0 or more)")
    p.add_argument("--yaw", type=float, default=0.0, metavar="DEG",
                   help="camera turn about the vertical from the pure side view (0)")
    p.add_argument("--elevation", type=float, default=0.0, metavar="DEG",
                   help="camera elevation, positive looks down (0)")
    p.add_argument("--lead", choices=("left", "right"), default="left",
                   help="leading leg for canter and gallop (left)")
    p.add_argument("--overwrite", action="store_true",
                   help="write into a folder that is not empty (its numbered frames are replaced)")
    p.set_defaults(run=run)


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"'{text}' is not a seed (a whole number from 0)")
    return value


def _check(args: argparse.Namespace) -> None:
    """Refuse values the renderer cannot honour, before anything is written."""
    for name, lo, hi in (("frames", 1, MAX_FRAMES), ("width", 8, MAX_SIDE_PX),
                         ("height", 8, MAX_SIDE_PX)):
        value = getattr(args, name)
        if not lo <= value <= hi:
            raise GaitInputError(f"--{name} must be from {lo} to {hi}, got {value}")
    for name in ("period", "noise", "yaw", "elevation"):
        value = getattr(args, name)
        if value is not None and not math.isfinite(value):
            raise GaitInputError(f"--{name} must be a finite number, got {value}")
    if args.noise < 0:
        raise GaitInputError(f"--noise must be 0 or more degrees, got {args.noise}")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise GaitInputError(f"--out {out} exists and is not a folder; pick a folder path")
    if out.is_dir() and any(out.iterdir()) and not args.overwrite:
        raise GaitInputError(f"--out {out} is not empty: pick a new folder, or add --overwrite "
                             "to replace the clip in it")


def run(args: argparse.Namespace) -> int:
    """Generate, render and write the clip; returns the exit status (0)."""
    import cv2

    from gaitcore.bench.gaits import generate_gait
    from gaitcore.io.pose_table import PoseTable, write_pose_table
    from gaitcore.rig.render import iter_render
    from gaitcore.rig.templates import load_template

    _check(args)
    skeleton = load_template("horse")
    poses = generate_gait(skeleton, args.gait, args.frames, period_frames=args.period,
                          noise_deg=args.noise, seed=args.seed, lead=args.lead)
    out = Path(args.out)
    images, masks = out / "images", out / "masks"
    for folder in (images, masks):
        folder.mkdir(parents=True, exist_ok=True)
        for stale in folder.iterdir():  # frames of an earlier, longer run would mix in
            if _FRAME_PNG.match(stale.name):
                stale.unlink()
    frames = iter_render(skeleton, poses, width=args.width, height=args.height,
                         yaw_deg=args.yaw, elevation_deg=args.elevation)
    for i, (rgb, mask) in enumerate(frames):
        name = f"{i:05d}.png"
        ok = cv2.imwrite(str(images / name), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        ok &= cv2.imwrite(str(masks / name), mask.astype(np.uint8) * 255)
        if not ok:
            raise GaitInputError(f"could not write {name} under {out}; check the folder")
    write_pose_table(out / "poses.csv",
                     PoseTable(np.arange(len(poses)), skeleton.channel_names, poses))
    skeleton.to_json(out / "skeleton.json")
    print(f"wrote {len(poses)} frames of {args.gait} ({args.width}x{args.height}) to {out}")
    return 0
