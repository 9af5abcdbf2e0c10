"""Standing an imported rig up: which way is up and forward, feet on the ground.

Rigs come Y-up (Maya, most BVH) or Z-up (Blender, 3ds Max), facing any axis, in metres or
centimetres, with the root anywhere. Gait Studio's frame is Y up, X forward, Z to the
animal's right (:mod:`gaitcore.rig.skeleton`). :func:`guess_axes` reads the rest pose: the up
axis is the one along which the most end joints (the feet) share the lowest level, forward
is the long horizontal axis, towards the head (a joint named so, else the highest end
joint). :func:`reoriented` turns the rest offsets into Gait Studio's frame and stands the
rig on the ground under the origin.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.rig.skeleton import Skeleton

AXES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
FOOT_BAND = 0.08
"""End joints within this share of the rig's height above its lowest one count as feet."""
HEAD_WORDS = ("head", "skull", "nose", "jaw")


@dataclass(frozen=True)
class RigAxes:
    """The axes of a rig as read, in its own file frame.

    Attributes
    ----------
    up, forward : str
        One of :data:`AXES` each, on different axes.
    ambiguous : bool
        The rest pose does not tell clearly; ``reason`` says why.
    reason : str
    """

    up: str
    forward: str
    ambiguous: bool = False
    reason: str = ""


def axis_vector(axis: str) -> np.ndarray:
    """The unit vector of ``axis`` ("+X" ... "-Z")."""
    if axis not in AXES:
        raise GaitInputError(f"unknown axis {axis!r}: use one of {', '.join(AXES)}")
    v = np.zeros(3)
    v["XYZ".index(axis[1])] = 1.0 if axis[0] == "+" else -1.0
    return v


def guess_axes(skeleton: Skeleton) -> RigAxes:
    """Up and forward axes of ``skeleton``'s rest pose (see the module notes)."""
    pos = skeleton.joint_positions(skeleton.rest_pose())
    ends = [j for j in range(skeleton.n_joints) if j not in skeleton.parents] or [0]
    scores = []
    for axis in AXES:
        h = pos @ axis_vector(axis)
        span = max(float(np.ptp(h)), 1e-9)
        feet = int(np.sum(h[ends] <= h.min() + FOOT_BAND * span))
        lifted = (h[0] - h.min()) / span  # the root stands above the feet
        scores.append((feet + lifted, axis))
    scores.sort(reverse=True)
    (best, up), runner_up = scores[0], scores[1]
    reasons = []
    if best - runner_up[0] < 0.5 and runner_up[1][1] != up[1]:
        reasons.append(f"{up} and {runner_up[1]} both look up")
    up_i = "XYZ".index(up[1])
    flat = [i for i in range(3) if i != up_i]
    along = max(flat, key=lambda i: np.ptp(pos[:, i]))
    side = min(flat, key=lambda i: np.ptp(pos[:, i]))
    if np.ptp(pos[:, side]) > 0.8 * np.ptp(pos[:, along]):
        reasons.append("the rig is about as wide as it is long")
    heads = [j for j, joint in enumerate(skeleton.joints)
             if any(w in joint.name.lower() for w in HEAD_WORDS)]
    h = pos @ axis_vector(up)
    head = heads[0] if heads else max(ends, key=lambda j: h[j])
    lead = pos[head, along] - pos[0, along]
    if abs(lead) < 0.1 * max(np.ptp(pos[:, along]), 1e-9):
        reasons.append("its head is not clearly ahead of its root")
    forward = ("+" if lead >= 0 else "-") + "XYZ"[along]
    return RigAxes(up, forward, bool(reasons), "; ".join(reasons))


def reoriented(skeleton: Skeleton, *, up: str, forward: str) -> Skeleton:
    """``skeleton`` turned so that ``up`` becomes +Y and ``forward`` +X, standing on the ground.

    Every offset is turned (a BVH rig's joint frames are the world's at rest, so the rest
    pose turns as a whole); the root is put above the origin with its lowest joint at y = 0.
    The channels keep their names, now about Gait Studio's axes.

    Raises
    ------
    GaitInputError
        ``up`` and ``forward`` on the same axis, or an unknown axis.
    """
    u, f = axis_vector(up), axis_vector(forward)
    if abs(u @ f) > 0.5:
        raise GaitInputError(f"up ({up}) and forward ({forward}) must be different axes")
    turn = np.stack([f, u, np.cross(f, u)])  # rows: the new X, Y, Z in the file's frame
    offsets = skeleton.offsets @ turn.T
    joints = [replace(j, offset=tuple(float(v) for v in o))
              for j, o in zip(skeleton.joints, offsets)]
    turned = Skeleton(name=skeleton.name, joints=tuple(joints))
    pos = turned.joint_positions(turned.rest_pose())
    root = (0.0, float(pos[0, 1] - pos[:, 1].min()), 0.0)
    joints[0] = replace(joints[0], offset=root)
    return Skeleton(name=skeleton.name, joints=tuple(joints))
