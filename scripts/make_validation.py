"""Regenerate docs/validation.md and its figures: the paper's Section 4 on our synthetic bench.

    .venv/bin/python scripts/make_validation.py      (about two minutes on 2 cores)

Every figure in the document comes from ``gaitcore.evaluate`` run here; nothing is typed in.
"""

from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import numpy as np  # noqa: E402

from gaitcore.evaluate import BenchSettings, evaluate_gait  # noqa: E402
from gaitcore.plots import plot_error_curves, plot_trajectory  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FIGS = DOCS / "figures"
GAITS = ("walk", "trot", "canter", "gallop")
PAPER_VARIANCE = {
    "walk": (33.7, 23.7, 11.4, 8.56),
    "canter": (32.5, 14.5, 9.17, 8.78),
    "gallop": (31.1, 19.9, 11.0, 8.33),
}
PAPER_R = {"walk": (.99, .94, "<.01", .05, "<.01"), "canter": (.94, .89, .08, "<.01", .01),
           "gallop": (.90, .92, .01, "<.01", "<.01")}


def oracle_error(gait: str, n_keys: int) -> float:
    """Error floor of any method that only interpolates n_keys poses of the cycle: the keys
    are spread evenly over one true cycle and every frame is interpolated linearly in its
    true phase (no silhouette, no PCA: the best possible timing)."""
    from gaitcore.evaluate import angle_error_deg
    from gaitcore.skeleton import load_template
    from gaitcore.synth.gaits import GAITS, generate_gait

    skel = load_template("horse")
    period = GAITS[gait].period_frames
    truth = generate_gait(skel, gait, 100)
    idx = skel.sagittal_angle_indices
    key_phase = np.arange(n_keys) / n_keys
    key_poses = np.stack([generate_gait(skel, gait, 1, phase=float(ph))[0] for ph in key_phase])
    phase = (np.arange(100) / period) % 1.0
    pred = np.column_stack([
        np.interp(phase, np.r_[key_phase, 1.0], np.r_[key_poses[:, j], key_poses[0, j]])
        for j in idx
    ])
    return float(angle_error_deg(pred, truth[:, idx]).mean())


def _row(*cells) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def main() -> None:
    FIGS.mkdir(parents=True, exist_ok=True)
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
        _row("gait", "4 keys, 2 PCs (deg)", "best of grid (deg)", "switching 4+4 (deg)", "acceptance"),
        _row("---", "---", "---", "---", "---"),
    ]
    for gait, ev in results.items():
        c = ev.cell(2, 4)
        best = min((x for x in ev.grid if not x.switching), key=lambda x: x.mean_deg)
        sw = ev.cell(2, 4, switching=True) if gait in ("walk", "trot") else None
        if gait in ("canter", "gallop"):
            target = "<= 2.0: " + ("met" if c.mean_deg <= 2.0 else f"missed by {c.mean_deg - 2.0:.1f}")
        elif gait == "walk":
            ok = sw.mean_deg <= 3.0 and sw.mean_deg <= 0.5 * c.mean_deg
            target = f"switching <= 3.0 and <= half of {c.mean_deg:.2f}: " + ("met" if ok else "missed")
        else:
            target = "(none)"
        out.append(_row(gait, f"{c.mean_deg:.2f} ({c.std_deg:.2f})",
                        f"{best.mean_deg:.2f} ({best.pcs} PCs, {best.keys} keys)",
                        f"{sw.mean_deg:.2f} ({sw.std_deg:.2f})" if sw else "-", target))
    out += [
        "",
        "Why the 2.0 deg target for canter and gallop is missed: on this motion it is below what",
        "interpolating 4 poses reaches even with perfect timing. Given the true phase of every frame",
        "(perfect timing, which PCA only approximates) and 4 keys spread evenly over the cycle,",
        "linear interpolation in phase gives the floors below; the legs' joints sweep 60-110 deg",
        "per stride with sharp stance/swing transitions that 4 samples cannot describe.",
        "",
        _row("gait", "floor, 4 keys", "floor, 6 keys", "floor, 8 keys", "ours, 4 keys 2 PCs"),
        _row(*["---"] * 5),
    ]
    for gait in ("canter", "gallop"):
        out.append(_row(gait, *[f"{oracle_error(gait, k):.2f}" for k in (4, 6, 8)],
                        f"{results[gait].cell(2, 4).mean_deg:.2f}"))
    out += ["", "## Error grid (mean deg), keys x PCs, as the paper's Figure 6", ""]
    for gait, ev in results.items():
        pcs = sorted({c.pcs for c in ev.grid})
        out += [f"### {gait}", "", f"![{gait} PC1 x PC2](figures/{gait}_pc1_pc2.png) "
                f"![{gait} error](figures/{gait}_error.png)", "",
                _row("keys", *[f"{p} PCs" for p in pcs]), _row(*["---"] * (len(pcs) + 1))]
        for m in sorted({c.keys for c in ev.grid}):
            out.append(_row(m, *[f"{ev.cell(p, m).mean_deg:.2f}" for p in pcs]))
            if any(c.switching and c.keys == m for c in ev.grid):
                out.append(_row(f"{m}+{m} switching", *[f"{ev.cell(p, m, switching=True).mean_deg:.2f}" for p in pcs]))
        out.append("")
    out += ["## Variance share of PC1..PC4 (%)", "", _row("gait", "ours", "paper"), _row("---", "---", "---")]
    for gait, ev in results.items():
        ours = " / ".join(f"{100 * v:.1f}" for v in ev.variance_ratio[:4])
        paper = " / ".join(str(v) for v in PAPER_VARIANCE.get(gait, ())) or "-"
        out.append(_row(gait, ours, paper))
    out += ["", "## Spectral diagnosis r per PC (paper Section 5.2)", "",
            _row("gait", "ours r1..r5", "paper r1..r5", "period (frames)", "r1, r2 >= 0.6", "r3..r5 <= 0.3"),
            _row(*["---"] * 6)]
    for gait, ev in results.items():
        r = ev.correlations
        out.append(_row(gait, " ".join(f"{v:.2f}" for v in r),
                        " ".join(str(v) for v in PAPER_R.get(gait, ())) or "-",
                        f"{ev.period_frames:.1f}",
                        "yes" if min(r[:2]) >= 0.6 else "no",
                        "yes" if np.all(r[2:5] <= 0.3) else f"no (max {r[2:5].max():.2f})"))
    out += ["", "## Region of interest: the paper's per-frame centre of mass vs. ours", "",
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
    out += ["", "## Robustness (canter, 4 keys, 2 PCs; reported, not required)", "",
            _row("condition", "mean (deg)", "std (deg)", "r1..r5"), _row(*["---"] * 4)]
    for name, ev in robust_ev.items():
        c = ev.cell(2, 4)
        out.append(_row(name, f"{c.mean_deg:.2f}", f"{c.std_deg:.2f}",
                        " ".join(f"{v:.2f}" for v in ev.correlations)))
    out.append("")
    (DOCS / "validation.md").write_text("\n".join(out) + "\n", encoding="utf-8")
    print("\n".join(out))


if __name__ == "__main__":
    main()
