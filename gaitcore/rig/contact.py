"""Ground contact clean-up: feet planted through stance and never under the ground, by leg IK.

Interpolated legs float, sink and skate: a blend of key poses does not know where the ground
is. After interpolation, each foot (an end joint at the lowest height of the rest skeleton)
is followed along the ground as the animal travels. Where it is low (near the ground, or
near its own lowest over the clip: a foot that floats above the ground all along is in stance
in its lowest phase) and slow it is in stance: it is brought down and planted at one point of
the ground for the whole stance, blended in over a few frames before touch-down and out after
lift-off, and everywhere else it is only lifted out of the ground.
:func:`gaitcore.rig.ik.solve_chain` moves the leg onto each target within its joint limits,
changing its angles as little as it can, the foot keeping its orientation. Where a leg cannot
reach (a body that rides too high in stance, or too low for a leg that cannot fold out of
the ground), the body's height follows: on every frame with a foot in stance the lowest foot
is brought onto the ground, and on every frame no foot stays under it (the report's
``body_shift_m`` says by how much the body moved).

The motion is judged in the frame of the travelling animal: ``travel`` adds the distance
covered to every pose, so an in-place cycle is cleaned as the forward motion it stands for.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report
from gaitcore.rig.ik import leg_joints, solve_chain
from gaitcore.rig.skeleton import Skeleton
from gaitcore.runs import true_runs

FOOT_BAND = 0.05
"""End joints whose rest height is within this fraction of the skeleton's height from the
lowest point are feet."""

OWN_LOWEST = 5.0
"""A foot's own lowest height over the clip is this percentile of its heights (a spike of a
frame or two does not set it)."""


@dataclass(frozen=True)
class ContactSettings:
    """How stance is found and how far the clean-up reaches.

    Attributes
    ----------
    ground_y_m : float or None
        Height of the ground; None: the height of the feet in the rest pose.
    height_m : float
        A foot at most this high above the ground, or above its own lowest
        (:data:`OWN_LOWEST`), is low.
    speed_ratio : float
        A foot moving at most this multiple of the animal's speed over the ground (or
        ``min_speed_m`` per frame, whichever is larger), measured over ``speed_window``
        frames on each side, is slow.
    min_speed_m : float
        Metres per frame.
    speed_window : int
    blend_frames : int
        Frames over which a plant is blended in before touch-down and out after lift-off.
    min_stance_frames : int
        Shorter low-and-slow runs are not stances.
    max_gap_frames : int
        Stances separated by at most this many frames are one stance (interpolation jitter).

    Raises
    ------
    GaitInputError
        Negative thresholds or frame counts.
    """

    ground_y_m: float | None = None
    height_m: float = 0.04
    speed_ratio: float = 1.5
    min_speed_m: float = 0.01
    speed_window: int = 2
    blend_frames: int = 3
    min_stance_frames: int = 3
    max_gap_frames: int = 2

    def __post_init__(self) -> None:
        if min(self.height_m, self.speed_ratio, self.min_speed_m, self.speed_window,
               self.blend_frames, self.max_gap_frames) < 0 or self.min_stance_frames < 1:
            raise GaitInputError("ground contact thresholds must be zero or positive and a "
                                 "stance at least one frame long")


@dataclass(frozen=True)
class FootReport:
    """What the clean-up did to one foot.

    Attributes
    ----------
    name : str
    stance_frames : int
        Frames found in stance.
    moved_frames : int
        Frames where the foot was moved.
    max_shift_m, mean_shift_m : float
        Largest and mean distance the foot was moved over the moved frames, metres.
    lowest_before_m, lowest_after_m : float
        Lowest height of the foot above the ground before and after, metres.
    worst_miss_m : float
        Largest distance left between the foot and its target (limits, reach).
    """

    name: str
    stance_frames: int
    moved_frames: int
    max_shift_m: float
    mean_shift_m: float
    lowest_before_m: float
    lowest_after_m: float
    worst_miss_m: float


@dataclass(frozen=True, eq=False)
class ContactResult:
    """Cleaned poses, the stance of each foot and the report.

    Attributes
    ----------
    poses : ndarray of shape (n, k)
    stance : ndarray of bool, shape (n, F)
        Stance of each foot in ``feet`` order.
    feet : tuple of FootReport
    body_shift_m : float
        The largest change of the body's height that brought the lowest foot onto the
        ground, metres (0 where the legs reached).
    """

    poses: np.ndarray
    stance: np.ndarray
    feet: tuple[FootReport, ...]
    body_shift_m: float = 0.0

    def summary(self) -> str:
        """One line: how far the feet were moved, e.g. for a status bar."""
        if not self.feet:
            return "ground contact: no feet found"
        worst = max(self.feet, key=lambda f: f.max_shift_m)
        planted = [f for f in self.feet if f.stance_frames]
        never = [f.name for f in self.feet if not f.stance_frames]
        head = (f"{len(planted)} feet planted" if not never else
                f"{len(planted)} of {len(self.feet)} feet planted ({', '.join(never)} never "
                "in stance)")
        body = (f", body height changed by up to {100 * self.body_shift_m:.1f} cm"
                if self.body_shift_m >= 0.0005 else "")
        return (f"ground contact: {head}, moved up to {100 * worst.max_shift_m:.1f} cm "
                f"({worst.name}){body}")


def find_feet(skeleton: Skeleton) -> tuple[str, ...]:
    """End joints (no children) at the lowest height of the rest skeleton, file order."""
    rest = skeleton.joint_positions(skeleton.rest_pose())
    height = float(np.ptp(rest[:, 1])) or 1.0
    leaves = [j for j in range(skeleton.n_joints) if not np.any(skeleton.parents == j)
              and skeleton.parents[j] >= 0]
    low = rest[:, 1].min() + FOOT_BAND * height
    return tuple(skeleton.joints[j].name for j in leaves if rest[j, 1] <= low)


def clean_ground_contact(skeleton: Skeleton, poses: np.ndarray, *,
                         travel_m: np.ndarray | None = None, cyclic: bool = False,
                         anchors: Sequence[int] = (),
                         settings: ContactSettings = ContactSettings(),
                         progress: Progress | None = None) -> ContactResult:
    """Plant the feet through stance and keep them above the ground.

    Parameters
    ----------
    skeleton : Skeleton
    poses : ndarray of shape (n, k)
        Poses laid out as ``skeleton.channel_names``.
    travel_m : ndarray of shape (n, 3), optional
        World offset of each frame from the animal's travel (zero by default): an in-place
        cycle with ``v * frame`` here is cleaned as the forward motion.
    cyclic : bool
        The poses are one loop: stances run across the end into the start, and the result
        loops as the input did.
    anchors : sequence of int
        Rows whose poses the artist made (the posed key-images, where the interpolation is
        exact): a stance that holds one is planted where the foot is in it, not at the
        median of the interpolated foot.
    settings : ContactSettings
    progress : callable (done, total) -> bool, optional
        Per frame; returning False cancels with ``Cancelled``.

    Returns
    -------
    ContactResult

    Raises
    ------
    GaitInputError
        Poses that do not fit the skeleton.
    """
    p = np.array(poses, dtype=float)
    skeleton.forward_kinematics(p[:1])  # one clear message for a wrong width
    travel = np.zeros((len(p), 3)) if travel_m is None else np.asarray(travel_m, float)
    n = len(p)
    anchored = np.zeros(n, dtype=bool)
    anchored[[int(a) for a in anchors if 0 <= a < n]] = True
    if cyclic and n > 1:  # three copies, cleaned as one clip; the middle one is the loop
        step = (travel[-1] - travel[0]) * n / (n - 1)
        p = np.concatenate([p, p, p])
        travel = np.concatenate([travel - step, travel, travel + step])
        anchored = np.concatenate([anchored, anchored, anchored])
    feet = find_feet(skeleton)
    ground = _ground(skeleton, settings)
    index = [skeleton.joint_index(f) for f in feet]
    posed = skeleton.joint_positions(p)  # once: the feet, their legs' tops, their heels
    before = posed[:, index] + travel[:, None, :]
    speed = _ground_speed(travel)
    legs = [_leg(skeleton, f) for f in feet]
    tops = posed[:, [top for top, _ in legs]] + travel[:, None, :]
    tops[..., 1] = skeleton.joint_positions(skeleton.rest_pose())[[t for t, _ in legs], 1]
    stance = np.stack([_within_reach(before[:, i], stance_mask(
        before[:, i], ground, animal_speed_m=speed, settings=settings), anchored,
        tops[:, i], legs[i][1], ground, settings) for i in range(len(feet))], axis=1)
    heels = [_foot_joint(skeleton, f) for f in feet]
    heel_y = posed[:, [skeleton.joint_index(h or f) for h, f in zip(heels, feet)], 1]
    targets = np.stack([_targets(before[:, i], heel_y[:, i] - before[:, i, 1], stance[:, i],
                                 anchored, ground, settings.blend_frames)
                        for i in range(len(feet))], axis=1)
    rows = range(n, 2 * n) if cyclic and n > 1 else range(n)
    moved = np.linalg.norm(targets - before, axis=2) > 1e-6
    out = _solve_frames(skeleton, p, feet, targets - travel[:, None, :], moved, rows, progress)
    if cyclic and len(p) > n:
        out, before, targets, stance, travel = (a[n:2 * n] for a in
                                                (out, before, targets, stance, travel))
    out, body_shift = _feet_on_ground(skeleton, out, index, stance, ground)
    after = skeleton.joint_positions(out)[:, index] + travel[:, None, :]
    reports = tuple(_report(name, before[:, i], after[:, i], targets[:, i], stance[:, i],
                            ground) for i, name in enumerate(feet))
    return ContactResult(out, stance, reports, body_shift)


def _feet_on_ground(skeleton: Skeleton, poses: np.ndarray, feet: list[int], stance: np.ndarray,
                    ground: float) -> tuple[np.ndarray, float]:
    """The body raised or lowered so that the lowest foot stands on the ground on frames
    with a foot in stance, and raised out of it elsewhere (the root's height channel; left
    as it is without one). Returns the poses and the largest change, metres."""
    if "ty" not in skeleton.joints[0].channels or not feet:
        return poses, 0.0
    lowest = skeleton.joint_positions(poses)[:, feet, 1].min(axis=1)
    change = np.where(stance.any(axis=1), ground - lowest, np.maximum(ground - lowest, 0.0))
    out = poses.copy()
    out[:, skeleton.channel_index(f"{skeleton.joints[0].name}.ty")] += change
    return out, float(np.abs(change).max(initial=0.0))


def _solve_frames(skeleton: Skeleton, poses: np.ndarray, feet: tuple[str, ...],
                  targets: np.ndarray, moved: np.ndarray, rows: range,
                  progress: Progress | None) -> np.ndarray:
    """Poses with every foot that ``moved`` (n, F) in the frames ``rows`` put on its target
    (n, F, 3, in the poses' own frame: travel taken off)."""
    out = poses.copy()
    for done, t in enumerate(rows):
        report(progress, done, len(rows), f"ground contact cancelled at frame {done}")
        for i, foot in enumerate(feet):
            if moved[t, i]:
                out[t] = _reach(skeleton, out[t], foot, targets[t, i])
    return out


def stance_mask(foot_xyz: np.ndarray, ground_y_m: float, *, animal_speed_m: float,
                settings: ContactSettings = ContactSettings()) -> np.ndarray:
    """Frames where a foot is low (near the ground or near its own lowest) and slow, runs
    shorter than the minimum dropped.

    Parameters
    ----------
    foot_xyz : ndarray of shape (n, 3)
        World positions of the foot, travel included.
    ground_y_m : float
    animal_speed_m : float
        The animal's speed over the ground, metres per frame.
    settings : ContactSettings

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    x = np.asarray(foot_xyz, float)
    lowest = float(np.percentile(x[:, 1], OWN_LOWEST)) if len(x) else ground_y_m
    low = (x[:, 1] - ground_y_m <= settings.height_m) | (x[:, 1] - lowest <= settings.height_m)
    if len(x) < 2:
        return low
    w = max(1, settings.speed_window)
    ahead = np.minimum(np.arange(len(x)) + w, len(x) - 1)
    behind = np.maximum(np.arange(len(x)) - w, 0)
    speed = np.linalg.norm(x[ahead][:, [0, 2]] - x[behind][:, [0, 2]], axis=1) / (ahead - behind)
    slow = speed <= max(settings.speed_ratio * animal_speed_m, settings.min_speed_m)
    mask = slow & low
    # At the clip's ends, where speed is one-sided, low is enough.
    for start, stop in true_runs(~mask):
        inside = start > 0 and stop < len(mask)
        if stop - start <= settings.max_gap_frames and (inside or low[start:stop].all()):
            mask[start:stop] = True
    for start, stop in true_runs(mask):
        if stop - start < settings.min_stance_frames:
            mask[start:stop] = False
    return mask


def _spot(foot: np.ndarray, start: int, stop: int, anchored: np.ndarray) -> np.ndarray:
    """Where a stance from ``start`` to ``stop`` plants the foot along the ground (x, z):
    where the posed frames in it put the foot, else the median of the run."""
    trusted = start + np.flatnonzero(anchored[start:stop])
    where = foot[trusted] if trusted.size else foot[start:stop]
    return np.array([np.median(where[:, 0]), np.median(where[:, 2])])


def _leg(skeleton: Skeleton, foot: str) -> tuple[int, float]:
    """The top joint of ``foot``'s leg (which the leg's IK does not move) and the leg's
    length from it to the foot, metres."""
    top = leg_joints(skeleton, foot)[0]
    j, reach = skeleton.joint_index(foot), 0.0
    while j != top:
        reach += float(np.linalg.norm(skeleton.offsets[j]))
        j = int(skeleton.parents[j])
    return top, reach


def _within_reach(foot: np.ndarray, stance: np.ndarray, anchored: np.ndarray, top: np.ndarray,
                  reach: float, ground: float, settings: ContactSettings) -> np.ndarray:
    """``stance`` kept on the frames where the leg, from its ``top`` (world positions, travel
    included, at the height the rig stands it), can reach where its stance plants the foot
    (shorter runs than the minimum dropped): a long low run of a foot that moves on with the
    body is not held back by a leg stretched past its length (a body that only rides high
    is brought down instead)."""
    out = stance.copy()
    for start, stop in true_runs(stance):
        x, z = _spot(foot, start, stop, anchored)
        out[start:stop] = np.linalg.norm(top[start:stop] - [x, ground, z], axis=1) <= reach
    for start, stop in true_runs(out):
        if stop - start < settings.min_stance_frames:
            out[start:stop] = False
    return out


def _targets(foot: np.ndarray, heel_rise: np.ndarray, stance: np.ndarray,
             anchored: np.ndarray, ground: float, blend: int) -> np.ndarray:
    """Where the foot should be in each frame: planted in stance, blended near it, and with
    both its end and its heel (``heel_rise`` above the end; the foot keeps its orientation)
    above the ground everywhere."""
    n = len(foot)
    weight = np.zeros(n)
    shift = np.zeros_like(foot)
    for start, stop in true_runs(stance):
        x, z = _spot(foot, start, stop, anchored)
        spot = np.array([x, ground, z])
        for t in range(max(0, start - blend), min(n, stop + blend)):
            gap = max(start - t, t - (stop - 1), 0)
            w = 1.0 if gap == 0 else _smooth(1.0 - gap / (blend + 1))
            if w > weight[t]:  # outside, the correction at touch-down (lift-off) fades out
                edge = min(max(t, start), stop - 1)
                weight[t], shift[t] = w, w * (spot - foot[edge]) if gap else spot - foot[t]
    target = foot + shift
    target[:, 1] = np.maximum(target[:, 1], ground - np.minimum(heel_rise, 0.0))
    return target


def _smooth(u: float) -> float:
    return u * u * (3 - 2 * u)


def _ground(skeleton: Skeleton, settings: ContactSettings) -> float:
    if settings.ground_y_m is not None:
        return float(settings.ground_y_m)
    rest = skeleton.joint_positions(skeleton.rest_pose())
    feet = [skeleton.joint_index(f) for f in find_feet(skeleton)]
    return float(rest[feet, 1].min()) if feet else float(rest[:, 1].min())


def _ground_speed(travel: np.ndarray) -> float:
    if len(travel) < 2:
        return 0.0
    return float(np.linalg.norm(travel[-1, [0, 2]] - travel[0, [0, 2]]) / (len(travel) - 1))


def _reach(skeleton: Skeleton, pose: np.ndarray, foot: str, target: np.ndarray) -> np.ndarray:
    """The leg onto the target, changed as little as it can, the hoof keeping its angle."""
    upper = skeleton.joints[leg_joints(skeleton, foot)[0]].name
    return solve_chain(skeleton, pose, foot, target, root_joint=upper,
                       foot_joint=_foot_joint(skeleton, foot), iterations=20).pose


def _foot_joint(skeleton: Skeleton, end: str) -> str | None:
    """The joint carrying the end site, kept level by the IK (None if it cannot be)."""
    parent = skeleton.joints[skeleton.joint_index(end)].parent
    if parent is None or not skeleton.joints[skeleton.joint_index(parent)].channels:
        return None
    return parent


def _report(name: str, before: np.ndarray, after: np.ndarray, target: np.ndarray,
            stance: np.ndarray, ground: float) -> FootReport:
    shift = np.linalg.norm(after - before, axis=1)
    moved = shift > 1e-6
    return FootReport(
        name=name, stance_frames=int(stance.sum()), moved_frames=int(moved.sum()),
        max_shift_m=float(shift.max(initial=0.0)),
        mean_shift_m=float(shift[moved].mean()) if moved.any() else 0.0,
        lowest_before_m=float(before[:, 1].min() - ground),
        lowest_after_m=float(after[:, 1].min() - ground),
        worst_miss_m=float(np.linalg.norm(after - target, axis=1).max(initial=0.0)))
