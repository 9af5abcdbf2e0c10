"""Rotations in one place: the ZXY Euler convention of every joint, as matrices and quaternions.

A joint's local rotation is R = Rz(rz) @ Rx(rx) @ Ry(ry), angles in degrees (the channel order
``rz rx ry`` of :data:`gaitcore.rig.skeleton.ROTATION_CHANNELS`). BVH import converts other
orders through matrices; glTF stores quaternions; posing decomposes turned matrices back.
"""

from __future__ import annotations

import numpy as np


def euler_zxy_matrix(angles_deg: np.ndarray) -> np.ndarray:
    """Rotation matrices R = Rz(rz) @ Rx(rx) @ Ry(ry).

    Parameters
    ----------
    angles_deg : ndarray of shape (..., 3)
        (rz, rx, ry) in degrees.

    Returns
    -------
    ndarray of shape (..., 3, 3)
    """
    a = np.radians(np.asarray(angles_deg, dtype=float))
    cz, sz = np.cos(a[..., 0]), np.sin(a[..., 0])
    cx, sx = np.cos(a[..., 1]), np.sin(a[..., 1])
    cy, sy = np.cos(a[..., 2]), np.sin(a[..., 2])
    r = np.empty(a.shape[:-1] + (3, 3))
    r[..., 0, 0] = cz * cy - sz * sx * sy
    r[..., 0, 1] = -sz * cx
    r[..., 0, 2] = cz * sy + sz * sx * cy
    r[..., 1, 0] = sz * cy + cz * sx * sy
    r[..., 1, 1] = cz * cx
    r[..., 1, 2] = sz * sy - cz * sx * cy
    r[..., 2, 0] = -cx * sy
    r[..., 2, 1] = sx
    r[..., 2, 2] = cx * cy
    return r


def axis_matrix(axis: str, angles_deg: np.ndarray) -> np.ndarray:
    a = np.radians(angles_deg)
    c, s = np.cos(a), np.sin(a)
    m = np.zeros(a.shape + (3, 3))
    i, j, k = {"x": (0, 1, 2), "y": (1, 2, 0), "z": (2, 0, 1)}[axis]
    m[..., i, i] = 1.0
    m[..., j, j] = c
    m[..., k, k] = c
    m[..., j, k] = -s
    m[..., k, j] = s
    return m


def zxy_from_matrix(matrices: np.ndarray) -> np.ndarray:
    """Angles (rz, rx, ry) in degrees with ``R = Rz @ Rx @ Ry``; rx within [-90, 90].

    Parameters
    ----------
    matrices : ndarray of shape (..., 3, 3)
        Rotation matrices.

    Returns
    -------
    ndarray of shape (..., 3)
        At gimbal lock (rx = +-90) ry is 0 and rz carries the whole turn.
    """
    r = np.asarray(matrices, float)
    rx = np.arctan2(r[..., 2, 1], np.hypot(r[..., 0, 1], r[..., 1, 1]))
    locked = np.hypot(r[..., 0, 1], r[..., 1, 1]) < 1e-9
    rz = np.where(locked, np.arctan2(r[..., 1, 0], r[..., 0, 0]),
                  np.arctan2(-r[..., 0, 1], r[..., 1, 1]))
    ry = np.where(locked, 0.0, np.arctan2(-r[..., 2, 0], r[..., 2, 2]))
    return np.degrees(np.stack([rz, rx, ry], axis=-1))


def continuous_zxy(matrices: np.ndarray) -> np.ndarray:
    """ZXY angles of a sequence of rotations, without jumps between consecutive frames.

    Every rotation has two triples, (z, x, y) and (z + 180, 180 - x, y + 180), each defined up
    to turns of 360 degrees; per frame keep the one nearest the previous frame's angles. At
    gimbal lock (x = +-90) only z + y (or z - y) is defined: keep the previous y.
    """
    first = zxy_from_matrix(matrices)
    second = first + [180.0, 0.0, 180.0]
    second[:, 1] = 180.0 - first[:, 1]
    locked = np.abs(np.abs(first[:, 1]) - 90.0) < 1e-7
    out = first.copy()
    for f in range(1, len(first)):
        prev = out[f - 1]
        if locked[f]:
            sign = np.sign(first[f, 1])  # R depends on z + y (x = 90) or z - y (x = -90)
            candidates = [np.array([first[f, 0] - sign * prev[2], first[f, 1], prev[2]])]
        else:
            candidates = [first[f], second[f]]
        best = None
        for cand in candidates:
            cand = cand + 360.0 * np.round((prev - cand) / 360.0)
            if best is None or np.abs(cand - prev).sum() < np.abs(best - prev).sum() - 1e-9:
                best = cand
        out[f] = best
    return out


def quaternions_zxy(angles_deg: np.ndarray) -> np.ndarray:
    """Unit quaternions (x, y, z, w) of ``R = Rz(rz) @ Rx(rx) @ Ry(ry)``.

    Parameters
    ----------
    angles_deg : ndarray of shape (..., 3)
        (rz, rx, ry) in degrees.

    Returns
    -------
    ndarray of shape (..., 4)
        glTF order: vector part first, scalar last.
    """
    half = np.radians(np.asarray(angles_deg, float)) / 2
    cz, sz = np.cos(half[..., 0]), np.sin(half[..., 0])
    cx, sx = np.cos(half[..., 1]), np.sin(half[..., 1])
    cy, sy = np.cos(half[..., 2]), np.sin(half[..., 2])
    # (0, 0, sz, cz) * (sx, 0, 0, cx) * (0, sy, 0, cy), Hamilton products written out
    return np.stack([
        cz * sx * cy - sz * cx * sy,
        cz * cx * sy + sz * sx * cy,
        sz * cx * cy + cz * sx * sy,
        cz * cx * cy - sz * sx * sy,
    ], axis=-1)
