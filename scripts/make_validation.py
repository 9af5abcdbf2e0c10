"""Regenerate docs/validation.md and its figures: the paper's Section 4 on our synthetic bench.

    .venv/bin/python scripts/make_validation.py      (about five minutes on 2 cores)

Every figure in the document comes from ``gaitcore.bench.evaluate`` run here; nothing is typed in.
"""

from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import numpy as np  # noqa: E402

from gaitcore.bench.blend_floor import best_blend_floor  # noqa: E402
from gaitcore.bench.evaluate import BenchSettings, evaluate_gait  # noqa: E402
from gaitcore.bench.exports import measure_exports  # noqa: E402
from gaitcore.bench.gaits import generate_gait  # noqa: E402
from gaitcore.bench.plots import plot_error_curves, plot_trajectory  # noqa: E402
from gaitcore.rig.templates import load_template  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FIGS = DOCS / "figures"
GAITS = ("walk", "trot", "canter", "gallop")
PAPER_VARIANCE = {
    "walk": (33.7, 23.7, 11.4, 8.56),
    "canter": (32.5, 14.5, 9.17, 8.78),
    "gallop": (31.1, 19.9, 11.0, 8.33),
}
MEASURED_WALK_ROM = {"carpus": "54 +- 4", "hock": "40 +- 9", "fore_fetlock": "45 +- 8",
                     "hind_fetlock": "60 +- 10"}
"""Sagittal ranges of motion of flat-walking Tennessee Walking Horse yearlings (2-D kinematics,
"Two-dimensional kinematics of the flat-walking Tennessee Walking Horse yearling")."""
PAPER_R = {"walk": (.99, .94, "<.01", .05, "<.01"), "canter": (.94, .89, .08, "<.01", .01),
           "gallop": (.90, .92, .01, "<.01", "<.01")}


def true_angles(gait: str, n_frames: int = 100) -> np.ndarray:
    """The true angles about the image normal of the bench clip."""
    skel = load_template("horse")
    return generate_gait(skel, gait, n_frames)[:, skel.sagittal_angle_indices]


def fundamental_share(ev) -> np.ndarray:
    """Share of each PC's variance carried by a sinusoid at the gait frequency f0."""
    diagnosis = ev.analyses[min(ev.analyses)].diagnosis
    t = np.arange(len(ev.projections))
    basis = np.column_stack([np.cos(2 * np.pi * diagnosis.f0 * t),
                             np.sin(2 * np.pi * diagnosis.f0 * t), np.ones_like(t)])
    x = ev.projections - ev.projections.mean(axis=0)
    fit = basis @ np.linalg.lstsq(basis, x, rcond=None)[0]
    return (fit**2).sum(axis=0) / (x**2).sum(axis=0)


def _row(*cells) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def _exports_section() -> list[str]:
    """Root motion and ground contact of the exports (gaitcore.bench.exports)."""
    figures = [measure_exports(g) for g in ("canter", "walk")]
    out = ["", "## Exports: root motion and feet on the ground", "",
           "The same pipeline (2 PCs, 4 keys, switching on the walk, keys posed with the true",
           "poses), exported by `gaitcore.io.motion.export_motion` with the defaults (forward",
           "root motion at the keys' speed, ground contact clean-up on) and with the clean-up off.",
           "Reproduce with `python -m gaitcore.bench.exports`. Feet are the four toes and the",
           "hoof joints carrying them; stance is the true stance of the synthetic gait.", "",
           _row("gait", "angle error, clean-up off / on (deg)", "lowest foot, off / on (cm)",
                "stance slip, off / on (cm per frame)", "acceptance"), _row(*["---"] * 5)]
    for f in figures:
        ok = (f.lowest_clean_cm >= -0.5 and f.slip_clean_cm <= 1.0
              and f.error_clean_deg - f.error_raw_deg <= 0.3)
        out.append(_row(f.gait, f"{f.error_raw_deg:.2f} / {f.error_clean_deg:.2f}",
                        f"{f.lowest_raw_cm:.2f} / {f.lowest_clean_cm:.2f}",
                        f"{f.slip_raw_cm:.2f} / {f.slip_clean_cm:.2f}",
                        "met" if ok else "missed"))
    out += ["",
            "Acceptance: no foot below -0.5 cm, stance slip at most 1 cm per frame, angle error",
            "at most 0.3 deg worse than without the clean-up. The synthetic hooves are planted",
            "in the side view only; as the trunk rolls and yaws the true hooves slide sideways",
            "by up to 2.5 cm a frame, which the clean-up removes along with the interpolation's",
            "skating.", "",
            _row("gait", "root as interpolated: largest step back (cm)",
                 "forward: speed vs truth (%)",
                 "forward: spread of steps (%)", "in-place loop: mean velocity (cm/frame)",
                 "loop: closing frame vs first (cm)"), _row(*["---"] * 6)]
    for f in figures:
        out.append(_row(f.gait, f"{f.back_step_as_keys_cm:.1f}", f"{f.speed_error_pct:+.2f}",
                        f"{f.speed_spread_pct:.4f}", f"{f.in_place_speed_cm:.5f}",
                        f"{f.loop_seam_cm:.5f}"))
    return out


def main() -> None:
    FIGS.mkdir(parents=True, exist_ok=True)
    results, robust_ev, paper_roi = _evaluate()
    out = (_headline(results) + _floors(results) + _grids(results) + _spectra(results)
           + _roi(results, paper_roi) + _robustness(robust_ev) + _exports_section())
    out.append("")
    (DOCS / "validation.md").write_text("\n".join(out) + "\n", encoding="utf-8")
    print("\n".join(out))


def _evaluate():
    """Every gait's bench (with its plots), the robustness cases and the paper's ROI."""
    results = {}
    for gait in GAITS:
        ev = evaluate_gait(BenchSettings(gait=gait), keys=(2, 3, 4, 5, 6),
                           switching=gait in ("walk", "trot"))
        results[gait] = ev
        plot_trajectory(ev, FIGS / f"{gait}_pc1_pc2.png")
        plot_error_curves(ev, FIGS / f"{gait}_error.png")
    robust = {
        "side view (reference)": BenchSettings(gait="canter"),
        "camera 15 deg off the side view": BenchSettings(gait="canter", yaw_deg=15.0),
        "5% of mask pixels flipped": BenchSettings(gait="canter", mask_noise=0.05),
    }
    robust_ev = {k: evaluate_gait(s, pcs=(2,), keys=(4,)) for k, s in robust.items()}
    paper_roi = {g: evaluate_gait(BenchSettings(gait=g), pcs=(2,), keys=(4, 5, 6),
                                  switching=g in ("walk", "trot"), stabilize_roi=False)
                 for g in GAITS}

    return results, robust_ev, paper_roi


def _headline(results) -> list[str]:
    """The bench described, and the error with 4 keys and 2 PCs."""
    out = ["# Validation on the synthetic horse (paper Section 4)", ""]
    out += [
        "Regenerate with `.venv/bin/python scripts/make_validation.py`; single gaits with",
        "`gaitcore evaluate --gait G --pcs 1,2,3,4,5 --keys 2,3,4,5 [--switching] --plots DIR`.",
        "",
        "The bench: the 45-joint ellipsoid horse of `resources/skeletons/horse.json`, 100 frames",
        "at 320 x 240 (the paper's sizes), rendered from the side with pyrender. The pipeline is",
        "the product's own: masks -> tracked ROI -> PCA -> exact key selection -> keys posed",
        "with the true poses -> RBF prediction. The error is the mean (standard deviation) of",
        "|true - predicted| over every frame and every joint angle about the axis perpendicular",
        f"to the image ({results['canter'].n_angles} angles; the paper had 36).",
        "",
        "## Error with 4 keys and 2 PCs (the paper's recommended setting)",
        "",
        _row("gait", "4 keys, 2 PCs (deg)", "best of grid (deg)", "switching 4+4 (deg)",
             "acceptance"),
        _row("---", "---", "---", "---", "---"),
    ]
    for gait, ev in results.items():
        c = ev.cell(2, 4)
        best = min((x for x in ev.grid if not x.switching), key=lambda x: x.mean_deg)
        sw = ev.cell(2, 4, switching=True) if gait in ("walk", "trot") else None
        if gait in ("canter", "gallop"):
            target = "<= 2.0: " + ("met" if c.mean_deg <= 2.0
                                   else f"missed by {c.mean_deg - 2.0:.1f}")
        elif gait == "walk":
            ok = sw.mean_deg <= 3.0 and sw.mean_deg <= 0.5 * c.mean_deg
            target = (f"switching <= 3.0 and <= half of {c.mean_deg:.2f}: "
                      + ("met" if ok else "missed"))
        else:
            target = "(none)"
        out.append(_row(gait, f"{c.mean_deg:.2f} ({c.std_deg:.2f})",
                        f"{best.mean_deg:.2f} ({best.pcs} PCs, {best.keys} keys)",
                        f"{sw.mean_deg:.2f} ({sw.std_deg:.2f})" if sw else "-", target))
    return out


def _floors(results) -> list[str]:
    """Why 2.0 deg with 4 keys is out of reach: the floor of any linear blend of m poses."""
    out: list[str] = []
    floors = {(g, m): best_blend_floor(true_angles(g), m)
              for g in ("canter", "gallop") for m in (4, 5)}
    out += [
        "",
        "### Why 2.0 deg with 4 keys is out of reach on canter and gallop",
        "",
        "The RBF map predicts every frame as a linear combination of the key poses, so no",
        "timing, kernel or segmentation can beat, frame by frame, the best linear blend of",
        "those poses (`gaitcore/blend_floor.py`). That floor, in the same metric:",
        "",
        "- *our keys*: exact (least absolute deviations, a linear program per frame) for the",
        "  keys the condition number picked; `gaitcore evaluate` prints it as `floor_deg`;",
        "- *any m poses*: over every set of m distinct poses of the motion, a proven lower",
        "  bound (linear programming duality) and the floor of the best set found; the best",
        "  possible set lies between the two.",
        "",
        _row("gait", "keys", "ours, 2 PCs", "floor of our keys", "any m poses: proven >=",
             "any m poses: best found", "sets examined"),
        _row(*["---"] * 7),
    ]
    for (gait, m), f in floors.items():
        c = results[gait].cell(2, m)
        out.append(_row(gait, m, f"{c.mean_deg:.2f}", f"{c.floor_deg:.2f}",
                        f"{f.lower_deg:.2f}", f"{f.achieved_deg:.2f} (frames "
                        f"{', '.join(map(str, f.key_frames))})", f.n_sets))
    out += [
        "",
        "So no choice of 4 poses of this canter blends closer than "
        f"{floors['canter', 4].lower_deg:.2f} deg, nor of this gallop closer than "
        f"{floors['gallop', 4].lower_deg:.2f} deg:",
        "the target is below what the paper's method can reach on this motion, whatever its",
        "timing. The legs' joints sweep 60-110 deg per stride with sharp stance/swing",
        "transitions; the gaits were not smoothed to flatter the metric. Of our 4-key error,",
        "the part above the floor of the same keys is what timing (PCA + RBF) costs:",
        f"{results['canter'].cell(2, 4).mean_deg - results['canter'].cell(2, 4).floor_deg:.2f}"
        " deg on the canter, "
        f"{results['gallop'].cell(2, 4).mean_deg - results['gallop'].cell(2, 4).floor_deg:.2f}"
        " deg on the gallop.",
        "",
        "Are the joint ranges real? They come from the inverse kinematics of the hoof paths.",
        "The one measured set we could compare with is a walk (flat-walking yearlings, 2-D",
        "markers: \"Two-dimensional kinematics of the flat-walking Tennessee Walking Horse",
        "yearling\"); ours are of the same order, some larger, some smaller. We found no measured",
        "canter or gallop ranges to compare with. Scaling every angle by s scales the floor by s,",
        "so reaching 2.0 deg on the canter would need its angles scaled by at most "
        f"{2.0 / floors['canter', 4].lower_deg:.2f}"
        " (proven) and",
        f"probably by about {2.0 / floors['canter', 4].achieved_deg:.2f} (best set found).",
        "",
        _row("walk, range of motion (deg)", "ours", "measured (mean +- sd)"),
        _row("---", "---", "---"),
    ]
    walk = generate_gait(load_template("horse"), "walk", 200)
    channels = load_template("horse").channel_names
    for joint, measured in MEASURED_WALK_ROM.items():
        ours = np.ptp(walk[:, channels.index(f"L_{joint}.rz")])
        out.append(_row(joint.replace("_", " "), f"{ours:.0f}", measured))
    return out


def _grids(results) -> list[str]:
    """The error grid per gait (the paper's Figure 6) and the variance shares."""
    out: list[str] = []
    out += ["", "## Error grid (mean deg), keys x PCs, as the paper's Figure 6", ""]
    for gait, ev in results.items():
        pcs = sorted({c.pcs for c in ev.grid})
        out += [f"### {gait}", "", f"![{gait} PC1 x PC2](figures/{gait}_pc1_pc2.png) "
                f"![{gait} error](figures/{gait}_error.png)", "",
                _row("keys", *[f"{p} PCs" for p in pcs]), _row(*["---"] * (len(pcs) + 1))]
        for m in sorted({c.keys for c in ev.grid}):
            out.append(_row(m, *[f"{ev.cell(p, m).mean_deg:.2f}" for p in pcs]))
            if any(c.switching and c.keys == m for c in ev.grid):
                out.append(_row(f"{m}+{m} switching",
                                *[f"{ev.cell(p, m, switching=True).mean_deg:.2f}" for p in pcs]))
        out.append("")
    out += ["## Variance share of PC1..PC4 (%)", "", _row("gait", "ours", "paper"),
            _row("---", "---", "---")]
    for gait, ev in results.items():
        ours = " / ".join(f"{100 * v:.1f}" for v in ev.variance_ratio[:4])
        paper = " / ".join(str(v) for v in PAPER_VARIANCE.get(gait, ())) or "-"
        out.append(_row(gait, ours, paper))
    return out


def _spectra(results) -> list[str]:
    """The spectral diagnosis per gait, and how much of each PC is at the gait frequency."""
    out: list[str] = []
    out += ["", "## Spectral diagnosis r per PC (paper Section 5.2)", "",
            _row("gait", "ours r1..r5", "paper r1..r5", "period (frames)", "r1, r2 >= 0.6",
                 "r3..r5 <= 0.3"),
            _row(*["---"] * 6)]
    for gait, ev in results.items():
        r = ev.correlations
        out.append(_row(gait, " ".join(f"{v:.2f}" for v in r),
                        " ".join(str(v) for v in PAPER_R.get(gait, ())) or "-",
                        f"{ev.period_frames:.1f}",
                        "yes" if min(r[:2]) >= 0.6 else "no",
                        "yes" if np.all(r[2:5] <= 0.3) else f"no (max {r[2:5].max():.2f})"))
    f0_share = {gait: fundamental_share(ev) for gait, ev in results.items()}
    band_share = {}
    for gait, ev in results.items():
        d = ev.analyses[min(ev.analyses)].diagnosis
        band_share[gait] = (min(d.band[1], 0.5) - d.band[0]) / 0.5
    noise_r = np.sqrt(np.mean(list(band_share.values())))
    out += ["", "Share of each PC's variance carried by the gait frequency f0 (a sinusoid at f0",
            "fitted by least squares), and the band's share of the spectrum: broadband noise",
            "reaches r of about the square root of that share, so on 100 frames a PC with no",
            f"periodic content at all scores about {noise_r:.2f} (the paper's threshold is 0.3).",
            "", _row("gait", "f0 share of PC1..PC5", "band share", "noise r ~ sqrt(share)"),
            _row(*["---"] * 4)]
    for gait in results:
        out.append(_row(gait, " ".join(f"{v:.3f}" for v in f0_share[gait][:5]),
                        f"{band_share[gait]:.3f}", f"{np.sqrt(band_share[gait]):.2f}"))
    gallop = f0_share["gallop"]
    out += ["", f"The gallop's PC4 keeps {100 * gallop[3]:.0f} % of its variance at f0: "
            "most of the rest is at 2 f0. The",
            "gallop's silhouettes have a strong second harmonic, which PCA mixes into PC1 and",
            f"PC2 (their f0 shares are {gallop[0]:.2f} and {gallop[1]:.2f}), leaving some of the "
            "f0 variance to PC3",
            "and PC4. It is periodic motion, not noise; we report the miss rather than tune the",
            "band or the crop until it passes."]
    return out


def _roi(results, paper_roi) -> list[str]:
    """The paper's per-frame centre of mass against our period-locked window."""
    out = ["", "## Region of interest: the paper's per-frame centre of mass vs. ours", "",
            "The paper centres the window on each frame's centre of mass, which swings with",
            "the legs; we centre it on the track averaged over one gait period (found by a first",
            "diagnosis), which cancels the per-stride wobble and keeps the body's bounce in the",
            "images (`gaitcore analyze --paper-roi` restores the paper's way). 2 PCs; walk and",
            "trot with switching models; mean error in degrees.", "",
            _row("gait", "ROI", "4 keys", "5 keys", "6 keys", "r1..r5"), _row(*["---"] * 6)]
    for gait in GAITS:
        for name, ev in (("paper", paper_roi[gait]), ("period-locked", results[gait])):
            sw = gait in ("walk", "trot")
            out.append(_row(gait, name, *[f"{ev.cell(2, m, switching=sw).mean_deg:.2f}"
                                          for m in (4, 5, 6)],
                            " ".join(f"{v:.2f}" for v in ev.correlations)))
    return out


def _robustness(robust_ev) -> list[str]:
    """The canter seen off the side view and with noisy masks."""
    out: list[str] = []
    out += ["", "## Robustness (canter, 4 keys, 2 PCs; reported, not required)", "",
            _row("condition", "mean (deg)", "std (deg)", "r1..r5"), _row(*["---"] * 4)]
    for name, ev in robust_ev.items():
        c = ev.cell(2, 4)
        out.append(_row(name, f"{c.mean_deg:.2f}", f"{c.std_deg:.2f}",
                        " ".join(f"{v:.2f}" for v in ev.correlations)))
    return out


if __name__ == "__main__":
    main()
