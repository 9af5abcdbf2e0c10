"""Synthetic quadruped bench: gait generators and ellipsoid renders (paper Section 4).

``generate_gait`` makes periodic joint-angle curves for a walk, trot, canter or gallop;
``render_clip`` draws them from the side with pyrender (OpenGL is only imported when a
renderer is created). The names are imported when first used (PEP 562): the ``gaitcore``
command imports this package for ``synth``'s options whatever it is asked to do.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gaitcore.bench.gaits import GAITS, GaitSpec, generate_gait
    from gaitcore.rig.render import SkeletonRenderer, iter_render, render_clip

_HOMES = {
    "GAITS": "gaitcore.bench.gaits",
    "GaitSpec": "gaitcore.bench.gaits",
    "generate_gait": "gaitcore.bench.gaits",
    "SkeletonRenderer": "gaitcore.rig.render",
    "iter_render": "gaitcore.rig.render",
    "render_clip": "gaitcore.rig.render",
}

__all__ = ["GAITS", "GaitSpec", "SkeletonRenderer", "generate_gait", "iter_render", "render_clip"]


def __getattr__(name: str) -> object:
    if name not in _HOMES:
        raise AttributeError(f"module 'gaitcore.bench' has no attribute {name!r}")
    return getattr(import_module(_HOMES[name]), name)
