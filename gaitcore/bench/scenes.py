"""Synthetic clips with a known stretch of steady gait, to measure the cycle finder.

:func:`stand_walk_turn` renders the horse standing still, then walking side-on, then turning
away from the camera while it keeps walking: the shape of a real clip where only the middle
is worth analysing, with the true ends of that middle known to the frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.bench.gaits import generate_gait
from gaitcore.errors import GaitInputError
from gaitcore.rig.render import SkeletonRenderer
from gaitcore.rig.templates import load_template


@dataclass(frozen=True)
class Scene:
    """A rendered clip and where its steady gait is.

    Attributes
    ----------
    masks : ndarray of shape (n, H, W), bool
    gait_start, gait_stop : int
        Frames ``gait_start <= f < gait_stop`` show the gait side-on.
    period_frames : float
        The gait cycle.
    """

    masks: np.ndarray
    gait_start: int
    gait_stop: int
    period_frames: float


def stand_walk_turn(*, stand: int = 45, walk: int = 110, turn: int = 40, turn_frames: int = 20,
                    turn_deg: float = 80.0, gait: str = "walk", period_frames: float = 40.0,
                    width: int = 320, height: int = 240) -> Scene:
    """The horse stands ``stand`` frames, walks ``walk`` frames side-on, then turns by
    ``turn_deg`` about the vertical over ``turn_frames`` frames (smoothly, away from the
    camera) and walks on for the rest of ``turn`` frames.

    Standing, it holds the first pose of the gait, so the gait starts without a jump.

    Raises
    ------
    GaitInputError
        For a negative or empty part, or a turn longer than the part after the walk.
    """
    if min(stand, turn) < 0 or walk < 1 or not 0 < turn_frames <= max(turn, 1):
        raise GaitInputError("stand and turn must be >= 0, walk >= 1, 0 < turn_frames <= turn")
    skeleton = load_template("horse")
    moving = generate_gait(skeleton, gait, walk + turn, period_frames=period_frames)
    poses = np.vstack([np.repeat(moving[:1], stand, axis=0), moving])
    yaw = np.zeros(len(poses))
    ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, turn_frames + 1) / turn_frames)
    yaw[stand + walk: stand + walk + turn_frames] = ramp
    yaw[stand + walk + turn_frames:] = 1.0
    yaw *= np.radians(turn_deg)
    world = skeleton.forward_kinematics(poses)
    masks = np.empty((len(poses), height, width), bool)
    with SkeletonRenderer(skeleton, width=width, height=height) as renderer:
        for i, w in enumerate(world):
            masks[i] = renderer.render_world(_yawed(w, yaw[i]))[1]
    return Scene(masks, stand, stand + walk, float(period_frames))


def _yawed(world: np.ndarray, angle: float) -> np.ndarray:
    """Joint transforms (J, 4, 4) turned by ``angle`` about the vertical through the root."""
    c, s = np.cos(angle), np.sin(angle)
    turn = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    out = world.copy()
    pivot = world[0, :3, 3]
    out[:, :3, :3] = turn @ world[:, :3, :3]
    out[:, :3, 3] = (world[:, :3, 3] - pivot) @ turn.T + pivot
    return out
