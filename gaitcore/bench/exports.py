"""What an animator gets from the exports of the synthetic bench: feet, slip, root, angles.

The pipeline of :func:`gaitcore.bench.evaluate.evaluate_gait` (2 PCs, 4 keys, switching on
the walk, keys posed with the true poses), then :func:`gaitcore.io.motion.export_motion`
with the defaults and with the clean-up off, measured against the true motion:

    python -m gaitcore.bench.exports            (about a minute; prints the table)

``scripts/make_validation.py`` writes the same figures into ``docs/validation.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.analysis.analyze import AnalysisSettings, analyze_silhouettes
from gaitcore.animation.animate import animate
from gaitcore.bench.evaluate import BenchSettings, angle_error_deg, render_bench_clip
from gaitcore.bench.gaits import GAITS, stance_mask
from gaitcore.io.motion import export_motion
from gaitcore.rig.contact import find_feet
from gaitcore.rig.skeleton import Skeleton
from gaitcore.silhouettes.tracking import crop_rois


@dataclass(frozen=True)
class ExportFigures:
    """Measured on one gait; lengths in centimetres, angles in degrees.

    Attributes
    ----------
    gait : str
    error_raw_deg, error_clean_deg : float
        Mean joint-angle error about the image normal against the truth, without and with
        the ground contact clean-up.
    lowest_raw_cm, lowest_clean_cm : float
        Lowest point of any foot (toe or the joint carrying it) over all frames.
    slip_raw_cm, slip_clean_cm : float
        Largest horizontal foot movement in one frame while the true foot is in stance.
    back_step_as_keys_cm : float
        Largest backward step of the root with the interpolated root (the old export).
    speed_error_pct : float
        Forward speed of the export against the true mean speed, percent.
    speed_spread_pct : float
        Spread (max - min) of the forward root's per-frame steps, percent of the mean step.
    in_place_speed_cm : float
        Mean horizontal root velocity of the in-place loop, centimetres per frame.
    loop_seam_cm : float
        Largest distance between a joint in the loop's closing frame and in its first.
    """

    gait: str
    error_raw_deg: float
    error_clean_deg: float
    lowest_raw_cm: float
    lowest_clean_cm: float
    slip_raw_cm: float
    slip_clean_cm: float
    back_step_as_keys_cm: float
    speed_error_pct: float
    speed_spread_pct: float
    in_place_speed_cm: float
    loop_seam_cm: float


def measure_exports(gait: str, *, n_frames: int = 100) -> ExportFigures:
    """Run the bench pipeline on ``gait`` and measure its exports (see the module)."""
    settings = BenchSettings(gait=gait, n_frames=n_frames)
    skeleton, truth, masks = render_bench_clip(settings)
    analysis = analyze_silhouettes(crop_rois(masks), AnalysisSettings(
        pcs=2, keys=4, switching=gait in ("walk", "trot")))
    posed = {f: truth[f] for f in analysis.posed_frames}
    curves = animate(analysis.coords, analysis.key_frames, posed,
                     alternate_frames=analysis.alternate_frames, theta=analysis.loop_angle)
    names, period = skeleton.channel_names, analysis.diagnosis.period_frames

    def export(**options):
        return export_motion(curves, names, key_poses=posed, skeleton=skeleton,
                             period_frames=period, **options).poses

    clean, raw = export(), export(ground_contact=False)
    as_keys = export(root_motion="as-keys", ground_contact=False)
    loop = export(loop=True)
    idx = skeleton.sagittal_angle_indices
    spec = GAITS[gait]
    steps = np.diff(clean[:, skeleton.channel_index("root.tx")])
    in_place = np.diff(loop[:-1, skeleton.channel_index("root.tx")])
    seam = skeleton.joint_positions(loop[-1]) - skeleton.joint_positions(loop[0])
    return ExportFigures(
        gait=gait,
        error_raw_deg=float(angle_error_deg(raw[:, idx], truth[:, idx]).mean()),
        error_clean_deg=float(angle_error_deg(clean[:, idx], truth[:, idx]).mean()),
        lowest_raw_cm=100 * _lowest(skeleton, raw),
        lowest_clean_cm=100 * _lowest(skeleton, clean),
        slip_raw_cm=100 * _stance_slip(skeleton, raw, gait),
        slip_clean_cm=100 * _stance_slip(skeleton, clean, gait),
        back_step_as_keys_cm=100 * float(max(0.0, -np.diff(
            skeleton.joint_positions(as_keys)[:, 0, 0]).min())),
        speed_error_pct=100 * float(steps.mean() / (spec.stride_m / spec.period_frames) - 1),
        speed_spread_pct=100 * float(np.ptp(steps) / steps.mean()),
        in_place_speed_cm=100 * float(in_place.mean()),
        loop_seam_cm=100 * float(np.linalg.norm(seam, axis=1).max()),
    )


def _feet_and_heels(skeleton: Skeleton) -> list[int]:
    feet = [skeleton.joint_index(f) for f in find_feet(skeleton)]
    return feet + [int(skeleton.parents[f]) for f in feet]


def _lowest(skeleton: Skeleton, poses: np.ndarray) -> float:
    return float(skeleton.joint_positions(poses)[:, _feet_and_heels(skeleton), 1].min())


def _stance_slip(skeleton: Skeleton, poses: np.ndarray, gait: str) -> float:
    """Largest horizontal step of a toe between two frames both in true stance, metres."""
    stance = stance_mask(gait, len(poses))
    world = skeleton.joint_positions(poses)
    worst = 0.0
    for foot in find_feet(skeleton):
        limb = foot[0] + ("F" if "fore" in foot else "H")
        both = stance[limb][1:] & stance[limb][:-1]
        step = np.linalg.norm(np.diff(world[:, skeleton.joint_index(foot)][:, [0, 2]], axis=0),
                              axis=1)
        worst = max(worst, float(step[both].max(initial=0.0)))
    return worst


def main() -> None:
    """Print the figures of the synthetic canter and walk."""
    print("gait   err raw/clean (deg)  lowest raw/clean (cm)  stance slip raw/clean (cm/frame)"
          "  back step as-keys (cm)  speed err (%)  speed spread (%)  in-place v (cm/frame)"
          "  loop seam (cm)")
    for gait in ("canter", "walk"):
        f = measure_exports(gait)
        print(f"{gait:6s} {f.error_raw_deg:6.2f} / {f.error_clean_deg:5.2f}     "
              f"{f.lowest_raw_cm:7.2f} / {f.lowest_clean_cm:5.2f}        "
              f"{f.slip_raw_cm:6.2f} / {f.slip_clean_cm:5.2f}                  "
              f"{f.back_step_as_keys_cm:7.1f}              {f.speed_error_pct:+6.2f}        "
              f"{f.speed_spread_pct:7.4f}           {f.in_place_speed_cm:8.5f}          "
              f"{f.loop_seam_cm:.5f}")


if __name__ == "__main__":
    main()
