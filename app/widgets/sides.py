"""Left, right and centre: one colour each, the same in every view of the rig.

Joints carry a side (``Joint.side``: "L" on -Z, "R" on +Z facing the side camera, "C"); in a
side view the two legs of a pair project a few pixels apart, so the colour is what tells
them apart, in the 3D viewport, the joint tree and anywhere else a joint is named.
"""

from __future__ import annotations

SIDE_RGB = {"L": (40, 140, 255), "R": (240, 80, 60), "C": (215, 215, 215)}
"""Left blue, right red (as port and starboard lights, and most DCC tools), centre grey."""
SIDE_WORDS = {"L": "left", "R": "right", "C": "centre"}


def side_rgba(side: str, alpha: float = 1.0) -> tuple[float, float, float, float]:
    """The colour of ``side`` ("L", "R" or "C") as floats in [0, 1], for GL items."""
    r, g, b = SIDE_RGB.get(side, SIDE_RGB["C"])
    return (r / 255, g / 255, b / 255, alpha)
