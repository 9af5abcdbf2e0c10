"""The gait library shipped with Gait Studio: example poses of the horse template.

:func:`gait_library` samples one cycle of each synthetic gait of :mod:`gaitcore.bench.gaits`
in both leads; the library that ships (``resources/poses/horse_gaits.csv``, read by
:func:`gaitcore.rig.pose_library.shipped_library`) is :data:`SHIPPED_GAITS`, written by
:func:`write_gait_library` (``python -m gaitcore.bench.gait_library``). The canter is left
out on purpose: ``python -m benchmarks posing`` measures the drags on it, and the library's
gaits are measured leaving each one out in turn.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from gaitcore.bench.gaits import generate_gait
from gaitcore.rig.pose_library import PoseLibrary
from gaitcore.rig.skeleton import ROTATION_CHANNELS
from gaitcore.rig.templates import load_template

SHIPPED_GAITS = ("walk", "trot", "gallop")
FRAMES_PER_CYCLE = 40
DECIMALS = 2


def gait_library(gaits: Sequence[str] = SHIPPED_GAITS, *,
                 frames_per_cycle: int = FRAMES_PER_CYCLE) -> PoseLibrary:
    """One cycle of each of ``gaits`` on the horse template, left and right lead.

    Returns
    -------
    PoseLibrary
        ``2 * frames_per_cycle * len(gaits)`` poses of the template's rotation channels,
        rounded to :data:`DECIMALS` (as the shipped file stores them).

    Raises
    ------
    GaitInputError
        An unknown gait.
    """
    horse = load_template("horse")
    rotations = [i for i, c in enumerate(horse.channel_names)
                 if c.rsplit(".", 1)[1] in ROTATION_CHANNELS]
    poses = [generate_gait(horse, gait, frames_per_cycle, period_frames=frames_per_cycle,
                           lead=lead)[:, rotations]
             for gait in gaits for lead in ("left", "right")]
    return PoseLibrary(tuple(horse.channel_names[i] for i in rotations),
                       np.round(np.concatenate(poses), DECIMALS),
                       f"synthetic {', '.join(gaits)} (gaitcore.bench.gaits)")


def write_gait_library(path: Path, gaits: Sequence[str] = SHIPPED_GAITS) -> None:
    """Write :func:`gait_library` as a pose CSV (``frame`` column, one column per channel)."""
    library = gait_library(gaits)
    lines = [f"# {library.source}, both leads, {FRAMES_PER_CYCLE} frames per cycle; written "
             "by python -m gaitcore.bench.gait_library",
             ",".join(("frame", *library.channel_names))]
    lines += [",".join((str(i), *(f"{v:.{DECIMALS}f}" for v in row)))
              for i, row in enumerate(library.poses)]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    write_gait_library(Path(__file__).resolve().parents[2] / "resources" / "poses"
                       / "horse_gaits.csv")
