"""The ``gaitcore`` command: the whole method without a GUI.

Exit status: 0 on success, 2 on bad input (one line on stderr, never a traceback), 130 when
interrupted. An unexpected error (a bug) also ends in one line and status 2; set
``GAITCORE_TRACEBACK=1`` to see its traceback.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path
from typing import NoReturn

from gaitcore.bench import synth_command
from gaitcore.errors import GaitInputError
from gaitcore.io import segment_command
from gaitcore.progress import Cancelled
from gaitcore.project import batch_command, pose_command
from gaitcore.schema import check_fps, check_path, dump_json


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, like every other gaitcore error.

    Values that start with a minus and a digit (``--subject -10,-10,50,50``) are values, not
    options (argparse before Python 3.13 took only plain negative numbers for values).
    """

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message: str) -> NoReturn:  # noqa: D102 - argparse API
        raise GaitInputError(f"{self.prog}: {message} (see '{self.prog} --help')")


def _frame_list(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of "
                                         "frames") from None


def _range(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a range lo,hi") from None
    return lo, hi


def _add_frame_range(p: argparse.ArgumentParser) -> None:
    """``--start F --stop F``: the source frames to use (stop excluded), and ``--fps``."""
    p.add_argument("--start", type=int, default=0, metavar="F",
                   help="first source frame to use (default 0)")
    p.add_argument("--stop", type=int, default=None, metavar="F",
                   help="source frame to stop before (default: the end)")
    p.add_argument("--fps", type=float, default=None,
                   help="frame rate of the clip (default: the video's; image folders have none)")


def _clip_fps(args: argparse.Namespace) -> float | None:
    """``--fps``, else the video's frame rate, else None; refuses a bad ``--fps``."""
    from gaitcore.footage.sources import video_fps

    if args.fps is not None:
        return check_fps(args.fps, what="--fps")
    return video_fps(args.input) if args.input.is_file() else None


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
                   help="one fixed-size crop centred on each frame's centre of mass, as the "
                   "paper does (default: crops at the animal's steady height, centred on its "
                   "smoothed track)")
    p.add_argument("--bring-back", type=_frame_list, default=(), metavar="F,F",
                   help="frames to analyse although the animal looks only partly in view "
                   "there (by default they are left out)")
    p.add_argument("--key-time-limit", type=float, default=60.0, metavar="SECONDS",
                   help="time budget of the exact key search (default 60)")
    _add_frame_range(p)
    p.add_argument("--json", action="store_true", help="print analysis.json on stdout")
    p.set_defaults(run=_run_analyze)


def _run_analyze(args: argparse.Namespace) -> int:
    from gaitcore.analysis.analyze import AnalysisSettings
    from gaitcore.io.analysis_file import analysis_to_dict, write_analysis_json
    from gaitcore.project.document import Silhouettes
    from gaitcore.project.steps import analyze
    from gaitcore.silhouettes.extract import is_mask_folder, load_silhouettes

    settings = AnalysisSettings(
        pcs=args.pcs,
        keys=args.keys,
        switching=args.switching,
        pinned=args.pin,
        forbidden=args.forbid,
        key_time_limit_s=args.key_time_limit,
        stabilize_roi=not args.paper_roi,
        bring_back=args.bring_back,
    )
    fps = _clip_fps(args)
    states: dict = {}
    roi = load_silhouettes(args.input, args.out, max_side=settings.max_side_px,
                           start=args.start, stop=args.stop, state_sink=states.__setitem__,
                           **segment_command.segmentation_options(args))
    if states:
        from gaitcore.io.scribbles import write_segmentation_json

        write_segmentation_json(args.out / "segmentation.json",
                                [states[t] for t in sorted(states)], source=str(args.input),
                                first_frame=args.start)
    silhouettes = Silhouettes(roi, "masks" if is_mask_folder(args.input) else "segmented")
    analysis = analyze(silhouettes, settings, first_frame=args.start)
    write_analysis_json(args.out / "analysis.json", analysis, source=str(args.input), fps=fps)
    if args.json:
        print(dump_json(analysis_to_dict(analysis, source=str(args.input), fps=fps), indent=1,
                        what="the analysis"))
    else:
        d = analysis.diagnosis
        sel = analysis.selection
        start, stop = analysis.frame_range
        print(f"frames: {analysis.n_frames}, {start} to {stop - 1} "
              f"(subject lost or left out in {len(analysis.lost_frames)} of them)")
        if fps is None:
            print("frame rate: unknown (an image folder says none): give --fps for periods in "
                  "seconds and for animate's timing, which otherwise assumes 24")
        if states:
            segment_command.print_frames_to_check([states[t] for t in sorted(states)],
                                                  first_frame=args.start)
        print("variance: " + " ".join(f"{100 * v:.1f}%" for v in analysis.pca.variance_ratio))
        print(f"components used: {analysis.pair_name}; r: " + ", ".join(
            f"{name} {r:.2f}" for name, r in zip(analysis.component_names, d.correlations)))
        lagged = analysis.rhythm is not None and analysis.rhythm.lag_frames is not None
        stride = ("" if not lagged or abs(analysis.cycle_frames - d.period_frames) < 0.5
                  else f" (a walk's stride about {analysis.cycle_frames:.1f})")
        print(f"period: {d.period_frames:.1f} frames{stride}; verdict: {d.verdict.value}: "
              f"{d.reason}")
        print(f"key-images: {list(analysis.key_frames)} (cond {sel.condition_number:.3g}, "
              f"{'proven optimal' if sel.exact else 'not proven optimal'})")
        if analysis.alternate_frames is not None:
            print(f"alternates: {list(analysis.alternate_frames)}")
        if analysis.alternates_note:
            print(analysis.alternates_note)
        for c in analysis.cycles:
            d = c.to_dict(analysis.cycle_offset)
            print(f"steady gait: frames {d['start']} to {d['stop'] - 1}, cycle "
                  f"{d['period_frames']:.1f} frames, r1 = {c.r1:.2f}, r2 = {c.r2:.2f}")
        advice = analysis.advice
        if advice is not None:
            for note in advice.notes:
                print(f"note: {note}")
            if advice.cause.value != "none":
                print(f"advice: {advice.message} {advice.next_step}")
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
                   help="CSV with a 'frame' column and one column per channel, one row per key "
                   "(and alternate) frame; 'gaitcore pose' writes one to start from")
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
    p.add_argument("--fps", type=float, default=None,
                   help="frame rate of time_s, the BVH frame time and glTF key times (default: "
                   "the clip's, from analysis.json, else 24)")
    p.add_argument("--csv-time", action="store_true",
                   help="add a time_s column (frame / fps) after 'frame' in CURVES.csv")
    p.add_argument("--loop", action="store_true",
                   help="write one gait cycle that loops (its last frame leads into its first)")
    p.add_argument("--root", choices=("in-place", "footage", "forward", "as-keys"), default=None,
                   help="horizontal root motion: held in place, along the animal's progress in "
                   "the footage (at the --skeleton's scale), forward at constant speed, or as "
                   "interpolated (default: in-place with --loop, else footage when the animal "
                   "crosses the view, else forward)")
    p.add_argument("--speed", type=float, default=None, metavar="M/S",
                   help="speed of --root forward, metres per second (default: the footage's, "
                   "else the keys' roots'); needed when the camera follows the animal")
    p.add_argument("--no-ground-contact", action="store_true",
                   help="leave the feet as interpolated (default: planted through stance and "
                   "kept above the ground by leg IK; needs --skeleton)")
    p.add_argument("--bone-names", choices=("as-is", "rigify"), default="as-is",
                   help="joint names in BVH/glTF: as in the skeleton, or Rigify style (hip.L)")
    p.set_defaults(run=_run_animate)


def _run_animate(args: argparse.Namespace) -> int:
    import numpy as np

    from gaitcore.animation.animate import animate_record
    from gaitcore.footage.sources import DEFAULT_FPS
    from gaitcore.io.analysis_file import read_analysis_json
    from gaitcore.io.export import EXPORTERS
    from gaitcore.io.motion import AUTO, export_motion
    from gaitcore.io.pose_table import PoseTable, pose_matrix, read_pose_table, write_pose_table

    exports = [(flag, path) for flag, path in (("bvh", args.bvh), ("glb", args.glb))
               if path is not None]
    if exports and args.skeleton is None:
        raise GaitInputError(f"--{exports[0][0]} needs --skeleton SKEL.json (or a .bvh file) "
                             "to know the joint hierarchy")
    if args.fps is not None:
        check_fps(args.fps, what="--fps")
    if args.speed is not None and not (np.isfinite(args.speed) and 0 < args.speed <= 100):
        raise GaitInputError(f"--speed must be metres per second in (0, 100], got {args.speed}")
    if args.root == "footage" and args.skeleton is None:
        raise GaitInputError("--root footage needs --skeleton: the footage's travel is "
                             "measured at the rig's size")
    skeleton = None
    if args.skeleton is not None:
        from gaitcore.project.steps import read_rig

        skeleton, note = read_rig(args.skeleton)
        if note:
            print(note)
    record = read_analysis_json(args.analysis)
    fps = args.fps or record.fps or DEFAULT_FPS
    travel = None
    if skeleton is not None:
        from gaitcore.project.footage_fit import travel_metres

        travel = travel_metres(record.travel, skeleton)
    table = read_pose_table(args.key_poses)
    if exports:
        pose_matrix(skeleton, table)  # every channel of the skeleton posed, before any work
    first = record.first_frame
    poses = table.as_dict()
    alternates = None if args.no_switching else record.alternate_frames
    try:
        curves = animate_record(record, poses, alternates=alternates, filtered=args.filtered,
                                clamp=args.clamp)
    except GaitInputError as exc:
        raise GaitInputError(f"{args.key_poses}: {exc}") from None
    _warn_swaps(record, alternates)
    motion = export_motion(curves, table.columns, key_poses=record.rows_of(poses),
                           skeleton=skeleton, loop=args.loop, period_frames=record.period_frames,
                           root_motion=args.root or AUTO,
                           ground_contact=not args.no_ground_contact, first_frame=first,
                           travel_m=travel,
                           speed_m=None if args.speed is None else args.speed / fps)
    out_table = PoseTable(motion.frames, table.columns, motion.poses)
    write_pose_table(args.out, out_table, fps=fps if args.csv_time else None)
    n = len(motion.frames)
    print(f"wrote {args.out} ({n} frames, {len(table.columns)} channels): {motion.summary()}")
    if motion.warning and skeleton is not None:
        print(f"gaitcore: warning: {motion.warning} (--speed M/S)", file=sys.stderr)
    _print_contact(motion.contact)
    for flag, path in exports:  # the flag, not the file's suffix, names the format
        EXPORTERS[f".{flag}"].write(path, skeleton, out_table, fps, args.bone_names)
        print(f"wrote {path} ({skeleton.n_joints} joints, {n} frames at {fps:g} fps)")
    return 0


def _print_contact(contact) -> None:
    """How far the ground contact clean-up moved each foot, one line per foot."""
    for foot in contact.feet if contact is not None else ():
        print(f"  {foot.name}: {foot.stance_frames} frames in stance, moved in "
              f"{foot.moved_frames} frames by up to {100 * foot.max_shift_m:.1f} cm "
              f"(mean {100 * foot.mean_shift_m:.1f} cm); lowest {100 * foot.lowest_before_m:.1f}"
              f" -> {100 * foot.lowest_after_m:.1f} cm")


def _warn_swaps(record, alternates: tuple[int, ...] | None) -> None:
    """Warn (stderr) when the alternates swap left and right faster than the gait."""
    from gaitcore.analysis.alternates import swap_warning

    warning = alternates and swap_warning(record.loop_angle, record.rows(record.key_frames),
                                          record.rows(alternates))
    if warning:
        print(f"gaitcore: warning: {warning}", file=sys.stderr)


def _int_list(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of "
                                         "numbers") from None
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
    from gaitcore.bench.synth_command import MAX_FRAMES, MAX_SIDE_PX

    for name, hi in (("frames", MAX_FRAMES), ("width", MAX_SIDE_PX), ("height", MAX_SIDE_PX)):
        value = getattr(args, name)
        if not 8 <= value <= hi:
            raise GaitInputError(f"--{name} must be from 8 to {hi}, got {value}")

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
        print(dump_json(ev.to_dict(), indent=1, what="the evaluation"))
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
    pose_command.add_parser(sub)
    synth_command.add_parser(sub)
    segment_command.add_parser(sub)
    _add_evaluate(sub)
    batch_command.add_parser(sub)
    return parser


def _flag(dest: str) -> str:
    """How the command line names argument ``dest`` (``--key-poses``, ``input``)."""
    return dest if dest in POSITIONAL else f"--{dest.replace('_', '-')}"


POSITIONAL = ("input", "analysis", "manifest")


def main(argv: list[str] | None = None) -> int:
    """Run the ``gaitcore`` command; returns the exit status."""
    try:
        args = build_parser().parse_args(argv)
        for name, value in vars(args).items():
            if isinstance(value, Path):
                setattr(args, name, check_path(value, what=_flag(name)))
        return args.run(args)
    except GaitInputError as exc:
        print(f"gaitcore: error: {exc}", file=sys.stderr)
        return 2
    except Cancelled as exc:
        print(f"gaitcore: {exc}", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print("gaitcore: interrupted", file=sys.stderr)
        return 130
    except OSError as exc:
        print(f"gaitcore: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "),
              file=sys.stderr)
        return 2
    except Exception as exc:  # noqa: BLE001 - a bug must still end in one line, not a traceback
        if os.environ.get("GAITCORE_TRACEBACK"):
            raise
        message = " ".join(str(exc).split())[:300]
        print(f"gaitcore: error: unexpected {type(exc).__name__} ({message}); this is a bug: "
              "please report it with the command (GAITCORE_TRACEBACK=1 shows where)",
              file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
