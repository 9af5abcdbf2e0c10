"""Synthetic quadruped bench: gait generators and ellipsoid renders (paper Section 4).

``generate_gait`` makes periodic joint-angle curves for a walk, trot, canter or gallop;
``render_clip`` draws them from the side with pyrender (OpenGL is only imported when a
renderer is created).
"""

from gaitcore.bench.gaits import GAITS, GaitSpec, generate_gait
from gaitcore.rig.render import SkeletonRenderer, iter_render, render_clip

__all__ = ["GAITS", "GaitSpec", "SkeletonRenderer", "generate_gait", "iter_render", "render_clip"]
