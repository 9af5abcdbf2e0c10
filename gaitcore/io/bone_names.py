"""Bone names written to files: as in the skeleton, or Rigify style (``thigh.L``).

Blender's mirror tools (X-Axis Mirror, Symmetrize, pose flipping) and Rigify pair bones by a
``.L``/``.R`` suffix; Gait Studio skeletons mark sides with an ``L_``/``R_`` prefix and the
joint's ``side``. The Rigify naming strips the side marker from the name and appends it.
"""

from __future__ import annotations

import re

from gaitcore.errors import GaitInputError
from gaitcore.rig.skeleton import Skeleton

BONE_NAMINGS = ("as-is", "rigify")
_MARKER = re.compile(r"^(?:[LR][_.\-])|(?:[_.\-][LR])$")


def bone_names(skeleton: Skeleton, naming: str = "as-is") -> tuple[str, ...]:
    """The name to write for every joint, in joint order.

    Parameters
    ----------
    skeleton : Skeleton
    naming : {"as-is", "rigify"}
        ``rigify`` turns ``L_hip`` (side L) into ``hip.L`` and ``R_fore_toe`` into
        ``fore_toe.R``; centre joints keep their names.

    Returns
    -------
    tuple of str

    Raises
    ------
    GaitInputError
        An unknown naming, or two joints that would get the same name.

    Examples
    --------
    >>> from gaitcore.rig.templates import load_template
    >>> bone_names(load_template("horse"), "rigify")[-1]
    'hind_toe.L'
    """
    if naming not in BONE_NAMINGS:
        raise GaitInputError(f"unknown bone naming {naming!r}; "
                             f"use one of {', '.join(BONE_NAMINGS)}")
    if naming == "as-is":
        return skeleton.joint_names
    names = tuple(j.name if j.side == "C" else f"{_MARKER.sub('', j.name)}.{j.side}"
                  for j in skeleton.joints)
    if len(set(names)) != len(names):
        raise GaitInputError(f"Rigify names of skeleton {skeleton.name!r} collide; rename "
                             "its joints so that left and right differ only by L_/R_")
    return names
