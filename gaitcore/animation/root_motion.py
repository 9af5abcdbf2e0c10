"""Root motion of a gait cycle: in place, along the footage, forward at constant speed, or as
the keys say.

The RBF map interpolates every channel as a function of the silhouette's place on its loop,
which is periodic; the root's horizontal position is not (the animal travels), so the
interpolated ``root.tx`` slides forward and jumps back once per cycle. Here the horizontal
root translation is replaced: held still (in place), moved along the animal's own progress
in the footage (its track, converted to metres by the caller), or at constant velocity
(forward: a speed given, else the one fitted to the keys' own root positions). Vertical
motion (bounce) stays as interpolated: it is periodic.

Channels are found by name: the root's horizontal translations are the channels named
``<joint>.tx`` and ``<joint>.tz`` (only the root translates in a Gait Studio skeleton, with X
the direction of travel and Y up).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from gaitcore.errors import GaitInputError

ROOT_MODES = ("in-place", "footage", "forward", "as-keys")
"""``in-place``: horizontal root translation removed (held at the keys' mean); ``footage``:
along the animal's progress in the footage; ``forward``: constant velocity (given, or fitted
to the keys); ``as-keys``: the interpolated root, untouched."""
HORIZONTAL = ("tx", "tz")


def horizontal_root_channels(channel_names: Sequence[str]) -> np.ndarray:
    """Indices of the horizontal root translations (``*.tx``, ``*.tz``) among the channels.

    Returns
    -------
    ndarray of int, shape (h,)
        0 to 2 indices, X first.
    """
    found = {name.rsplit(".", 1)[-1]: i for i, name in enumerate(channel_names)
             if name.rsplit(".", 1)[-1] in HORIZONTAL}
    return np.array([found[c] for c in HORIZONTAL if c in found], dtype=int)


def key_velocity(key_poses: Mapping[int, np.ndarray], channels: np.ndarray) -> np.ndarray:
    """Mean horizontal root velocity of the keys, metres per frame.

    The least-squares line through the keys' root positions against their frame numbers:
    a key's position is the mean travel plus a small periodic surge, which averages out
    over keys spread through the cycle (the keys of a cycle are, by their selection).

    Parameters
    ----------
    key_poses : mapping of int to ndarray of shape (k,)
        Pose of every posed frame.
    channels : ndarray of int, shape (h,)
        :func:`horizontal_root_channels`.

    Returns
    -------
    ndarray of shape (h,)

    Raises
    ------
    GaitInputError
        Fewer than two posed frames.
    """
    frames = np.array(sorted(key_poses), dtype=float)
    if len(frames) < 2:
        raise GaitInputError("forward root motion needs at least two posed frames to measure "
                             "the speed; pose more keys or export in place")
    positions = np.stack([np.asarray(key_poses[int(f)], float)[channels] for f in frames])
    centred = frames - frames.mean()
    return centred @ (positions - positions.mean(axis=0)) / (centred @ centred)


def mean_speed(path: np.ndarray) -> float:
    """The least-squares slope of a progress ``path`` (metres on each frame): its mean speed,
    metres per frame."""
    return float(np.polyfit(np.arange(len(path), dtype=float), np.asarray(path, float), 1)[0])


def apply_root_motion(curves: np.ndarray, channel_names: Sequence[str], mode: str, *,
                      key_poses: Mapping[int, np.ndarray], frames: np.ndarray | None = None,
                      velocity: np.ndarray | None = None, path: np.ndarray | None = None,
                      ) -> np.ndarray:
    """Replace the horizontal root translation of ``curves`` as ``mode`` says.

    Parameters
    ----------
    curves : ndarray of shape (n, k)
        Interpolated poses.
    channel_names : sequence of str
        The k channel names.
    mode : {"in-place", "footage", "forward", "as-keys"}
    key_poses : mapping of int to ndarray of shape (k,)
        The posed frames, whose root positions give the mean position and speed.
    frames : ndarray of shape (n,), optional
        Clip frame of each row (default 0..n-1): a loop cut from frame 30 moves as frames
        30, 31... did.
    velocity : ndarray of shape (h,), optional
        ``forward``'s velocity, metres per frame (default: :func:`key_velocity`).
    path : ndarray of shape (m,), optional
        ``footage``'s progress along X on every clip frame (indexed by ``frames`` and the
        keys' frames), metres; required by that mode.

    Returns
    -------
    ndarray of shape (n, k)
        A copy; ``forward`` puts the root at ``p0 + v * frame`` where the line passes
        through the keys' mean position at their mean frame, ``footage`` at the keys' mean
        position plus the path's progress from its mean over the keys, ``in-place`` at the
        keys' mean position.

    Raises
    ------
    GaitInputError
        An unknown mode, ``forward`` with no velocity and fewer than two posed frames,
        ``footage`` without a path.
    """
    if mode not in ROOT_MODES:
        raise GaitInputError(f"unknown root motion {mode!r}; use one of {', '.join(ROOT_MODES)}")
    out = np.array(curves, dtype=float)
    channels = horizontal_root_channels(channel_names)
    if mode == "as-keys" or channels.size == 0 or not key_poses:
        return out
    t = np.arange(len(out), dtype=float) if frames is None else np.asarray(frames, float)
    keys = np.array(sorted(key_poses), dtype=float)
    mean = np.mean([np.asarray(key_poses[int(f)], float)[channels] for f in keys], axis=0)
    if mode == "in-place":
        out[:, channels] = mean
    elif mode == "footage":
        if path is None:
            raise GaitInputError("the footage shows no travel to follow (the animal stays in "
                                 "view, or the camera follows it): give a speed instead")
        along = np.asarray(path, float)
        out[:, channels] = mean
        out[:, channels[0]] += along[t.astype(int)] - along[keys.astype(int)].mean()
    else:
        v = key_velocity(key_poses, channels) if velocity is None else np.asarray(velocity)
        out[:, channels] = mean + (t - keys.mean())[:, None] * v
    return out
