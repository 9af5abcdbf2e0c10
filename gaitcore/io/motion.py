"""The motion written to files: a loop or the whole clip, its root motion, its feet on the ground.

:func:`export_motion` is the one step between the interpolated curves and every exporter,
called by ``gaitcore animate`` and by the app's Export menu alike:

1. the horizontal root is taken out (:func:`gaitcore.animation.root_motion.apply_root_motion`)
   so that a loop can be cut without dragging the travel into the mismatch it spreads;
2. one loop is cut (:func:`gaitcore.animation.weights.loop_cycle`) when asked;
3. the feet are planted (:func:`gaitcore.rig.contact.clean_ground_contact`) as the animal
   travels (along its progress in the footage, else at a speed given or the keys'), across
   the loop's seam when it is a loop, where the posed frames put them when a stance holds
   one;
4. the root motion asked for goes back in: in place, along the footage, forward at constant
   speed, or as the keys interpolate it;
5. a loop gets a closing frame equal to its first (moved on by one stride when it goes
   forward), so that every format plays it round without a hitch: a glTF player blends the
   last key into the first, Blender's Cycles modifier repeats from the last key.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from gaitcore.animation.root_motion import (
    ROOT_MODES,
    apply_root_motion,
    horizontal_root_channels,
    key_velocity,
    mean_speed,
)
from gaitcore.animation.weights import loop_cycle
from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress
from gaitcore.rig.contact import ContactResult, clean_ground_contact, find_feet
from gaitcore.rig.skeleton import Skeleton

AUTO = "auto"
"""Root motion by what is exported: in place for one loop, forward for the whole clip."""


SPEED_SOURCES = ("given", "footage", "keys")
"""Where the root's speed comes from, first found first: a speed the user gave, the animal's
progress in the footage, the keys' own root positions."""


@dataclass(frozen=True, eq=False)
class ExportMotion:
    """Poses ready to write, and what was done to them.

    Attributes
    ----------
    frames : ndarray of int, shape (n,)
        Frame numbers to write: source frames of the whole clip, or 0..n-1 for a loop (its
        closing frame included).
    poses : ndarray of shape (n, k)
    root_motion : str
        The mode applied (``auto`` resolved).
    cycle_start : int or None
        First clip frame of the loop, None for the whole clip.
    contact : ContactResult or None
        The ground contact clean-up, None when it was off or there was no skeleton or feet.
    speed_m : float
        The root's mean speed along X, metres per frame (0 in place).
    speed_source : str
        One of :data:`SPEED_SOURCES`, or "" when the root does not travel.
    """

    frames: np.ndarray
    poses: np.ndarray
    root_motion: str
    cycle_start: int | None = None
    contact: ContactResult | None = None
    speed_m: float = 0.0
    speed_source: str = ""

    @property
    def warning(self) -> str | None:
        """Why the root stands still although it should travel (None when all is well)."""
        return STANDING_ROOT if self.root_motion == "forward" and not self.speed_m else None

    def summary(self) -> str:
        """One line for a status bar or the command's output."""
        what = (f"loop of {len(self.frames) - 1} frames (+1 closing) from frame "
                f"{self.cycle_start}" if self.cycle_start is not None
                else f"{len(self.frames)} frames")
        contact = self.contact.summary() if self.contact is not None else "ground contact off"
        root = f"root {self.root_motion}"
        if self.speed_source and self.root_motion in ("footage", "forward"):
            root += f" at {100 * self.speed_m:.1f} cm per frame ({SPEED_NAMES[self.speed_source]})"
        return f"{what}, {root}, {contact}"


SPEED_NAMES = {"given": "speed given", "footage": "from the footage",
               "keys": "from the keys' roots"}


def export_motion(curves: np.ndarray, channel_names: Sequence[str], *,
                  key_poses: Mapping[int, np.ndarray], skeleton: Skeleton | None = None,
                  loop: bool = False, period_frames: float | None = None,
                  root_motion: str = AUTO, ground_contact: bool = True, first_frame: int = 0,
                  travel_m: np.ndarray | None = None, speed_m: float | None = None,
                  progress: Progress | None = None) -> ExportMotion:
    """Turn interpolated curves into the motion to export.

    Parameters
    ----------
    curves : ndarray of shape (n, k)
        A pose per clip frame, columns ``channel_names``.
    channel_names : sequence of str
    key_poses : mapping of int to ndarray of shape (k,)
        The posed frames (same columns): their root positions give the speed when nothing
        else does.
    skeleton : Skeleton, optional
        Needed for the ground contact clean-up; each of its channels must be a column.
    loop : bool
        Export one gait cycle that loops, cut at ``period_frames``.
    period_frames : float, optional
        Gait period, required with ``loop``.
    root_motion : {"auto", "in-place", "footage", "forward", "as-keys"}
        ``auto``: in place for a loop; for the whole clip along the footage when
        ``travel_m`` is given, else forward.
    ground_contact : bool
        Plant the feet (needs ``skeleton``).
    first_frame : int
        Source frame of row 0 of ``curves`` (the start of the trim): the whole clip is
        numbered from it, a loop from 0.
    travel_m : ndarray of shape (n,), optional
        The animal's progress along X on each row of ``curves``, metres (its track in the
        footage at the rig's scale): what ``footage`` follows, and the speed of ``forward``
        when no speed is given.
    speed_m : float, optional
        ``forward``'s speed along X, metres per frame, over any other.
    progress : callable (done, total) -> bool, optional
        Reports the ground contact clean-up; returning False cancels.

    Returns
    -------
    ExportMotion

    Raises
    ------
    GaitInputError
        Unknown root motion, a loop without a usable period or too short a clip,
        ``footage`` without travel, curves without a channel of the skeleton.
    """
    names = tuple(channel_names)
    mode = _check(names, skeleton, root_motion, loop, travel_m)
    x = np.asarray(curves, dtype=float)
    still = apply_root_motion(x, names, "in-place", key_poses=key_poses)
    start = None
    frames = np.arange(len(x))
    if loop:
        start, still = loop_cycle(still, float("nan") if period_frames is None else period_frames)
        frames = np.arange(start, start + len(still))
    velocity, source = root_velocity(names, key_poses, travel_m=travel_m, speed_m=speed_m)
    path = travel_m if mode == "footage" and not loop else None
    contact = None
    if ground_contact and skeleton is not None and find_feet(skeleton):
        columns = [names.index(c) for c in skeleton.channel_names]
        contact = clean_ground_contact(skeleton, still[:, columns], cyclic=loop,
                                       travel_m=_travel(names, frames, velocity, path),
                                       anchors=[int(f) - frames[0] for f in key_poses
                                                if frames[0] <= f <= frames[-1]],
                                       progress=progress)
        still = still.copy()
        still[:, columns] = contact.poses
    moving = "forward" if mode == "footage" and loop else mode  # a loop goes at the mean speed
    poses = _with_root(still, x, names, moving, key_poses, frames, velocity, path)
    if loop:
        closing = poses[:1].copy()
        stride = len(still) * velocity if moving == "forward" else 0.0
        closing[0, horizontal_root_channels(names)] += stride
        poses = np.concatenate([poses, closing])
    numbered = np.arange(len(poses)) + (0 if loop else int(first_frame))
    bad = np.flatnonzero(~np.isfinite(poses).all(axis=1))
    if bad.size:
        raise GaitInputError(
            f"the animation is not a number on frame {int(numbered[bad[0]])} (and "
            f"{bad.size - 1} more): the analysis or the key poses hold values too large to "
            "compute with; run 'gaitcore analyze' again, and check the key poses")
    travels = mode in ("footage", "forward") and velocity.size
    return ExportMotion(numbered, poses, mode, start, contact,
                        float(velocity[0]) if travels else 0.0, source if travels else "")


STANDING_ROOT = ("the root does not travel: the footage shows none (the camera follows the "
                 "animal, or it stays in view) and the keys' roots stand still; give the "
                 "speed, or export in place")
"""The warning of :attr:`ExportMotion.warning`."""


def root_velocity(names: Sequence[str], key_poses: Mapping[int, np.ndarray], *,
                  travel_m: np.ndarray | None = None, speed_m: float | None = None,
                  ) -> tuple[np.ndarray, str]:
    """The root's horizontal velocity (metres per frame, X first) and where it came from
    (:data:`SPEED_SOURCES`): a speed given, else the footage's mean (the least-squares slope
    of ``travel_m``), else the keys' (zero with fewer than two keys)."""
    channels = horizontal_root_channels(names)
    velocity = np.zeros(channels.size)
    if channels.size == 0:
        return velocity, ""
    if speed_m is not None:
        velocity[0] = float(speed_m)
        return velocity, "given"
    if travel_m is not None and len(travel_m) >= 2:
        velocity[0] = mean_speed(travel_m)
        return velocity, "footage"
    if len(key_poses) >= 2:
        return key_velocity(key_poses, channels), "keys"
    return velocity, ""


def _check(names: tuple[str, ...], skeleton: Skeleton | None, root_motion: str,
           loop: bool, travel_m: np.ndarray | None) -> str:
    """The root motion to apply (``auto`` resolved), after checking the request."""
    if root_motion not in (AUTO, *ROOT_MODES):
        raise GaitInputError(f"unknown root motion {root_motion!r}; use one of "
                             f"{', '.join((AUTO, *ROOT_MODES))}")
    missing = [] if skeleton is None else sorted(set(skeleton.channel_names) - set(names))
    if missing:
        raise GaitInputError(f"the curves lack {len(missing)} channel(s) of skeleton "
                             f"{skeleton.name!r} (e.g. {missing[0]}); pose every channel")
    if root_motion == "footage" and travel_m is None:
        raise GaitInputError("the footage shows no travel to follow (the camera follows the "
                             "animal, or it stays in view): give a speed and export forward")
    if root_motion != AUTO:
        return root_motion
    if loop:
        return "in-place"
    return "footage" if travel_m is not None else "forward"


def _with_root(poses: np.ndarray, curves: np.ndarray, names: tuple[str, ...], mode: str,
               key_poses: Mapping[int, np.ndarray], frames: np.ndarray, velocity: np.ndarray,
               path: np.ndarray | None) -> np.ndarray:
    """``poses`` with the horizontal root of ``mode`` (``as-keys``: the interpolated one)."""
    if mode != "as-keys":
        return apply_root_motion(poses, names, mode, key_poses=key_poses, frames=frames,
                                 velocity=velocity, path=path)
    out = poses.copy()
    channels = horizontal_root_channels(names)
    out[:, channels] = curves[frames][:, channels]
    return out


def _travel(names: tuple[str, ...], frames: np.ndarray, velocity: np.ndarray,
            path: np.ndarray | None) -> np.ndarray:
    """World offset of each frame from the animal's travel, shape (n, 3): along ``path``
    when given, else at constant ``velocity``."""
    travel = np.zeros((len(frames), 3))
    axes = [{"tx": 0, "tz": 2}[names[i].rsplit(".", 1)[-1]]
            for i in horizontal_root_channels(names)]  # X first, as the velocity
    travel[:, axes] = frames[:, None] * velocity
    if path is not None and axes:
        travel[:, 0] = np.asarray(path, float)[frames]
    return travel
