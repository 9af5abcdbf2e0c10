"""Fitting a rig to the animal: per-part length scales (legs, neck, body, head, tail).

A template rig is a horse of average build; the animal in the footage has its own
proportions. :class:`RigProportions` scales the bone lengths of each part of the body (the
offsets of the joints in that part, never the channels, so every pose stays valid), and
:func:`proportioned` returns the skeleton in those proportions: the one posed over the
footage and handed to every exporter. The root is raised or lowered so that the feet stay on
the ground.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from functools import lru_cache

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.rig.skeleton import Skeleton

PARTS = ("legs", "neck", "body", "head", "tail")
SCALE_RANGE = (0.25, 4.0)
"""Allowed per-part scales."""
_PART_WORDS = (("tail", "tail"), ("head", "head"), ("ear", "head"), ("jaw", "head"),
               ("skull", "head"), ("nose", "head"), ("neck", "neck"))
"""Substrings of a centre joint's name (lower case) that put its bone in a part; the first
that matches wins. Other centre bones are the body's; left and right bones below the trunk
are the legs'."""


@dataclass(frozen=True)
class RigProportions:
    """Length scale of each part of the rig relative to the template (1: unchanged).

    Attributes
    ----------
    legs, neck, body, head, tail : float
        Factors on the bone lengths of that part, within :data:`SCALE_RANGE`.

    Raises
    ------
    GaitInputError
        For a scale that is not a number within :data:`SCALE_RANGE`.
    """

    legs: float = 1.0
    neck: float = 1.0
    body: float = 1.0
    head: float = 1.0
    tail: float = 1.0

    def __post_init__(self) -> None:
        lo, hi = SCALE_RANGE
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and lo <= value <= hi):
                raise GaitInputError(f"the {f.name} scale must be a number from {lo:g} to {hi:g}, "
                                     f"got {value!r}")

    def scale_of(self, part: str) -> float:
        return float(getattr(self, part))

    @property
    def is_identity(self) -> bool:
        return all(self.scale_of(p) == 1.0 for p in PARTS)


def body_parts(skeleton: Skeleton) -> tuple[str, ...]:
    """The part of each joint's bone (the offset from its parent), one of :data:`PARTS`.

    Left and right joints whose parent is also left or right are the legs (the offsets that
    attach a leg to the trunk, spine to scapula or pelvis to hip, are the body's); centre
    joints are named into the tail, head or neck (:data:`_PART_WORDS`), else the body.
    The root's offset (its height) is the body's.
    """
    out = []
    for joint in skeleton.joints:
        parent = (None if joint.parent is None
                  else skeleton.joints[skeleton.joint_index(joint.parent)])
        if joint.side != "C" and parent is not None and parent.side != "C":
            out.append("legs")
            continue
        name = joint.name.lower()
        out.append(next((part for word, part in _PART_WORDS
                         if word in name and joint.side == "C"), "body"))
    return tuple(out)


def _level_legs(skeleton: Skeleton, offsets: np.ndarray) -> None:
    """Move each leg's attachment (a left or right joint under a centre one) along Y so that
    the lowest point of every leg keeps its height relative to the others' (in place)."""
    attachments = [j for j, joint in enumerate(skeleton.joints)
                   if joint.side != "C" and skeleton.parents[j] >= 0
                   and skeleton.joints[skeleton.parents[j]].side == "C"]
    if len(attachments) < 2:
        return
    below = {j: _subtree(skeleton, j) for j in attachments}
    rest = skeleton.rest_pose()
    before = skeleton.joint_positions(rest)[:, 1]
    scaled = Skeleton(name=skeleton.name, joints=tuple(
        replace(j, offset=tuple(float(v) for v in o)) for j, o in zip(skeleton.joints, offsets)))
    after = scaled.joint_positions(rest)[:, 1]
    change = np.array([before[below[j]].min() - after[below[j]].min() for j in attachments])
    offsets[attachments, 1] += change - change.mean()


def _subtree(skeleton: Skeleton, top: int) -> np.ndarray:
    """``top`` and every joint below it."""
    inside = np.zeros(skeleton.n_joints, dtype=bool)
    inside[top] = True
    for j in range(top + 1, skeleton.n_joints):  # parents come before their children
        inside[j] = skeleton.parents[j] >= 0 and inside[skeleton.parents[j]]
    return np.flatnonzero(inside)


@lru_cache(maxsize=16)
def proportioned(skeleton: Skeleton, proportions: RigProportions) -> Skeleton:
    """``skeleton`` with each part's bone lengths scaled, standing at the same ground height.

    Parameters
    ----------
    skeleton : Skeleton
    proportions : RigProportions

    Returns
    -------
    Skeleton
        ``skeleton`` itself when every scale is 1; otherwise a new skeleton with the same
        joints, channels and limits, the offsets scaled by part, each leg's attachment to
        the trunk (shoulder blade, hip) moved up or down so that every leg still reaches
        as low as the others did (fore and hind legs of different lengths shorten by
        different amounts), and the root's rest height changed so that the lowest joint of
        the rest pose stays where it was. The result is cached: the same arguments give the
        same object.

    Examples
    --------
    >>> from gaitcore.rig.templates import load_template
    >>> horse = load_template("horse")
    >>> tall = proportioned(horse, RigProportions(legs=1.2))
    >>> bool(tall.offsets[0, 1] > horse.offsets[0, 1])
    True
    """
    if proportions.is_identity:
        return skeleton
    scales = np.array([proportions.scale_of(p) for p in body_parts(skeleton)])
    offsets = skeleton.offsets * scales[:, None]
    offsets[0] = skeleton.offsets[0]
    _level_legs(skeleton, offsets)
    joints = [replace(j, offset=tuple(float(v) for v in o))
              for j, o in zip(skeleton.joints, offsets)]
    scaled = Skeleton(name=skeleton.name, joints=tuple(joints))
    ground = skeleton.joint_positions(skeleton.rest_pose())[:, 1].min()
    lift = ground - scaled.joint_positions(scaled.rest_pose())[:, 1].min()
    root = joints[0]
    joints[0] = replace(root, offset=(root.offset[0], root.offset[1] + float(lift), root.offset[2]))
    return Skeleton(name=skeleton.name, joints=tuple(joints))
