"""The ``gaitcore synth`` subcommand: render a synthetic horse clip with its true poses.

Writes ``DIR/images/00000.png...`` (shaded renders), ``DIR/masks/00000.png...`` (single
channel, 0 or 255), ``DIR/poses.csv`` (``frame`` then one column per channel; metres and
degrees) and ``DIR/skeleton.json``: the input and the ground truth of the paper's Section 4.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import numpy as np

from gaitcore.errors import GaitInputError

_FRAME_PNG = re.compile(r"^\d{5}\.png$")


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
    p.add_argument("--seed", type=int, default=None, metavar="S", help="noise seed")
    p.add_argument("--yaw", type=float, default=0.0, metavar="DEG",
                   help="camera turn about the vertical from the pure side view (0)")
    p.add_argument("--elevation", type=float, default=0.0, metavar="DEG",
                   help="camera elevation, positive looks down (0)")
    p.add_argument("--lead", choices=("left", "right"), default="left",
                   help="leading leg for canter and gallop (left)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Generate, render and write the clip; returns the exit status (0)."""
    import cv2

    from gaitcore.bench.gaits import generate_gait
    from gaitcore.io.pose_table import PoseTable, write_pose_table
    from gaitcore.rig.render import iter_render
    from gaitcore.rig.skeleton import load_template

    if args.frames < 1:
        raise GaitInputError(f"--frames must be at least 1, got {args.frames}")
    skeleton = load_template("horse")
    poses = generate_gait(skeleton, args.gait, args.frames, period_frames=args.period,
                          noise_deg=args.noise, seed=args.seed, lead=args.lead)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise GaitInputError(f"--out {out} exists and is not a folder; pick a folder path")
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
