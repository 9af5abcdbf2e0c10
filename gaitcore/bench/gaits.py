"""Periodic quadruped gaits for the horse template: walk, trot, canter, gallop.

The legs are driven by their hooves: each hoof is planted on the ground (y = 0) for a duty
factor of the cycle and swung forward along a lifted, minimum-jerk path otherwise; its touch-
down time follows the footfall order of the gait. A planar inverse kinematics per leg turns the
hoof targets into joint angles with two flexion synergies (loaded stance: fetlock sinks; swing:
carpus/hock, fetlock and pastern fold), and the top joint (scapula, hip) carries the rest of
the protraction. The trunk, neck, head and tail follow a few harmonics per gait, with small
out-of-plane motions (roll, yaw, lateral sway, limb abduction, tail swish).

Footfall phases (fraction of the cycle at which each hoof lands, 0 for the first footfall of
the gait) and duty factors follow Hildebrand's gait diagrams of the horse (M. Hildebrand,
"Symmetrical gaits of horses", Science 150, 1965; "Analysis of asymmetrical gaits",
J. Mammalogy 58, 1977) and Muybridge's plates ("Animals in Motion", 1899):

- walk: 4-beat lateral sequence LH 0, LF .25, RH .5, RF .75; duty 0.62 (2-3 hooves always
  down), stride 1.6 m;
- trot: diagonal pairs LH+RF 0, RH+LF .5; duty 0.40 (two short flights), stride 2.5 m;
- canter, left lead: RH 0, then LH .28 with RF .30, then LF .56; 3 beats, duty 0.38, flight
  after LF, stride 3.0 m;
- gallop, transverse, left lead: RH 0, LH .10, RF .36, LF .47; 4 beats, duty 0.27, gathered
  flight after LF, stride 4.2 m.

The walk is symmetric: half a cycle later the pose is the left/right mirror (up to small
asymmetric trunk harmonics), which is the side-view ambiguity of the paper's Section 3.2.

Conventions are those of :mod:`gaitcore.rig.skeleton` (metres, degrees, X forward, Y up).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.rig.skeleton import Skeleton

LIMBS = ("LH", "LF", "RH", "RF")
FORE_CHAIN = ("scapula", "shoulder", "elbow", "carpus", "fore_fetlock", "fore_pastern",
              "fore_hoof", "fore_toe")
HIND_CHAIN = ("hip", "stifle", "hock", "hind_fetlock", "hind_pastern", "hind_hoof",
              "hind_toe")
# Flexion synergies, degrees per unit flexion, for the joints between the top joint and the
# hoof joint (fore: shoulder, elbow, carpus, fetlock, pastern; hind: stifle, hock, fetlock,
# pastern). Positive rz swings the distal part forward.
FORE_STANCE = np.array([-8.0, 10.0, 2.0, 42.0, 10.0])
FORE_SWING = np.array([-18.0, 55.0, -105.0, -75.0, -20.0])
HIND_STANCE = np.array([-10.0, 12.0, 40.0, 10.0])
HIND_SWING = np.array([-38.0, 48.0, -80.0, -20.0])
FORE_EXTEND = np.array([35.0, -30.0, 3.0, -15.0, -5.0])
HIND_EXTEND = np.array([30.0, -30.0, -15.0, -5.0])
"""Extension synergies, used for negative flexion (a leg reaching longer than at rest)."""
FORE_PROTRACTION = np.array([0.4, 0.0, 0.0, 0.0, 0.0])
"""Share of the leg's swing angle taken by the shoulder; the scapula takes the rest."""
HIND_PROTRACTION = np.array([0.0, 0.0, 0.0, 0.0])
PITCH_PIVOT_M = 0.55
"""Distance ahead of the root (pelvis) about which the trunk pitches, metres."""
_S_GRID = np.linspace(-1.6, 1.4, 151)

Harmonics = tuple[tuple[int, float, float], ...]
"""(k, amplitude, phase): amplitude * cos(2 pi k (t - phase)), t in cycles; k = 0 is a bias."""


@dataclass(frozen=True)
class GaitSpec:
    """Parameters of one gait.

    Attributes
    ----------
    name : str
    footfalls : dict of str to float
        Touch-down phase of each limb ("LH", "LF", "RH", "RF"), fraction of the cycle.
    duty_factor : float
        Fraction of the cycle each hoof spends on the ground.
    stride_m : float
        Distance travelled per cycle, metres.
    period_frames : int
        Default frames per cycle.
    lift_m : (float, float)
        Peak toe height in swing (fore, hind), metres.
    reach : (float, float)
        Fraction of the stance sweep (stride * duty) spent ahead of the rest hoof position
        (fore, hind): where the hoof lands relative to the standing pose.
    tuck_deg : float
        Hoof pitch at the height of swing (negative: sole turned backwards), degrees.
    motion : dict of str to Harmonics
        Trunk, neck, head and tail channels (root.ty in metres, angles in degrees).
    """

    name: str
    footfalls: dict[str, float]
    duty_factor: float
    stride_m: float
    period_frames: int
    lift_m: tuple[float, float]
    reach: tuple[float, float]
    tuck_deg: float
    motion: dict[str, Harmonics]


def _spec(name, footfalls, duty, stride, period, lift, reach, tuck, **motion) -> GaitSpec:
    return GaitSpec(name, dict(zip(LIMBS, footfalls)), duty, stride, period, lift, reach, tuck,
                    {k.replace("__", "."): tuple(v) for k, v in motion.items()})


GAITS: dict[str, GaitSpec] = {
    "walk": _spec(
        "walk", (0.0, 0.25, 0.5, 0.75), 0.62, 1.6, 40, (0.12, 0.10), (0.40, 0.5), -60.0,
        root__ty=[(2, 0.018, 0.30), (1, 0.004, 0.1)], root__tx=[(2, 0.012, 0.2)],
        root__tz=[(1, 0.018, 0.05)], root__rz=[(2, 1.2, 0.12), (1, 0.3, 0.2)],
        root__rx=[(1, 2.0, 0.05)], root__ry=[(1, 1.6, 0.30)],
        spine1__rz=[(2, 0.8, 0.2)], spine2__rz=[(2, 0.6, 0.25)],
        spine1__ry=[(1, 1.5, 0.3)], spine2__ry=[(1, 1.5, 0.35)], spine3__ry=[(1, 1.0, 0.4)],
        spine2__rx=[(1, 1.0, 0.1)],
        neck1__rz=[(0, -8.0, 0), (2, 4.0, 0.20)], neck2__rz=[(0, -4.0, 0), (2, 3.0, 0.25)],
        head__rz=[(2, 3.0, 0.30)], neck1__ry=[(1, 3.0, 0.4)], neck2__ry=[(1, 2.0, 0.45)],
        head__rx=[(1, 2.0, 0.3)],
        tail1__rz=[(0, -6.0, 0), (2, 3.0, 0.35)], tail2__rz=[(2, 3.0, 0.4)],
        tail3__rz=[(2, 3.0, 0.45)], tail1__rx=[(1, 6.0, 0.3)], tail2__rx=[(1, 6.0, 0.35)],
        tail3__rx=[(1, 6.0, 0.42)], tail4__rx=[(1, 6.0, 0.5)]),
    "trot": _spec(
        "trot", (0.0, 0.5, 0.5, 0.0), 0.40, 2.5, 30, (0.24, 0.18), (0.42, 0.5), -105.0,
        root__ty=[(0, -0.04, 0), (2, -0.035, 0.2), (1, 0.004, 0.3)], root__tx=[(2, 0.015, 0.1)],
        root__tz=[(1, 0.01, 0.2)], root__rz=[(2, 1.0, 0.3), (1, 0.4, 0.1)],
        root__rx=[(1, 2.5, 0.1)], root__ry=[(1, 1.5, 0.35)],
        spine1__rz=[(2, 1.0, 0.35)], spine2__rz=[(2, 0.8, 0.4)],
        spine1__ry=[(1, 1.2, 0.3)], spine2__ry=[(1, 1.2, 0.35)],
        neck1__rz=[(0, -2.0, 0), (2, 2.5, 0.30)], neck2__rz=[(2, 2.0, 0.35)],
        head__rz=[(0, 4.0, 0), (2, 2.0, 0.4)], neck1__ry=[(1, 1.5, 0.4)],
        tail1__rz=[(0, -14.0, 0), (2, 5.0, 0.40)], tail2__rz=[(0, -6.0, 0), (2, 5.0, 0.45)],
        tail3__rz=[(2, 5.0, 0.5)], tail4__rz=[(2, 4.0, 0.55)], tail1__rx=[(1, 4.0, 0.3)],
        tail2__rx=[(1, 4.0, 0.35)], tail3__rx=[(1, 5.0, 0.4)]),
    "canter": _spec(
        "canter", (0.28, 0.56, 0.0, 0.30), 0.38, 3.0, 28, (0.26, 0.22), (0.42, 0.5), -110.0,
        root__ty=[(0, -0.05, 0), (1, -0.055, 0.45), (2, -0.015, 0.22)], root__tx=[(1, 0.02, 0.3)],
        root__tz=[(1, 0.012, 0.3), (0, 0.01, 0)], root__rz=[(1, 5.0, 0.18), (2, 1.0, 0.1)],
        root__rx=[(1, 2.5, 0.2), (0, 1.5, 0)], root__ry=[(0, 3.0, 0), (1, 1.5, 0.4)],
        spine1__rz=[(1, -3.0, 0.05)], spine2__rz=[(1, -2.0, 0.1)],
        spine1__ry=[(0, 1.5, 0), (1, 1.0, 0.4)], spine2__ry=[(0, 1.0, 0)],
        neck1__rz=[(0, -9.0, 0), (1, 6.0, 0.20)], neck2__rz=[(1, 4.0, 0.25)],
        head__rz=[(0, 12.0, 0), (1, 4.0, 0.3)], neck1__ry=[(0, 4.0, 0), (1, 2.0, 0.3)],
        tail1__rz=[(0, -18.0, 0), (1, 8.0, 0.35)], tail2__rz=[(0, -8.0, 0), (1, 7.0, 0.42)],
        tail3__rz=[(1, 7.0, 0.5)], tail4__rz=[(1, 6.0, 0.58)], tail1__rx=[(1, 4.0, 0.3)],
        tail2__rx=[(1, 5.0, 0.4)]),
    "gallop": _spec(
        "gallop", (0.10, 0.47, 0.0, 0.36), 0.27, 4.2, 24, (0.30, 0.26), (0.42, 0.45), -115.0,
        root__ty=[(0, -0.06, 0), (1, -0.05, 0.35), (2, -0.025, 0.12)], root__tx=[(1, 0.03, 0.2)],
        root__tz=[(1, 0.012, 0.3)], root__rz=[(1, 7.0, 0.95), (2, 1.5, 0.05)],
        root__rx=[(1, 2.5, 0.2), (0, 1.5, 0)], root__ry=[(0, 2.0, 0), (1, 1.5, 0.4)],
        spine1__rz=[(1, -5.0, 0.95), (2, 1.5, 0.2)], spine2__rz=[(1, -3.5, 0.0)],
        spine3__rz=[(1, -2.0, 0.05)], spine1__ry=[(1, 1.0, 0.4)],
        neck1__rz=[(0, -10.0, 0), (1, 7.0, 0.15)], neck2__rz=[(0, -4.0, 0), (1, 5.0, 0.2)],
        head__rz=[(0, 22.0, 0), (1, 6.0, 0.25)], neck1__ry=[(0, 3.0, 0), (1, 2.0, 0.3)],
        tail1__rz=[(0, -25.0, 0), (1, 10.0, 0.3)], tail2__rz=[(0, -12.0, 0), (1, 9.0, 0.38)],
        tail3__rz=[(0, -6.0, 0), (1, 8.0, 0.46)], tail4__rz=[(1, 7.0, 0.54)],
        tail1__rx=[(1, 5.0, 0.3)], tail2__rx=[(1, 6.0, 0.4)]),
}


def generate_gait(skeleton: Skeleton, gait: str, n_frames: int, *,
                  period_frames: float | None = None, noise_deg: float = 0.0,
                  seed: int | None = None, phase: float = 0.0,
                  lead: str = "left") -> np.ndarray:
    """Joint-angle curves of a periodic gait.

    Parameters
    ----------
    skeleton : Skeleton
        The horse template (:func:`gaitcore.rig.templates.load_template` ``("horse")``) or any
        skeleton with the same leg joint names (``L_``/``R_`` + FORE_CHAIN, HIND_CHAIN),
        ``spine3`` and the named trunk channels.
    gait : {"walk", "trot", "canter", "gallop"}
    n_frames : int
        Number of frames, >= 1.
    period_frames : float, optional
        Frames per gait cycle (default: walk 40, trot 30, canter 28, gallop 24); >= 8.
    noise_deg : float
        Standard deviation of independent Gaussian noise added to every rotation channel of
        every frame, degrees (0: exact periodic motion).
    seed : int, optional
        Seed of the noise generator.
    phase : float
        Gait phase of frame 0, in cycles (0: first footfall of the gait).
    lead : {"left", "right"}
        Leading side; "right" mirrors the motion (canter and gallop leads; for the symmetric
        gaits it only shifts which side starts).

    Returns
    -------
    ndarray of shape (n_frames, k)
        Poses laid out as ``skeleton.channel_names``; root.tx grows with the stride.

    Raises
    ------
    GaitInputError
        Unknown gait, bad frame count or period, negative noise, or a skeleton without the
        horse's joints.

    Notes
    -----
    Input of the paper's Section 4 experiment (a horse of ellipsoids in walk, canter and
    gallop). Footfall order and duty factors: see the module docstring.
    """
    spec = GAITS.get(gait)
    if spec is None:
        raise GaitInputError(f"unknown gait {gait!r}; choose one of {', '.join(GAITS)}")
    if isinstance(n_frames, bool) or int(n_frames) != n_frames or n_frames < 1:
        raise GaitInputError(f"n_frames must be a positive integer, got {n_frames!r}")
    period = float(spec.period_frames if period_frames is None else period_frames)
    if not np.isfinite(period) or period < 8:
        raise GaitInputError(f"period_frames must be at least 8 frames, got {period_frames!r}")
    if not np.isfinite(noise_deg) or noise_deg < 0:
        raise GaitInputError(f"noise_deg must be zero or positive, got {noise_deg!r}")
    if lead not in ("left", "right"):
        raise GaitInputError(f"lead must be 'left' or 'right', got {lead!r}")
    _check_skeleton(skeleton, spec)

    t = np.arange(int(n_frames)) / period + phase
    poses = np.zeros((len(t), skeleton.n_channels))
    for channel, harmonics in spec.motion.items():
        poses[:, skeleton.channel_index(channel)] = _harmonics(t, harmonics)
    poses[:, skeleton.channel_index("root.tx")] += spec.stride_m * t
    # the trunk pitches about its middle, not about the pelvis (the root)
    pitch = np.radians(poses[:, skeleton.channel_index("root.rz")])
    poses[:, skeleton.channel_index("root.ty")] -= PITCH_PIVOT_M * np.sin(pitch)
    trunk_world = skeleton.forward_kinematics(poses)
    rest = skeleton.joint_positions(skeleton.rest_pose())
    for limb in LIMBS:
        _solve_leg(skeleton, spec, limb, t, poses, trunk_world, rest)
    if lead == "right":
        poses = skeleton.mirror_pose(poses)
    if noise_deg > 0:
        rot = np.array([not n.rsplit(".", 1)[1].startswith("t")
                        for n in skeleton.channel_names])
        rng = np.random.default_rng(seed)
        poses[:, rot] += rng.normal(0.0, noise_deg, size=(len(t), int(rot.sum())))
    return poses


def stance_mask(gait: str, n_frames: int, *, period_frames: float | None = None,
                phase: float = 0.0) -> dict[str, np.ndarray]:
    """Which hooves are on the ground in each frame (left lead).

    Returns
    -------
    dict of str to ndarray of bool, shape (n_frames,)
        One entry per limb ("LH", "LF", "RH", "RF").
    """
    spec = GAITS.get(gait)
    if spec is None:
        raise GaitInputError(f"unknown gait {gait!r}; choose one of {', '.join(GAITS)}")
    t = np.arange(n_frames) / float(period_frames or spec.period_frames) + phase
    return {limb: (t - spec.footfalls[limb]) % 1.0 < spec.duty_factor for limb in LIMBS}


def _harmonics(t: np.ndarray, harmonics: Harmonics) -> np.ndarray:
    out = np.zeros_like(t)
    for k, amp, ph in harmonics:
        out += amp * np.cos(2 * np.pi * k * (t - ph))
    return out


def _check_skeleton(skeleton: Skeleton, spec: GaitSpec) -> None:
    names = set(skeleton.channel_names)
    need = {f"{s}_{j}.rz" for s in "LR" for j in FORE_CHAIN[:-1] + HIND_CHAIN[:-1]}
    need |= set(spec.motion) | {"root.tx"}
    missing = sorted(need - names)
    joints = set(skeleton.joint_names)
    for s in "LR":
        for end in (FORE_CHAIN[-1], HIND_CHAIN[-1]):
            if f"{s}_{end}" not in joints:
                missing.append(f"{s}_{end}")
    if missing:
        raise GaitInputError(
            f"skeleton {skeleton.name!r} lacks {', '.join(missing[:6])}"
            f"{'...' if len(missing) > 6 else ''}; gaits need the horse template's joints "
            "(load_template('horse'))"
        )


def _limb_trajectory(spec: GaitSpec, limb: str, t: np.ndarray, toe_rest_x: float,
                     ) -> tuple[np.ndarray, ...]:
    """World toe x, y, hoof pitch (deg), synergy weight and swing phase (-1 in stance).

    ``toe_rest_x`` is the toe's world x in the rest pose; the body travels stride_m * t.
    """
    beta, stride = spec.duty_factor, spec.stride_m
    fore = limb.endswith("F")
    lift, reach = (spec.lift_m[0], spec.reach[0]) if fore else (spec.lift_m[1], spec.reach[1])
    rel = t - spec.footfalls[limb]
    k, u = np.floor(rel), rel - np.floor(rel)
    landing_x = stride * (k + spec.footfalls[limb]) + toe_rest_x + stride * beta * reach
    swing = u >= beta
    us = np.clip((u - beta) / (1 - beta), 0.0, 1.0)
    x = landing_x + stride * np.where(swing, us**3 * (10 - 15 * us + 6 * us**2), 0.0)
    y = np.where(swing, lift * np.sin(np.pi * us**0.75) ** 1.5, 0.0)
    breakover = -35.0
    ub = np.clip((u / beta - 0.8) / 0.2, 0.0, 1.0)
    pitch_stance = breakover * ub * ub * (3 - 2 * ub)
    from scipy.interpolate import PchipInterpolator  # scipy.interpolate: 0.2 s to import

    tuck = PchipInterpolator([0.0, 0.35, 0.85, 1.0], [breakover, spec.tuck_deg, 8.0, 0.0])
    pitch = np.where(swing, tuck(us), pitch_stance)
    # swing weight of the synergies: 0 in loaded stance, rising through breakover and the
    # start of swing to 1, back to 0 at touch-down (continuous everywhere)
    ramp_in = 0.5 * np.clip((u / beta - 0.85) / 0.15, 0.0, 1.0)
    w_swing = np.clip(np.minimum(0.5 + 0.5 * us / 0.12, (1 - us) / 0.12), 0.0, 1.0)
    w = np.where(swing, w_swing, ramp_in)
    return x, y, pitch, w, np.where(swing, us, -1.0)


def _solve_leg(skeleton: Skeleton, spec: GaitSpec, limb: str, t: np.ndarray,
               poses: np.ndarray, world: np.ndarray, rest: np.ndarray) -> None:
    """Planar inverse kinematics of one leg; writes its channels into ``poses``."""
    side, fore = limb[0], limb[1] == "F"
    chain = [skeleton.joint_index(f"{side}_{j}") for j in (FORE_CHAIN if fore else HIND_CHAIN)]
    stance_syn, swing_syn, extend = ((FORE_STANCE, FORE_SWING, FORE_EXTEND) if fore
                                     else (HIND_STANCE, HIND_SWING, HIND_EXTEND))
    protraction = FORE_PROTRACTION if fore else HIND_PROTRACTION
    top, hoof, toe = chain[0], chain[-2], chain[-1]
    parent = int(skeleton.parents[top])
    offs = skeleton.offsets[chain][:, :2]  # offsets[i] is joint chain[i] in its parent frame

    toe_x, toe_y, pitch, w, swing_u = _limb_trajectory(spec, limb, t, rest[toe, 0])
    toe_rest_vec = rest[toe, :2] - rest[hoof, :2]  # hoof joint -> toe at rest (world)
    c, s = np.cos(np.radians(pitch)), np.sin(np.radians(pitch))
    hoof_dir = np.stack([c * toe_rest_vec[0] - s * toe_rest_vec[1],
                         s * toe_rest_vec[0] + c * toe_rest_vec[1]], axis=1)
    target = np.stack([toe_x, toe_y, np.full_like(t, rest[toe, 2])], axis=1)
    target[:, :2] -= hoof_dir
    # into the parent frame of the top joint, relative to the top joint
    rot, origin = world[:, parent, :3, :3], world[:, parent, :3, 3]
    local = np.einsum("nji,nj->ni", rot, target - origin)[:, :2] - offs[0]
    hoof_local = np.einsum("nji,nj->ni", rot[:, :2, :], hoof_dir)[:, :2]
    rest_dir = np.sum(offs[1:-1], axis=0)
    swing_angle = _angle(local) - _angle(rest_dir[None, :])

    syn = (1 - w)[:, None] * stance_syn + w[:, None] * swing_syn  # (n, m)
    grid = _S_GRID[None, :, None]
    q = (np.where(grid >= 0, grid * syn[:, None, :], -grid * extend)
         + (protraction * swing_angle[:, None])[:, None])
    ends = _chain_end(offs[1:-1], q)  # (n, g, 2), top joint unrotated
    s_star = _solve_flexion(np.linalg.norm(ends, axis=-1), np.linalg.norm(local, axis=1))
    qd = (np.where(s_star[:, None] >= 0, s_star[:, None] * syn, -s_star[:, None] * extend)
          + protraction * swing_angle[:, None])
    end = _chain_end(offs[1:-1], qd[:, None, :])[:, 0]
    q_top = _angle(local) - _angle(end)
    q_hoof = _angle(hoof_local) - _angle(offs[-1][None, :]) - q_top - qd.sum(axis=1)

    angles = np.column_stack([q_top, qd, q_hoof])
    for j, a in zip(chain[:-1], angles.T):
        poses[:, skeleton.channel_index(f"{skeleton.joints[j].name}.rz")] = a
    # out-of-plane: swing abduction at the top joint, hind cannon rotation in stance
    out_sign = -1.0 if side == "R" else 1.0
    bump = np.where(swing_u >= 0, np.sin(np.pi * np.clip(swing_u, 0, 1)) ** 2, 0.0)
    poses[:, skeleton.channel_index(f"{skeleton.joints[top].name}.rx")] = out_sign * 3.0 * bump
    if not fore:
        hock = skeleton.joints[chain[2]].name
        poses[:, skeleton.channel_index(f"{hock}.ry")] = out_sign * 2.0 * (1.0 - w)


def _solve_flexion(lengths: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Flexion s per frame such that the chain length equals ``dist``.

    lengths : (n, g) chain length on _S_GRID; dist : (n,). Takes the root nearest s = 0
    (the least bent solution) and, when the leg cannot reach, the grid point nearest to it.
    """
    f = lengths - dist[:, None]
    cross = f[:, :-1] * f[:, 1:] <= 0
    mid = np.abs(0.5 * (_S_GRID[:-1] + _S_GRID[1:]))
    k = np.argmin(np.where(cross, mid, np.inf), axis=1)
    f0, f1 = f[np.arange(len(f)), k], f[np.arange(len(f)), k + 1]
    frac = np.clip(f0 / np.where(f0 == f1, 1.0, f0 - f1), 0.0, 1.0)
    s = _S_GRID[k] + frac * (_S_GRID[k + 1] - _S_GRID[k])
    nearest = _S_GRID[np.argmin(np.abs(f), axis=1)]
    return np.where(cross.any(axis=1), s, nearest)


def _angle(v: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(v[..., 1], v[..., 0]))


def _chain_end(offsets: np.ndarray, q: np.ndarray) -> np.ndarray:
    """End of a planar chain: sum of offsets[i] rotated by the cumulative angles q[..., :i+1].

    offsets : (m, 2) for the joints after the top; q : (..., m) angles of the joints that
    carry them (the top joint excluded, it is applied afterwards).
    """
    cum = np.radians(np.cumsum(q, axis=-1))
    c, s = np.cos(cum), np.sin(cum)
    # offsets[0] is carried by the top joint only, offsets[i] by joints 1..i (q[..., :i])
    x = offsets[0, 0] + np.sum(c * offsets[1:, 0] - s * offsets[1:, 1], axis=-1)
    y = offsets[0, 1] + np.sum(s * offsets[1:, 0] + c * offsets[1:, 1], axis=-1)
    return np.stack([x, y], axis=-1)
