"""Figures of the validation report, drawn like the paper's Figures 3 and 6.

Matplotlib is an optional dependency (the ``docs`` extra): only ``gaitcore evaluate --plots``
and the documentation need it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gaitcore.bench.evaluate import Evaluation
from gaitcore.errors import GaitInputError


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise GaitInputError(
            "plots need matplotlib: pip install 'gaitstudio[docs]' (or drop --plots)"
        ) from None
    return plt


def plot_trajectory(evaluation: Evaluation, path: str | Path, *, pcs: int = 2,
                    keys: int = 4) -> None:
    """PC1 x PC2 over time with the selected key-images circled (paper Figure 3)."""
    plt = _pyplot()
    a = evaluation.analyses[(pcs, keys)]
    p = evaluation.projections
    fig, ax = plt.subplots(figsize=(4.5, 4.5), dpi=110)
    ax.plot(p[:, 0], p[:, 1], "-", color="0.75", lw=1, zorder=1)
    sc = ax.scatter(p[:, 0], p[:, 1], c=np.arange(len(p)), cmap="viridis", s=14, zorder=2)
    k = list(a.key_frames)
    ax.scatter(p[k, 0], p[k, 1], s=160, facecolors="none", edgecolors="crimson", lw=2, zorder=3,
               label=f"{keys} keys (cond {a.selection.condition_number:.3g})")
    for f in k:
        ax.annotate(str(f), p[f, :2], xytext=(6, 6), textcoords="offset points", color="crimson")
    if a.alternate_frames:
        alt = list(a.alternate_frames)
        ax.scatter(p[alt, 0], p[alt, 1], s=120, marker="s", facecolors="none",
                   edgecolors="darkorange", lw=2, zorder=3, label="alternates")
    fig.colorbar(sc, ax=ax, label="frame", shrink=0.8)
    ax.set_xlabel("PC1")
    ax.set_ylabel("PC2")
    ax.set_title(f"{evaluation.settings.gait}: PC1 x PC2")
    ax.legend(loc="lower right", fontsize=8)
    ax.set_aspect("equal", adjustable="datalim")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_error_curves(evaluation: Evaluation, path: str | Path) -> None:
    """Mean joint-angle error against the number of PCs, one curve per number of keys
    (paper Figure 6)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(5, 3.6), dpi=110)
    for switching in (False, True):
        cells = [c for c in evaluation.grid if c.switching == switching]
        for m in sorted({c.keys for c in cells}):
            row = sorted((c for c in cells if c.keys == m), key=lambda c: c.pcs)
            label = f"{m} keys" + (f" + {m} alternates" if switching else "")
            ax.plot([c.pcs for c in row], [c.mean_deg for c in row], "--" if switching else "-o",
                    label=label, ms=4)
    ax.set_xlabel("principal components")
    ax.set_ylabel("mean |error| (deg)")
    ax.set_title(f"{evaluation.settings.gait}: error over {evaluation.n_angles} angles")
    ax.set_xticks(sorted({c.pcs for c in evaluation.grid}))
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
