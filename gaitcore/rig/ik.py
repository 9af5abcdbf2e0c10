"""Inverse kinematics on a skeleton, within its joint limits: legs and free chains.

Two solvers, both Qt-free and working on one pose vector at a time:

- :func:`solve_leg`, analytic two-bone IK: the knee bends about its own flexion axis (its
  ``rz`` axis, perpendicular to the side-view image) until the hip-to-end distance is right,
  then the upper joint swings the whole leg onto the target. A ``foot_joint`` keeps its world
  orientation (a hoof stays flat on the ground while the leg moves).
- :func:`solve_chain`, damped least squares over every rotation channel from an ancestor
  down to the end: for necks and tails, or a whole leg changed as little as possible.

Every joint angle stays within :attr:`Joint.limits`; a target out of reach gives the closest
pose the limits allow and says so (:attr:`IKResult.reached`).

References
----------
S. R. Buss, "Introduction to inverse kinematics with Jacobian transpose, pseudoinverse and
damped least squares methods", 2004 (the chain solver). R. Tolani, H. Ko, N. Badler,
"Real-time inverse kinematics techniques for anthropomorphic limbs", Graphical Models 62(5),
2000 (analytic two-bone).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.rig.rotations import euler_zxy_matrix, zxy_from_matrix
from gaitcore.rig.skeleton import ROTATION_CHANNELS, Skeleton

DEFAULT_TOLERANCE_M = 1e-4
"""Distance from the target under which a solve stops, metres."""
DEFAULT_DAMPING = 0.02
"""Damping of the least-squares chain solver, metres."""


@dataclass(frozen=True, eq=False)
class IKResult:
    """A solved pose and how close its end joint came to the target.

    Attributes
    ----------
    pose : ndarray of shape (k,)
        The input pose with the chain's rotation channels changed.
    error_m : float
        Distance from the end joint to the target, metres.
    reached : bool
        ``error_m`` is within the tolerance; False means the target is out of reach within
        the joint limits and ``pose`` is the closest one found.
    """

    pose: np.ndarray
    error_m: float
    reached: bool


class _Chain:
    """World transforms of one pose, recomputed joint by joint as angles change."""

    def __init__(self, skeleton: Skeleton, pose: np.ndarray) -> None:
        self.skeleton = skeleton
        self.pose = np.array(pose, dtype=float)
        self.world = skeleton.forward_kinematics(self.pose)
        self.limits, self.slots, self._below, self._moves = _layout(skeleton)

    def position(self, j: int) -> np.ndarray:
        return self.world[j, :3, 3]

    def angles(self, j: int) -> np.ndarray:
        idx = self.slots[j]
        return np.where(idx >= 0, self.pose[np.maximum(idx, 0)], 0.0)

    def parent_rotation(self, j: int) -> np.ndarray:
        parent = self.skeleton.parents[j]
        return np.eye(3) if parent < 0 else self.world[parent, :3, :3]

    def set_angles(self, j: int, angles: np.ndarray) -> None:
        """Write (rz, rx, ry) of joint j, clamped to its limits, and update the world below."""
        self.add_angles([(j, c) for c in range(3)], np.asarray(angles) - self.angles(j))

    def add_angles(self, channels: list[tuple[int, int]], deltas: np.ndarray) -> None:
        """Add ``deltas`` (degrees) to (joint, channel) pairs, clamped; update once."""
        top = None
        for (j, c), delta in zip(channels, deltas):
            slot = self.slots[j][c]
            if slot >= 0:
                lo, hi = self.limits[slot]
                self.pose[slot] = min(max(self.pose[slot] + delta, lo), hi)
                top = j if top is None or j < top else top
        if top is not None:
            self._update_below(top)

    def set_world_rotation(self, j: int, rotation: np.ndarray) -> None:
        """Give joint j the world rotation ``rotation`` as nearly as its channels allow."""
        local = self.parent_rotation(j).T @ rotation
        self.set_angles(j, _nearest_zxy(local, self.angles(j)))

    def _update_below(self, j: int) -> None:
        skel, parents = self.skeleton, self.skeleton.parents
        for i in self._below[j]:
            local = np.eye(4)
            local[:3, :3] = euler_zxy_matrix(self.angles(i))
            local[:3, 3] = skel.offsets[i] + [self.pose[k] if k >= 0 else 0.0
                                              for k in self._moves[i]]
            self.world[i] = local if parents[i] < 0 else self.world[parents[i]] @ local


@lru_cache(maxsize=8)
def _layout(skeleton: Skeleton) -> tuple[np.ndarray, dict, dict, dict]:
    """Per skeleton: channel limits; per joint its (rz, rx, ry) and (tx, ty, tz) channel
    indices (-1 where absent) and itself with its descendants, parents first."""
    names = {n: i for i, n in enumerate(skeleton.channel_names)}
    slots, moves, below = {}, {}, {}
    for j, joint in enumerate(skeleton.joints):
        slots[j] = np.array([names.get(f"{joint.name}.{c}", -1) for c in ROTATION_CHANNELS])
        moves[j] = [names.get(f"{joint.name}.{c}", -1) for c in ("tx", "ty", "tz")]
        below[j] = [j]
    for j in range(skeleton.n_joints - 1, 0, -1):  # parents come first: fold children up
        below[int(skeleton.parents[j])] += below[j]
    below = {j: sorted(v) for j, v in below.items()}
    return skeleton.limits_array(), slots, below, moves


def solve_leg(skeleton: Skeleton, pose: np.ndarray, end_joint: str, target_xyz: np.ndarray, *,
              upper_joint: str | None = None, knee_joint: str | None = None,
              foot_joint: str | None = None, iterations: int = 4,
              tolerance_m: float = DEFAULT_TOLERANCE_M) -> IKResult:
    """Move a leg so that ``end_joint`` reaches ``target_xyz``: analytic two-bone IK.

    Parameters
    ----------
    skeleton : Skeleton
    pose : array_like of shape (k,)
        Pose vector laid out as ``skeleton.channel_names``.
    end_joint : str
        The joint (or end site) that must reach the target, e.g. ``"L_fore_toe"``.
    target_xyz : array_like of shape (3,)
        World position, metres.
    upper_joint, knee_joint : str, optional
        The joint that swings the leg and the joint that bends it. By default
        (:func:`leg_joints`) the top of the leg (the first joint below the trunk on the end
        joint's side) and the joint that splits the leg's length most evenly.
    foot_joint : str, optional
        A joint between the knee and the end that keeps its world orientation (the hoof stays
        flat while the leg moves); None lets the foot turn with the leg.
    iterations : int
        Bend-then-swing passes; more than one matters only when limits clamp an angle.
    tolerance_m : float

    Returns
    -------
    IKResult

    Raises
    ------
    GaitInputError
        Unknown joint names, a knee that is not between the upper joint and the end, or a
        target that is not three finite numbers.

    Examples
    --------
    >>> from gaitcore.rig.templates import load_template
    >>> horse = load_template("horse")
    >>> toe = horse.joint_positions(horse.rest_pose())[horse.joint_index("L_fore_toe")]
    >>> result = solve_leg(horse, horse.rest_pose(), "L_fore_toe", toe + [0.05, 0.05, 0.0])
    >>> result.reached
    True
    """
    end, target = skeleton.joint_index(end_joint), _target(target_xyz)
    upper, knee, foot = _leg(skeleton, end_joint, upper_joint, knee_joint, foot_joint)
    chain = _Chain(skeleton, pose)
    foot_rotation = None if foot is None else chain.world[foot, :3, :3].copy()
    for _ in range(max(1, iterations)):
        effector, aim = end, target
        if foot is not None:  # the foot joint aims where the end lands with the foot kept
            reach = chain.position(end) - chain.position(foot)
            aim = target - foot_rotation @ (chain.world[foot, :3, :3].T @ reach)
            effector = foot
        _bend(chain, upper, knee, effector, aim)
        _swing(chain, upper, effector, aim)
        if foot is not None:
            chain.set_world_rotation(foot, foot_rotation)
        if np.linalg.norm(chain.position(end) - target) <= tolerance_m:
            break
    return _result(chain, end, target, tolerance_m)


def _leg(skeleton: Skeleton, end_joint: str, upper_joint: str | None, knee_joint: str | None,
         foot_joint: str | None) -> tuple[int, int, int | None]:
    """Upper, knee and foot joint indices of a leg (defaults from :func:`leg_joints`), checked."""
    default_upper, default_knee = leg_joints(skeleton, end_joint)
    upper = skeleton.joint_index(upper_joint) if upper_joint else default_upper
    knee = skeleton.joint_index(knee_joint) if knee_joint else default_knee
    foot = skeleton.joint_index(foot_joint) if foot_joint else None
    path = _path_up(skeleton, skeleton.joint_index(end_joint), upper)
    if knee not in path[1:-1] or (foot is not None and foot not in path[:path.index(knee)]):
        raise GaitInputError(f"solve_leg: {skeleton.joints[knee].name!r} must lie between "
                             f"{skeleton.joints[upper].name!r} and {end_joint!r}, and the foot "
                             "between the knee and the end")
    return upper, knee, foot


def solve_chain(skeleton: Skeleton, pose: np.ndarray, end_joint: str, target_xyz: np.ndarray,
                *, root_joint: str, foot_joint: str | None = None, iterations: int = 30,
                damping: float = DEFAULT_DAMPING, tolerance_m: float = DEFAULT_TOLERANCE_M,
                min_gain_m_per_deg: float = 0.0) -> IKResult:
    """Move a chain (neck, tail, a whole leg) so that ``end_joint`` reaches ``target_xyz``.

    Damped least squares: each step changes every rotation channel of the chain by the
    smallest amount (in the least-squares sense) that moves the end toward the target, so
    the correction spreads over the chain instead of piling on the joints nearest the end
    (as cyclic coordinate descent does), and the pose changes as little as it can.

    Parameters
    ----------
    skeleton : Skeleton
    pose : array_like of shape (k,)
    end_joint : str
        The joint (or end site) that must reach the target.
    target_xyz : array_like of shape (3,)
        World position, metres.
    root_joint : str
        The highest joint of the chain that may turn (an ancestor of ``end_joint``).
    foot_joint : str, optional
        A joint of the chain that keeps its world orientation (see :func:`solve_leg`).
    iterations : int
        Least-squares steps.
    damping : float
        Metres; larger is steadier near unreachable targets and slower to converge.
    tolerance_m : float
    min_gain_m_per_deg : float
        The least a degree of change (the norm of the chain's angle changes) must bring the
        end closer for the solve to take it: near a target just out of the reach of the
        chain's shape, the last centimetres would straighten it (a tail, a neck) for little
        gain; the solve keeps the pose with the least ``miss + min_gain * change``. 0 follows
        the target to the closest pose.

    Returns
    -------
    IKResult

    Raises
    ------
    GaitInputError
        Unknown joints, ``root_joint`` not an ancestor of ``end_joint``, a bad target.

    References
    ----------
    S. R. Buss, "Introduction to inverse kinematics with Jacobian transpose, pseudoinverse
    and damped least squares methods", 2004.
    """
    end = skeleton.joint_index(end_joint)
    target = _target(target_xyz)
    path = _path_up(skeleton, end, skeleton.joint_index(root_joint))
    foot = skeleton.joint_index(foot_joint) if foot_joint else None
    if foot is not None and foot not in path[1:]:
        raise GaitInputError(f"solve_chain: the foot {foot_joint!r} must lie above {end_joint!r}")
    chain = _Chain(skeleton, pose)
    movers = [j for j in path[1:] if (chain.slots[j] >= 0).any() and j != foot]
    best = _descend(chain, movers, end, foot, target, iterations=iterations, damping=damping,
                    tolerance_m=tolerance_m, min_gain=min_gain_m_per_deg)
    return _result(_Chain(skeleton, best), end, target, tolerance_m)


def _descend(chain: _Chain, movers: list[int], end: int, foot: int | None,
             target: np.ndarray, *, iterations: int, damping: float, tolerance_m: float,
             min_gain: float = 0.0) -> np.ndarray:
    """Damped least-squares steps on ``chain``; the pose of least ``miss + min_gain *
    change`` (degrees from the start), the closest to the target when ``min_gain`` is 0."""
    foot_rotation = None if foot is None else chain.world[foot, :3, :3].copy()
    start = chain.pose.copy()
    best = (np.linalg.norm(chain.position(end) - target), chain.pose.copy())
    for _ in range(max(1, iterations)):
        effector, aim = _effector(chain, end, foot, foot_rotation, target)
        error = aim - chain.position(effector)
        if np.linalg.norm(error) <= tolerance_m:
            break
        slots, step = _least_squares_step(chain, [j for j in movers if j != effector],
                                          effector, error, damping)
        if not slots:
            break
        chain.add_angles(slots, step)
        if foot is not None:
            chain.set_world_rotation(foot, foot_rotation)
        cost = (np.linalg.norm(chain.position(end) - target)
                + min_gain * np.linalg.norm(chain.pose - start))
        if cost < best[0]:
            best = (cost, chain.pose.copy())
    return best[1]


def _effector(chain: _Chain, end: int, foot: int | None, foot_rotation: np.ndarray | None,
              target: np.ndarray) -> tuple[int, np.ndarray]:
    """The joint to move and where: the end itself, or the foot placed so that the end lands
    on the target with the foot's orientation kept."""
    if foot is None:
        return end, target
    reach = chain.world[foot, :3, :3].T @ (chain.position(end) - chain.position(foot))
    return foot, target - foot_rotation @ reach


def _least_squares_step(chain: _Chain, joints: list[int], effector: int, error: np.ndarray,
                        damping: float) -> tuple[list[tuple[int, int]], np.ndarray]:
    """Damped least-squares change of the free channels (degrees) toward ``error``.

    Channels held at a limit that the step would push further are left out and the step is
    solved again without them, so the remaining channels do the work.
    """
    slots, jacobian = _jacobian(chain, joints, effector)
    while slots:
        step = np.degrees(jacobian.T @ np.linalg.solve(
            jacobian @ jacobian.T + damping**2 * np.eye(3), error))
        values = np.array([chain.pose[chain.slots[j][c]] for j, c in slots])
        limits = np.array([chain.limits[chain.slots[j][c]] for j, c in slots])
        stuck = ((values <= limits[:, 0] + 1e-9) & (step < 0)) | \
                ((values >= limits[:, 1] - 1e-9) & (step > 0))
        if not stuck.any():
            return slots, step
        slots = [s for s, x in zip(slots, stuck) if not x]
        jacobian = jacobian[:, ~stuck]
    return slots, np.zeros(0)


def _jacobian(chain: _Chain, joints: list[int], effector: int
              ) -> tuple[list[tuple[int, int]], np.ndarray]:
    """(joint, channel) of every rotation channel and d(effector)/d(angle), (3, m)."""
    e = chain.position(effector)
    slots, columns = [], []
    for j in joints:
        rz, rx, _ = np.radians(chain.angles(j))
        parent = chain.parent_rotation(j)
        after_z = parent @ _axis_rotation(2, rz)
        axes = (parent[:, 2], after_z[:, 0], (after_z @ _axis_rotation(0, rx))[:, 1])
        for c, axis in enumerate(axes):
            slot = chain.slots[j][c]
            if slot < 0 or chain.limits[slot, 0] == chain.limits[slot, 1]:
                continue
            slots.append((j, c))
            columns.append(np.cross(axis, e - chain.position(j)))
    return slots, np.array(columns).T if columns else np.zeros((3, 0))


def _axis_rotation(axis: int, angle_rad: float) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m = np.eye(3)
    m[i, i] = m[j, j] = c
    m[i, j], m[j, i] = -s, s
    return m


def leg_joints(skeleton: Skeleton, end_joint: str) -> tuple[int, int]:
    """Default upper and knee joints of the leg ending at ``end_joint`` (indices).

    The upper joint is the top of the leg: the highest ancestor on the end joint's side
    (``L``/``R``), or the fourth joint up on a skeleton without sides. The knee is the
    rotating joint strictly between them whose distance from the upper joint along the rest
    skeleton is nearest half the leg's length.

    Raises
    ------
    GaitInputError
        The end joint has fewer than two rotating ancestors.
    """
    end = skeleton.joint_index(end_joint)
    side = skeleton.joints[end].side
    path = _path_up(skeleton, end, None)  # end ... root
    if side in ("L", "R"):
        upper_at = max(i for i, j in enumerate(path) if skeleton.joints[j].side == side)
    else:
        upper_at = min(4, len(path) - 1)
    leg = path[:upper_at + 1][::-1]  # upper ... end
    rest = skeleton.joint_positions(skeleton.rest_pose())
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(rest[leg], axis=0), axis=1))])
    inner = [i for i in range(1, len(leg) - 1) if skeleton.joints[leg[i]].channels]
    if not inner:
        raise GaitInputError(f"joint {end_joint!r} has no leg above it to bend (needs an upper "
                             "joint and a knee)")
    knee_at = min(inner, key=lambda i: abs(along[i] - along[-1] / 2))
    return leg[0], leg[knee_at]


def _bend(chain: _Chain, upper: int, knee: int, end: int, target: np.ndarray) -> None:
    """Turn the knee about its flexion axis so that |upper - end| = |upper - target|."""
    a, b, e = chain.position(upper), chain.position(knee), chain.position(end)
    axis = chain.parent_rotation(knee)[:, 2]  # rz turns about the parent frame's z
    u, v = a - b, e - b
    want = float(np.linalg.norm(target - a))
    s = (u @ u + v @ v - want * want) / 2  # u . R(theta) v must equal s
    ku, kv = u @ axis, v @ axis
    alpha, beta, gamma = u @ v - ku * kv, u @ np.cross(axis, v), ku * kv
    rho = np.hypot(alpha, beta)
    if rho < 1e-12:
        return
    phi = np.arctan2(beta, alpha)
    spread = np.arccos(np.clip((s - gamma) / rho, -1.0, 1.0))
    angles = chain.angles(knee)
    lo, hi = chain.limits[chain.slots[knee][0]] if chain.slots[knee][0] >= 0 else (-np.inf, np.inf)
    options = [np.degrees(_wrap(phi + sign * spread)) for sign in (1.0, -1.0)]
    inside = [d for d in options if lo <= angles[0] + d <= hi]
    if inside:
        delta = min(inside, key=abs)
    else:  # neither bend is allowed: the limit nearest to one of them
        clamped = [float(np.clip(angles[0] + d, lo, hi)) - angles[0] for d in options]
        delta = min(clamped, key=lambda c: min(abs(c - d) for d in options))
    chain.set_angles(knee, angles + [delta, 0.0, 0.0])


def _swing(chain: _Chain, joint: int, end: int, target: np.ndarray) -> None:
    """Turn ``joint`` by the smallest rotation that points its end at the target."""
    origin = chain.position(joint)
    turn = _rotation_between(chain.position(end) - origin, target - origin)
    if turn is not None:
        chain.set_world_rotation(joint, turn @ chain.world[joint, :3, :3])


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """The smallest rotation taking direction a to direction b (None if either is ~0)."""
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na < 1e-9 or nb < 1e-9:
        return None
    a, b = a / na, b / nb
    axis, cos = np.cross(a, b), float(np.clip(a @ b, -1.0, 1.0))
    sin = np.linalg.norm(axis)
    if sin < 1e-12:
        return None  # aligned (or exactly opposite, where any axis would do: leave it)
    k = axis / sin
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + sin * kx + (1 - cos) * kx @ kx


def _nearest_zxy(local: np.ndarray, current: np.ndarray) -> np.ndarray:
    """The (rz, rx, ry) of ``local`` nearest ``current`` among its equivalent triples."""
    first = zxy_from_matrix(local)
    second = first + [180.0, 0.0, 180.0]
    second[1] = 180.0 - first[1]
    cands = [cand + 360.0 * np.round((current - cand) / 360.0) for cand in (first, second)]
    return min(cands, key=lambda cand: float(np.abs(cand - current).sum()))  # first on a tie


def _wrap(angle_rad: float) -> float:
    return (angle_rad + np.pi) % (2 * np.pi) - np.pi


def _path_up(skeleton: Skeleton, start: int, stop: int | None) -> list[int]:
    """Joints from ``start`` up to ``stop`` (both included), or to the root when None."""
    path, j = [start], start
    while j != stop:
        j = int(skeleton.parents[j])
        if j < 0:
            if stop is None:
                return path
            raise GaitInputError(f"{skeleton.joints[stop].name!r} is not above "
                                 f"{skeleton.joints[start].name!r} in the hierarchy")
        path.append(j)
    return path


def _target(target_xyz: np.ndarray) -> np.ndarray:
    t = np.asarray(target_xyz, dtype=float)
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise GaitInputError(f"an IK target must be three finite numbers (x, y, z metres), "
                             f"got {target_xyz!r}")
    return t


def _result(chain: _Chain, end: int, target: np.ndarray, tolerance_m: float) -> IKResult:
    error = float(np.linalg.norm(chain.position(end) - target))
    return IKResult(chain.pose, error, error <= tolerance_m)
