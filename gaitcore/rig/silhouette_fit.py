"""The rig's proportions from a side-view silhouette: analysis by synthesis.

The posed rig, drawn as its bone ellipsoids seen from the side (orthographic, as the
synthetic renders of :mod:`gaitcore.rig.render`), is laid over a binary silhouette and its
part scales, size and place are changed until the two overlap best. The overall size is the
footage's scale (metres per pixel), so the body is the reference part and the others are
fitted relative to it: legs, neck, head, tail. From the fitted rig come the measures an
artist checks by eye: body length, height at the withers, leg length.

Each ellipsoid projects to an ellipse (its semi-axes' X, Y rows); the ellipses are filled
with anti-aliased edges into one coverage image, and the loss is one minus the soft overlap
(intersection over union of coverages), minimised by Powell's method from a start that
matches the silhouette's height and centre.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import minimize

from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report
from gaitcore.rig.proportions import RigProportions, body_parts
from gaitcore.rig.skeleton import BONE_END_ROUNDING, BONE_LENGTH_SCALE, Skeleton

FITTED_PARTS = ("legs", "neck", "head", "tail")
ELLIPSE_POINTS = 24
SUBPIXEL_BITS = 4
MIN_SILHOUETTE_PX = 50
PROBE_M_PER_PX = 0.01
POWELL_RESTARTS = 1
FIT_RANGE = (0.5, 2.0)
"""Part scales the automatic fit may reach (the artist may set any in SCALE_RANGE)."""
PRIOR_WEIGHT = 0.05
"""Weight of the pull of each part scale towards the start, in loss per (log scale)^2: a
15% change costs 0.1% of overlap, a halving 2.4%, so that a silhouette that does not look like
the posed rig (wrong pose, rider, occlusion) cannot stretch a part to a limit."""
POWELL_PASSES = 20
"""Passes over the parameters per Powell run (each pass is a line search per parameter)."""
PROBE_MARGIN_M = 0.4
POOR_OVERLAP = 0.45
"""Below this intersection over union the fit is reported as poor (a rider or a saddle
cloth, outside any rig, keeps a good fit of a ridden horse above it)."""
BOX_TOLERANCE = 0.15
"""The fitted rig's side view may be off the silhouette's middle (across) or bottom (up), or
differ from its length, by this share of the silhouette's box (its top and height are not
compared: a rider adds to them)."""
LEG_SHARE = (0.4, 0.7)
"""The legs' free length over the withers' height of a plausible quadruped."""


@dataclass(frozen=True)
class ProportionsFit:
    """The rig fitted to a silhouette.

    Attributes
    ----------
    proportions : RigProportions
        Part scales; ``body`` is the start's (the reference).
    metres_per_px : float
        Size of a silhouette pixel in the rig's metres.
    origin_px : tuple of 2 float
        Image position (x right, y down, pixels) of the world origin of the posed rig.
    overlap : float
        Intersection over union of the fitted rig's side view and the silhouette, in [0, 1].
    body_length_m, withers_height_m, leg_length_m : float
        Measures of the fitted rig at rest: trunk length (pelvis to the base of the neck),
        height of the highest joint of the trunk or the shoulder blades above the lowest foot,
        and the legs' free length, from the underside of the trunk (the belly, as drawn) to
        the ground, metres.
    rig_box, silhouette_box : tuple of 4 float
        ``(x, y, width, height)`` in the mask's pixels of the fitted rig's side view (what of
        it lies inside the mask's frame and beyond) and of the silhouette.
    """

    proportions: RigProportions
    metres_per_px: float
    origin_px: tuple[float, float]
    overlap: float
    body_length_m: float
    withers_height_m: float
    leg_length_m: float
    rig_box: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    silhouette_box: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    def problems(self) -> tuple[str, ...]:
        """Why the fit cannot be trusted, one phrase each (empty: it can): an overlap under
        :data:`POOR_OVERLAP`, a rig whose side view is off the silhouette's place or length
        by more than :data:`BOX_TOLERANCE` of it, legs outside :data:`LEG_SHARE` of the
        withers' height."""
        out = []
        if self.overlap < POOR_OVERLAP:
            out.append(f"the rig covers only {100 * self.overlap:.0f}% of the silhouette")
        (rx, ry, rw, rh), (sx, sy, sw, sh) = self.rig_box, self.silhouette_box
        off_x = abs((rx + rw / 2) - (sx + sw / 2)) / max(sw, 1.0)
        off_y = abs((ry + rh) - (sy + sh)) / max(sh, 1.0)  # the feet on the silhouette's
        if max(off_x, off_y) > BOX_TOLERANCE:
            out.append("the rig sits off the silhouette")
        if abs(rw / max(sw, 1.0) - 1.0) > BOX_TOLERANCE:
            out.append(f"the rig is {rw / max(sw, 1.0):.0%} of the silhouette's length")
        share = self.leg_length_m / max(self.withers_height_m, 1e-9)
        if not LEG_SHARE[0] <= share <= LEG_SHARE[1]:
            out.append(f"legs of {share:.0%} of the withers' height")
        return tuple(out)


class _SideView:
    """Side views of one skeleton in one pose for any part scales (rotations are fixed)."""

    def __init__(self, skeleton: Skeleton, pose: np.ndarray) -> None:
        self.skeleton = skeleton
        world = skeleton.forward_kinematics(pose)
        self.rot = world[:, :3, :3]
        self.root = world[0, :3, 3]
        self.parts = np.array(body_parts(skeleton))
        bones = skeleton.bone_ellipsoids()
        self.joint = np.array([b.joint for b in bones], int)
        self.child = np.array([b.child for b in bones], int)
        self.length = np.linalg.norm(skeleton.offsets[self.child], axis=1)
        self.radii = np.array([b.radii for b in bones]).reshape(-1, 3)
        self.round = BONE_END_ROUNDING * self.radii[:, 1:].min(axis=1)
        self.axes = np.array([b.axes for b in bones]).reshape(-1, 3, 3)
        t = np.linspace(0, 2 * np.pi, ELLIPSE_POINTS, endpoint=False)
        self.circle = np.stack([np.cos(t), np.sin(t)])

    def positions(self, scales: np.ndarray) -> np.ndarray:
        """World joint positions (J, 3) with each joint's offset scaled by ``scales`` (J,)."""
        pos = np.empty((self.skeleton.n_joints, 3))
        pos[0] = self.root
        for j in range(1, len(pos)):
            p = self.skeleton.parents[j]
            pos[j] = pos[p] + self.rot[p] @ (self.skeleton.offsets[j] * scales[j])
        return pos

    def coverage(self, scales: np.ndarray, metres_per_px: float, origin_px: np.ndarray,
                 shape_rc: tuple[int, int]) -> np.ndarray:
        """Anti-aliased coverage in [0, 1] of the rig's side view, shape ``shape_rc``."""
        pos = self.positions(scales)
        length = self.length * scales[self.child]
        radii = self.radii.copy()
        radii[:, 0] = 0.5 * length * BONE_LENGTH_SCALE + self.round
        rot = self.rot[self.joint]
        semi = rot @ (self.axes * radii[:, None, :])  # (B, 3, 3), semi-axes as columns
        centre = (pos[self.joint]
                  + np.einsum("bij,bj->bi", rot, self.axes[:, :, 0]) * length[:, None] / 2)
        u, s, _ = np.linalg.svd(semi[:, :2])  # the projected ellipses' axes and half-lengths
        xy = centre[:, :2, None] + u @ (s[:, :, None] * self.circle)  # (B, 2, n)
        px = np.stack([origin_px[0] + xy[:, 0] / metres_per_px,
                       origin_px[1] - xy[:, 1] / metres_per_px], axis=-1)
        fixed = np.round(px * (1 << SUBPIXEL_BITS)).astype(np.int32)
        image = np.zeros(shape_rc, np.uint8)
        for polygon in fixed:
            cv2.fillConvexPoly(image, polygon, 255, cv2.LINE_AA, SUBPIXEL_BITS)
        return image.astype(np.float32) / 255


def fit_proportions(mask: np.ndarray, skeleton: Skeleton, pose: np.ndarray, *,
                    start: RigProportions = RigProportions(),
                    parts: Sequence[str] = FITTED_PARTS,
                    progress: Progress | None = None) -> ProportionsFit:
    """Fit the part scales, size and place of the posed rig to a side-view silhouette.

    Parameters
    ----------
    mask : ndarray of shape (rows, cols), bool
        The silhouette (the key-image's ROI crop), the animal facing +x (right).
    skeleton : Skeleton
        The rig in its template proportions.
    pose : ndarray of shape (k,)
        The rig's pose on that frame (the key's pose, or the rest pose).
    start : RigProportions
        Where the search starts; its ``body`` is kept (the reference).
    parts : sequence of str
        The parts fitted, from :data:`FITTED_PARTS`.
    progress : callable(done, total) -> bool, optional
        Called after each pass over the parameters; False cancels.

    Returns
    -------
    ProportionsFit

    Raises
    ------
    GaitInputError
        An empty or tiny silhouette, or an unknown part.
    Cancelled
        When ``progress`` returned False.
    """
    m = np.asarray(mask, bool)
    if m.ndim != 2 or m.sum() < MIN_SILHOUETTE_PX:
        raise GaitInputError("the silhouette of this frame is empty or tiny: segment or sketch "
                             "it before fitting the rig")
    unknown = set(parts) - set(FITTED_PARTS)
    if unknown:
        raise GaitInputError(f"cannot fit {sorted(unknown)}; fit some of {list(FITTED_PARTS)}")
    view = _SideView(skeleton, pose)
    target = m.astype(np.float32)
    part_of = view.parts

    def unpack(x: np.ndarray) -> tuple[RigProportions, np.ndarray, float, np.ndarray]:
        values = {p: start.scale_of(p) for p in ("legs", "neck", "body", "head", "tail")}
        for p, v in zip(parts, np.exp(x[3:])):
            values[p] = float(np.clip(v, *FIT_RANGE))
        props = RigProportions(**values)
        scales = np.array([props.scale_of(p) for p in part_of])
        return props, scales, float(np.exp(x[0])), x[1:3]

    def loss(x: np.ndarray) -> float:
        _, scales, mpp, origin = unpack(x)
        cover = view.coverage(scales, mpp, origin, m.shape)
        overlap = float(np.minimum(cover, target).sum()
                        / max(np.maximum(cover, target).sum(), 1e-9))
        pull = PRIOR_WEIGHT * float(np.sum((x[3:] - prior) ** 2))
        return 1.0 - overlap + pull

    x0 = _start(view, m, start, part_of, parts)
    prior = x0[3:].copy()
    result = _minimise(loss, x0, progress)
    props, scales, mpp, origin = unpack(result.x)
    cover = view.coverage(scales, mpp, origin, m.shape)
    overlap = float(np.minimum(cover, target).sum() / max(np.maximum(cover, target).sum(), 1e-9))
    return ProportionsFit(props, mpp, (float(origin[0]), float(origin[1])), overlap,
                          *rig_measures(skeleton, props),
                          rig_box=_rig_box(view, scales, mpp, origin),
                          silhouette_box=_box(m))


def _minimise(loss, x0: np.ndarray, progress: Progress | None):
    """Powell's method, restarted (it stalls along its first directions), with progress."""
    passes = [0]
    total = (POWELL_RESTARTS + 1) * POWELL_PASSES

    def step(_x: np.ndarray) -> None:
        passes[0] += 1
        report(progress, min(passes[0], total), total, "rig fit cancelled")

    for _ in range(POWELL_RESTARTS + 1):
        result = minimize(loss, x0, method="Powell", callback=step,
                          options={"xtol": 1e-3, "ftol": 1e-6, "maxiter": POWELL_PASSES})
        x0 = result.x
    return result


def _start(view: _SideView, mask: np.ndarray, start: RigProportions, part_of: np.ndarray,
           parts: Sequence[str]) -> np.ndarray:
    """Size from the heights and place from the centres of area of the rig's view and the
    mask: the rig is drawn once at PROBE_M_PER_PX on a canvas that holds all of it."""
    scales = np.array([start.scale_of(p) for p in part_of])
    pos = view.positions(scales)[:, :2]
    lo, hi = pos.min(axis=0) - PROBE_MARGIN_M, pos.max(axis=0) + PROBE_MARGIN_M
    shape = tuple(int(v) for v in np.ceil((hi - lo)[::-1] / PROBE_M_PER_PX))
    probe = view.coverage(scales, PROBE_M_PER_PX, np.array([-lo[0], hi[1]]) / PROBE_M_PER_PX, shape)
    rows = np.nonzero(mask.any(axis=1))[0]
    probe_rows = np.nonzero(probe.any(axis=1))[0]
    mpp = PROBE_M_PER_PX * (np.ptp(probe_rows) + 1) / (np.ptp(rows) + 1)
    pr, pc = np.nonzero(probe > 0.5)
    centre_m = np.array([lo[0] + pc.mean() * PROBE_M_PER_PX, hi[1] - pr.mean() * PROBE_M_PER_PX])
    r, c = np.nonzero(mask)
    origin = np.array([c.mean() - centre_m[0] / mpp, r.mean() + centre_m[1] / mpp])
    return np.r_[np.log(mpp), origin, [np.log(start.scale_of(p)) for p in parts]]


def _box(mask: np.ndarray) -> tuple[float, float, float, float]:
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    return (float(cols[0]), float(rows[0]), float(cols[-1] - cols[0] + 1),
            float(rows[-1] - rows[0] + 1))


def _rig_box(view: _SideView, scales: np.ndarray, metres_per_px: float,
             origin: np.ndarray) -> tuple[float, float, float, float]:
    """The side-view box of the fitted rig in the mask's pixels, drawn on a canvas large
    enough to hold it wherever it lies."""
    pos = view.positions(scales)
    px = np.column_stack([origin[0] + pos[:, 0] / metres_per_px,
                          origin[1] - pos[:, 1] / metres_per_px])
    margin = PROBE_MARGIN_M / metres_per_px
    lo = np.floor(px.min(axis=0) - margin)
    shape = tuple(int(v) for v in np.ceil(px.max(axis=0) + margin - lo)[::-1])
    cover = view.coverage(scales, metres_per_px, origin - lo, shape) > 0.5
    if not cover.any():
        return (float(origin[0]), float(origin[1]), 0.0, 0.0)
    x, y, w, h = _box(cover)
    return (x + lo[0], y + lo[1], w, h)


def rig_measures(skeleton: Skeleton, proportions: RigProportions) -> tuple[float, float, float]:
    """Body length, height at the withers and the legs' free length (the underside of the
    trunk's ellipsoids above the lowest foot) of the proportioned rig at rest."""
    from gaitcore.rig.proportions import proportioned

    rig = proportioned(skeleton, proportions)
    world = rig.forward_kinematics(rig.rest_pose())
    pos = world[:, :3, 3]
    parts = np.array(body_parts(rig))
    trunk = [j for j, joint in enumerate(rig.joints) if joint.side == "C" and parts[j] == "body"]
    body_length = float(np.ptp(pos[trunk, 0])) if trunk else 0.0
    tops = [j for j, joint in enumerate(rig.joints) if parts[j] == "body"]  # trunk, shoulder blades
    ground = float(pos[:, 1].min())
    withers = float(pos[tops, 1].max() - ground)
    bellies = [float(centre[1] - half[1]) for centre, half in
               (b.world_box(world) for b in rig.bone_ellipsoids() if b.child in trunk)]
    legs = (min(bellies) if bellies else float(pos[trunk, 1].min()) if trunk else ground) - ground
    return body_length, withers, max(legs, 0.0)
