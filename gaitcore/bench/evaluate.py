"""The paper's Section 4 experiment: how close is the predicted motion to the true one?

A synthetic horse is rendered from the side, its silhouettes go through the real pipeline
(ROI -> PCA -> key selection), the keys are posed with the true poses, and the RBF
prediction is compared with the truth over every frame and every joint angle about the axis
perpendicular to the image plane.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gaitcore.analysis.analyze import Analysis, AnalysisSettings, analyze_silhouettes, rekey
from gaitcore.animation.animate import animate
from gaitcore.bench.blend_floor import blend_floor
from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template
from gaitcore.silhouettes.tracking import crop_rois


@dataclass(frozen=True)
class BenchSettings:
    """How the synthetic clip is made.

    Attributes
    ----------
    gait : str
        walk, trot, canter or gallop.
    n_frames : int
        Clip length (the paper uses 100).
    width, height : int
        Render size (the paper uses 320 x 240).
    yaw_deg, elevation_deg : float
        Camera offsets from the pure side view (robustness figures).
    mask_noise : float
        Fraction of mask pixels flipped at random after rendering (robustness figures).
    period_frames : float or None
        Gait cycle length; the generator's default when None.
    seed : int
        Seed of the mask noise.
    """

    gait: str = "canter"
    n_frames: int = 100
    width: int = 320
    height: int = 240
    yaw_deg: float = 0.0
    elevation_deg: float = 0.0
    mask_noise: float = 0.0
    period_frames: float | None = None
    seed: int = 0


@dataclass(frozen=True)
class GridCell:
    """Error of one (pcs, keys) configuration, degrees.

    ``floor_deg`` is the least error any blend of the same key poses reaches
    (:func:`gaitcore.bench.blend_floor.blend_floor`); None for switching models, whose frames
    blend different sets.
    """

    pcs: int
    keys: int
    mean_deg: float
    std_deg: float
    key_frames: tuple[int, ...]
    switching: bool = False
    alternate_frames: tuple[int, ...] = ()
    floor_deg: float | None = None


@dataclass(frozen=True, eq=False)
class Evaluation:
    """Result of :func:`evaluate_gait`."""

    settings: BenchSettings
    grid: tuple[GridCell, ...]
    variance_ratio: np.ndarray
    correlations: np.ndarray
    period_frames: float
    projections: np.ndarray
    n_angles: int
    analyses: dict[tuple[int, int], Analysis] = field(repr=False)

    def cell(self, pcs: int, keys: int, *, switching: bool = False) -> GridCell:
        for c in self.grid:
            if (c.pcs, c.keys, c.switching) == (pcs, keys, switching):
                return c
        raise KeyError((pcs, keys, switching))

    def to_dict(self) -> dict:
        """JSON-ready summary (the ``gaitcore evaluate --json`` output)."""
        return {
            "gait": self.settings.gait,
            "n_frames": self.settings.n_frames,
            "n_angles": self.n_angles,
            "yaw_deg": self.settings.yaw_deg,
            "mask_noise": self.settings.mask_noise,
            "grid": [
                {
                    "pcs": c.pcs,
                    "keys": c.keys,
                    "switching": c.switching,
                    "mean_deg": round(c.mean_deg, 4),
                    "std_deg": round(c.std_deg, 4),
                    "key_frames": list(c.key_frames),
                    **({"alternate_frames": list(c.alternate_frames)} if c.switching
                       else {"floor_deg": round(c.floor_deg, 4)}),
                }
                for c in self.grid
            ],
            "variance_ratio": [round(float(v), 5) for v in self.variance_ratio],
            "correlations": [round(float(r), 4) for r in self.correlations],
            "period_frames": round(self.period_frames, 3),
        }


def render_bench_clip(
    settings: BenchSettings, *, skeleton: Skeleton | None = None, progress: Progress | None = None
) -> tuple[Skeleton, np.ndarray, np.ndarray]:
    """Generate and render the synthetic clip.

    Returns
    -------
    skeleton : Skeleton
    poses : ndarray of shape (n, k)
        True pose of every frame.
    masks : ndarray of shape (n, height, width), bool
        Rendered silhouettes, with ``mask_noise`` applied.
    """
    from gaitcore.bench.gaits import generate_gait
    from gaitcore.rig.render import render_clip

    if not 0.0 <= settings.mask_noise < 0.5:
        raise GaitInputError(f"mask noise must be in [0, 0.5), got {settings.mask_noise}")
    skeleton = skeleton or load_template("horse")
    poses = generate_gait(skeleton, settings.gait, settings.n_frames,
                          period_frames=settings.period_frames)
    _, masks = render_clip(skeleton, poses, width=settings.width, height=settings.height,
                           yaw_deg=settings.yaw_deg, elevation_deg=settings.elevation_deg,
                           progress=progress)
    if settings.mask_noise > 0:
        rng = np.random.default_rng(settings.seed)
        masks ^= rng.random(masks.shape) < settings.mask_noise
    return skeleton, poses, masks


def angle_error_deg(predicted: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Absolute angle differences, wrapped to [0, 180] degrees."""
    return np.abs((np.asarray(predicted) - np.asarray(truth) + 180.0) % 360.0 - 180.0)


def evaluate_gait(
    settings: BenchSettings = BenchSettings(),
    *,
    pcs: Sequence[int] = (1, 2, 3, 4, 5),
    keys: Sequence[int] = (2, 3, 4, 5),
    switching: bool = False,
    stabilize_roi: bool = True,
    progress: Progress | None = None,
) -> Evaluation:
    """Run the Section 4 experiment on one synthetic gait.

    Parameters
    ----------
    settings : BenchSettings
    pcs, keys : sequence of int
        Numbers of principal components and of key-images to try (the grid).
    switching : bool
        Also evaluate switching models (keys + as many alternates) for every cell (paper
        Section 3.2; meant for walks).
    stabilize_roi : bool
        Centre the crops on the period-averaged track (False: on each frame's centre of
        mass, as the paper does).
    progress : callable(done, total) -> bool, optional
        Reports the rendering.

    Returns
    -------
    Evaluation

    Notes
    -----
    Paper Section 4 and Figure 6. The error is the mean (and standard deviation) of the
    absolute difference between true and predicted angles, over every frame and every
    rotation about Z, the axis perpendicular to the image plane. Each cell also carries the
    floor of its key poses: the part of the error no timing could remove.
    """
    if not pcs or not keys or min(pcs) < 1 or min(keys) < 1:
        raise GaitInputError("--pcs and --keys need positive numbers")
    skeleton, truth, masks = render_bench_clip(settings, progress=progress)
    idx = skeleton.sagittal_angle_indices
    base = analyze_silhouettes(
        crop_rois(masks), AnalysisSettings(pcs=1, keys=min(keys), stabilize_roi=stabilize_roi)
    )
    grid: list[GridCell] = []
    analyses: dict[tuple[int, int], Analysis] = {}
    floors: dict[tuple[int, ...], float] = {}
    for c in pcs:
        for m in keys:
            a = rekey(base, AnalysisSettings(pcs=c, keys=m, switching=switching,
                                             stabilize_roi=stabilize_roi))
            analyses[(c, m)] = a
            posed = {f: truth[f] for f in a.posed_frames}
            pred = animate(a.coords, a.key_frames, posed)
            err = angle_error_deg(pred[:, idx], truth[:, idx])
            if a.key_frames not in floors:
                floors[a.key_frames] = blend_floor(truth[:, idx], a.key_frames)
            grid.append(GridCell(c, m, float(err.mean()), float(err.std()), a.key_frames,
                                 floor_deg=floors[a.key_frames]))
            if a.alternate_frames is not None:
                pred = animate(a.coords, a.key_frames, posed,
                               alternate_frames=a.alternate_frames, theta=a.loop_angle)
                err = angle_error_deg(pred[:, idx], truth[:, idx])
                grid.append(GridCell(c, m, float(err.mean()), float(err.std()), a.key_frames,
                                     True, a.alternate_frames))
    return Evaluation(
        settings=settings,
        grid=tuple(grid),
        variance_ratio=base.pca.variance_ratio,
        correlations=base.diagnosis.correlations,
        period_frames=base.diagnosis.period_frames,
        projections=base.projections,
        n_angles=len(idx),
        analyses=analyses,
    )
