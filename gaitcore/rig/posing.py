"""Posing a rig by hand: turning one joint about an axis seen in the viewport.

The viewport drags a joint about a world axis (the view direction); :func:`turn_joint` turns
that into the joint's own channels, within its limits.
"""

from __future__ import annotations

import numpy as np

from gaitcore.rig.rotations import euler_zxy_matrix, zxy_from_matrix
from gaitcore.rig.skeleton import ROTATION_CHANNELS, Skeleton


def turn_joint(skeleton: Skeleton, base_pose: np.ndarray, joint: int, axis: np.ndarray,
               angle_deg: float) -> np.ndarray | None:
    """``base_pose`` with ``joint`` turned by ``angle_deg`` about the world ``axis``.

    Parameters
    ----------
    skeleton : Skeleton
    base_pose : ndarray of shape (k,)
    joint : int
        Index of the joint to turn.
    axis : ndarray of shape (3,)
        World axis (any length but zero).
    angle_deg : float

    Returns
    -------
    ndarray of shape (k,) or None
        The new pose: the turned local rotation decomposed as R = Rz Rx Ry, channels the joint
        lacks dropped and the others clamped to its limits. None when the joint has no
        rotation channel.
    """
    chans = [f"{skeleton.joints[joint].name}.{c}" for c in ROTATION_CHANNELS]
    have = [c for c in chans if c in skeleton.channel_names]
    if not have:
        return None
    world = skeleton.forward_kinematics(base_pose)
    parent = skeleton.parents[joint]
    parent_rot = np.eye(3) if parent < 0 else world[parent, :3, :3]
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    t = np.radians(angle_deg)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    turn = np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k
    old = [base_pose[skeleton.channel_index(c)] if c in have else 0.0 for c in chans]
    local = euler_zxy_matrix(np.array(old))
    new = zxy_from_matrix(parent_rot.T @ turn @ parent_rot @ local)
    pose = np.array(base_pose, dtype=float)
    limits = skeleton.limits_array()
    for c, v in zip(chans, new):
        if c in have:
            i = skeleton.channel_index(c)
            pose[i] = float(np.clip(v, *limits[i]))
    return pose
