"""The ``gaitcore`` command: the whole method without a GUI.

Exit status: 0 on success, 2 on bad input (one line on stderr, never a traceback), 130 when
interrupted.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gaitcore.bench import synth_command
from gaitcore.errors import GaitInputError
from gaitcore.io import segment_command


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, like every other gaitcore error."""

    def error(self, message: str) -> None:  # noqa: D102 - argparse API
        raise GaitInputError(f"{self.prog}: {message} (see '{self.prog} --help')")


def _frame_list(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of frames") from None


def _range(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a range lo,hi") from None
    return lo, hi


def _add_analyze(sub) -> None:
    p = sub.add_parser(
        "analyze",
        help="silhouettes -> PCA -> diagnosis -> key-images",
        description="Analyze a clip: a video file, a folder of colour images, or a folder of "
        "binary masks (then segmentation is skipped).",
    )
    p.add_argument("input", type=Path, help="video file, image folder or mask folder")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--pcs", type=int, default=2, help="principal components used (default 2)")
    p.add_argument("--keys", type=int, default=4, help="key-images to select (default 4)")
    p.add_argument("--switching", action="store_true", help="propose alternates for walks")
    segment_command.add_segmentation_options(p)
    p.add_argument("--pin", type=_frame_list, default=(), metavar="F,F",
                   help="frames that must be key-images")
    p.add_argument("--forbid", type=_frame_list, default=(), metavar="F,F",
                   help="frames that must not be key-images")
    p.add_argument("--paper-roi", action="store_true",
                   help="centre each crop on its own frame's centre of mass, as the paper does "
                   "(default: on the track averaged over one gait period)")
    p.add_argument("--key-time-limit", type=float, default=60.0, metavar="SECONDS",
                   help="time budget of the exact key search (default 60)")
    p.add_argument("--json", action="store_true", help="print analysis.json on stdout")
    p.set_defaults(run=_run_analyze)


def _run_analyze(args: argparse.Namespace) -> int:
    from gaitcore.analysis.analyze import AnalysisSettings, analyze_silhouettes
    from gaitcore.io.analysis_file import analysis_to_dict, write_analysis_json
    from gaitcore.silhouettes.extract import load_silhouettes

    settings = AnalysisSettings(
        pcs=args.pcs,
        keys=args.keys,
        switching=args.switching,
        pinned=args.pin,
        forbidden=args.forbid,
        key_time_limit_s=args.key_time_limit,
        stabilize_roi=not args.paper_roi,
    )
    states: dict = {}
    roi = load_silhouettes(args.input, args.out, max_side=settings.max_side_px,
                           state_sink=states.__setitem__,
                           **segment_command.segmentation_options(args))
    if states:
        from gaitcore.io.scribbles import write_segmentation_json

        write_segmentation_json(args.out / "segmentation.json",
                                [states[t] for t in sorted(states)], source=str(args.input))
    analysis = analyze_silhouettes(roi, settings)
    write_analysis_json(args.out / "analysis.json", analysis, source=str(args.input))
    if args.json:
        print(json.dumps(analysis_to_dict(analysis, source=str(args.input)), indent=1))
    else:
        d = analysis.diagnosis
        sel = analysis.selection
        print(f"frames: {analysis.n_frames} (subject lost in {len(analysis.lost_frames)})")
        print("variance: " + " ".join(f"{100 * v:.1f}%" for v in analysis.pca.variance_ratio))
        print("r per PC: " + " ".join(f"{r:.2f}" for r in d.correlations))
        print(f"period: {d.period_frames:.1f} frames; verdict: {d.verdict.value}: {d.reason}")
        print(f"key-images: {list(sel.frames)} (cond {sel.condition_number:.3g}, "
              f"{'proven optimal' if sel.exact else 'not proven optimal'})")
        if analysis.alternate_frames is not None:
            print(f"alternates: {list(analysis.alternate_frames)}")
        print(f"wrote {args.out / 'analysis.json'}")
    return 0


def _add_animate(sub) -> None:
    p = sub.add_parser(
        "animate",
        help="key poses -> a pose per frame (RBF interpolation)",
        description="Interpolate the poses of the key-images over the whole clip.",
    )
    p.add_argument("analysis", type=Path, help="analysis.json written by 'gaitcore analyze'")
    p.add_argument("--key-poses", type=Path, required=True, metavar="KEYS.csv",
                   help="CSV with a 'frame' column and one column per channel")
    p.add_argument("--out", type=Path, required=True, metavar="CURVES.csv")
    p.add_argument("--filtered", action="store_true",
                   help="drive the animation with the band-pass filtered trajectories")
    p.add_argument("--clamp", type=_range, default=None, metavar="LO,HI",
                   help="clamp the RBF weights to this range (e.g. -0.2,1.2)")
    p.add_argument("--no-switching", action="store_true",
                   help="ignore the alternates of the analysis and use the keys alone")
    p.add_argument("--bvh", type=Path, default=None, metavar="OUT.bvh",
                   help="also write a BVH file (needs --skeleton)")
    p.add_argument("--glb", type=Path, default=None, metavar="OUT.glb",
                   help="also write a binary glTF with a skinned mesh (needs --skeleton)")
    p.add_argument("--skeleton", type=Path, default=None, metavar="SKEL.json|SKEL.bvh",
                   help="joint hierarchy for --bvh/--glb: a skeleton JSON, or a BVH file")
    p.add_argument("--fps", type=float, default=24.0,
                   help="frame rate of time_s, the BVH frame time and glTF key times (24)")
    p.add_argument("--csv-time", action="store_true",
                   help="add a time_s column (frame / fps) after 'frame' in CURVES.csv")
    p.set_defaults(run=_run_animate)


def _run_animate(args: argparse.Namespace) -> int:
    import numpy as np

    from gaitcore.animation.animate import animate
    from gaitcore.io.analysis_file import read_analysis_json
    from gaitcore.io.export import EXPORTERS
    from gaitcore.io.pose_table import PoseTable, pose_matrix, read_pose_table, write_pose_table

    exports = [(flag, path) for flag, path in (("bvh", args.bvh), ("glb", args.glb))
               if path is not None]
    if exports and args.skeleton is None:
        raise GaitInputError(f"--{exports[0][0]} needs --skeleton SKEL.json (or a .bvh file) "
                             "to know the joint hierarchy")
    if not (np.isfinite(args.fps) and args.fps > 0):
        raise GaitInputError(f"--fps must be a positive number of frames per second, got {args.fps}")
    skeleton = None
    if args.skeleton is not None:
        from gaitcore.io.bvh.reader import read_bvh
        from gaitcore.rig.skeleton import Skeleton

        if args.skeleton.suffix.lower() == ".bvh":
            skeleton = read_bvh(args.skeleton)[0]
        else:
            skeleton = Skeleton.from_json(args.skeleton)
    record = read_analysis_json(args.analysis)
    table = read_pose_table(args.key_poses)
    if exports:
        pose_matrix(skeleton, table)  # every channel of the skeleton posed, before any work
    poses = table.as_dict()
    alternates = None if args.no_switching else record.alternate_frames
    posed = set(record.key_frames) | set(alternates or ())
    extra = sorted(set(poses) - posed)
    if extra:
        raise GaitInputError(
            f"{args.key_poses}: frame(s) {extra} are not key-images of this analysis "
            f"(keys {list(record.key_frames)}"
            + (f", alternates {list(alternates)}" if alternates else "")
            + ")"
        )
    coords = record.filtered_projections if args.filtered else record.projections
    curves = animate(
        coords,
        record.key_frames,
        poses,
        alternate_frames=alternates,
        theta=record.loop_angle,
        alpha=record.alpha,
        clamp=args.clamp,
    )
    out_table = PoseTable(np.arange(record.n_frames), table.columns, curves)
    write_pose_table(args.out, out_table, fps=args.fps if args.csv_time else None)
    print(f"wrote {args.out} ({record.n_frames} frames, {len(table.columns)} channels)")
    for flag, path in exports:  # the flag, not the file's suffix, names the format
        EXPORTERS[f".{flag}"].write(path, skeleton, out_table, args.fps)
        print(f"wrote {path} ({skeleton.n_joints} joints, {record.n_frames} frames "
              f"at {args.fps:g} fps)")
    return 0


def _int_list(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of numbers") from None
    if not values:
        raise argparse.ArgumentTypeError("give at least one number")
    return values


def _add_evaluate(sub) -> None:
    p = sub.add_parser(
        "evaluate",
        help="the paper's Section 4 experiment on a synthetic horse",
        description="Render a synthetic gait, run the pipeline, pose the keys with the true "
        "poses and measure the error of the predicted joint angles about the axis "
        "perpendicular to the image.",
    )
    p.add_argument("--gait", choices=("walk", "trot", "canter", "gallop"), required=True)
    p.add_argument("--pcs", type=_int_list, default=(1, 2, 3, 4, 5), metavar="1,2,3")
    p.add_argument("--keys", type=_int_list, default=(2, 3, 4, 5), metavar="2,3,4")
    p.add_argument("--switching", action="store_true",
                   help="also evaluate switching models (keys + alternates)")
    p.add_argument("--frames", type=int, default=100, help="clip length (100)")
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--yaw", type=float, default=0.0, help="camera yaw off the side view, deg")
    p.add_argument("--elevation", type=float, default=0.0, help="camera elevation, deg")
    p.add_argument("--mask-noise", type=float, default=0.0, metavar="FRACTION",
                   help="fraction of mask pixels flipped at random (e.g. 0.05)")
    p.add_argument("--paper-roi", action="store_true",
                   help="centre crops on each frame's centre of mass, as the paper does")
    p.add_argument("--plots", type=Path, default=None, metavar="DIR",
                   help="write PNG figures like the paper's Figures 3 and 6")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(run=_run_evaluate)


def _run_evaluate(args: argparse.Namespace) -> int:
    from gaitcore.bench.evaluate import BenchSettings, evaluate_gait

    settings = BenchSettings(
        gait=args.gait, n_frames=args.frames, width=args.width, height=args.height,
        yaw_deg=args.yaw, elevation_deg=args.elevation, mask_noise=args.mask_noise,
    )
    ev = evaluate_gait(settings, pcs=args.pcs, keys=args.keys, switching=args.switching,
                       stabilize_roi=not args.paper_roi)
    if args.plots is not None:
        from gaitcore.bench.plots import plot_error_curves, plot_trajectory

        args.plots.mkdir(parents=True, exist_ok=True)
        pcs, keys = min(2, max(args.pcs)), 4 if 4 in args.keys else max(args.keys)
        if (pcs, keys) in ev.analyses:
            plot_trajectory(ev, args.plots / f"{args.gait}_pc1_pc2.png", pcs=pcs, keys=keys)
        plot_error_curves(ev, args.plots / f"{args.gait}_error.png")
    if args.json:
        print(json.dumps(ev.to_dict(), indent=1))
        return 0
    print(f"{args.gait}: {ev.n_angles} angles, period {ev.period_frames:.1f} frames")
    print("variance %: " + " ".join(f"{100 * v:.1f}" for v in ev.variance_ratio))
    print("r per PC:   " + " ".join(f"{r:.2f}" for r in ev.correlations))
    print("pcs keys  mean_deg  std_deg  floor_deg")
    for c in ev.grid:
        tail = "  (switching)" if c.switching else f"  {c.floor_deg:9.2f}"
        print(f"{c.pcs:3d} {c.keys:4d} {c.mean_deg:9.2f} {c.std_deg:8.2f}{tail}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The ``gaitcore`` argument parser with all its subcommands."""
    parser = _Parser(prog="gaitcore", description="Animal gaits from video, headless.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _add_analyze(sub)
    _add_animate(sub)
    synth_command.add_parser(sub)
    segment_command.add_parser(sub)
    _add_evaluate(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the ``gaitcore`` command; returns the exit status."""
    try:
        args = build_parser().parse_args(argv)
        return args.run(args)
    except GaitInputError as exc:
        print(f"gaitcore: error: {exc}", file=sys.stderr)
        return 2
    except InterruptedError as exc:
        print(f"gaitcore: {exc}", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print("gaitcore: interrupted", file=sys.stderr)
        return 130
    except OSError as exc:
        print(f"gaitcore: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
