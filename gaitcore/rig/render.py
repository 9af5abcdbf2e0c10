"""Headless side-view renders of a skeleton drawn as ellipsoids (paper Section 4, Figure 2).

One pyrender ``OffscreenRenderer`` and one scene are built per clip. Bones are instances of
one unit icosphere grouped by colour: each group is a single instanced pyrender primitive
whose instance matrices (joint world transform @ ellipsoid shape) are refreshed every frame.
A frame thus costs one draw call per colour (7 for the horse) instead of one per bone (40);
on a CPU rasterizer the Python overhead per draw call dominates, so this is what brings the
renderer near 100 frames/s at 320x240 (see ``benchmarks/bench_synth.py``). The camera is
orthographic, on +Z looking along -Z (image plane XY, X to the right, Y up); it follows the
animal horizontally (X) and keeps the ground fixed, so vertical motion shows in the images.
``yaw_deg`` and ``elevation_deg`` turn it about the animal for robustness tests.

Needs an OpenGL context: set ``PYOPENGL_PLATFORM=egl`` before the first OpenGL import on a
machine without a display.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report
from gaitcore.rig.skeleton import Skeleton

BACKGROUND = (0.78, 0.84, 0.90)
FAR_SIDE_SHADE = 0.7
"""Colour factor for left-side (-Z, far from the camera) bones, so the legs read apart."""
AMBIENT = 0.4
"""Shading is baked into vertex colours (ambient + a headlight along each ellipsoid's lateral
axis, which is the viewing axis Z for bones in the sagittal plane) and drawn without lighting
(pyrender's FLAT mode): the physically lit shader costs about 4x more on a CPU rasterizer."""
DEFAULT_VIEW_HEIGHT_M = 2.9
"""World height covered by the image (orthographic): a 1.55 m horse with its head up fills
about two thirds of it, and a galloping horse's reach stays inside a 4:3 frame."""


class SkeletonRenderer:
    """Render poses of one skeleton, reusing a single OpenGL context and scene.

    Use as a context manager, or call :meth:`close`.

    Parameters
    ----------
    skeleton : Skeleton
    width, height : int
        Image size in pixels.
    yaw_deg : float
        Camera rotation about the vertical axis through the animal; positive turns the camera
        towards the animal's head (it then sees the face more).
    elevation_deg : float
        Camera height angle; positive looks down on the animal.
    view_height_m : float
        World height seen by the orthographic camera.
    subdivisions : int
        Icosphere subdivisions per ellipsoid (2 = 320 triangles).

    Raises
    ------
    GaitInputError
        Bad image size, angles out of range, or a skeleton with no bone to draw.
    """

    def __init__(self, skeleton: Skeleton, *, width: int = 320, height: int = 240,
                 yaw_deg: float = 0.0, elevation_deg: float = 0.0,
                 view_height_m: float = DEFAULT_VIEW_HEIGHT_M, subdivisions: int = 2) -> None:
        if not (16 <= width <= 4096 and 16 <= height <= 4096):
            raise GaitInputError(f"image size {width}x{height} must be within 16..4096 pixels")
        if not (-80 <= yaw_deg <= 80 and -80 <= elevation_deg <= 80):
            raise GaitInputError("yaw and elevation must be within -80..80 degrees")
        if view_height_m <= 0:
            raise GaitInputError(f"view height must be positive, got {view_height_m}")
        ellipsoids = skeleton.bone_ellipsoids()
        if not ellipsoids:
            raise GaitInputError(f"skeleton {skeleton.name!r} has no bone with 'radii' to draw")
        os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
        import pyrender
        import trimesh

        self.skeleton = skeleton
        self.width, self.height = int(width), int(height)
        self._pyrender = pyrender
        self._scene = pyrender.Scene(bg_color=(*BACKGROUND, 1.0))
        sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
        self._sphere = (np.asarray(sphere.vertices, np.float32),
                        np.asarray(sphere.vertex_normals, np.float32),
                        np.asarray(sphere.faces, np.uint32))
        light = np.clip(self._sphere[1][:, 2], 0.0, 1.0)  # headlight: the lateral axis
        groups: dict[tuple, list] = {}
        for e in ellipsoids:
            far = skeleton.joints[e.child].side == "L"
            groups.setdefault((tuple(e.color), far), []).append(e)
        self._groups = []  # (joint indices, unit-sphere-to-joint transforms, vertex colours)
        for (color, far), members in groups.items():
            shade = (AMBIENT + (1 - AMBIENT) * light) * (FAR_SIDE_SHADE if far else 1.0)
            rgba = np.column_stack([np.outer(shade, color), np.ones_like(shade)])
            local = np.zeros((len(members), 4, 4))
            for i, e in enumerate(members):
                local[i, :3, :3] = e.axes * e.radii
                local[i, :3, 3] = e.center
                local[i, 3, 3] = 1.0
            self._groups.append((np.array([e.joint for e in members]), local,
                                 np.clip(rgba, 0, 1).astype(np.float32)))
        self._mesh_nodes: list = []

        rest = skeleton.joint_positions(skeleton.rest_pose())
        root0 = rest[0]
        lo, hi = rest.min(axis=0), rest.max(axis=0)
        self._follow_dx = 0.5 * (lo[0] + hi[0]) - root0[0]
        self._target_y = 0.5 * view_height_m - 0.12 * view_height_m  # ground 12% above bottom
        ymag = 0.5 * view_height_m
        camera = pyrender.OrthographicCamera(xmag=ymag * width / height, ymag=ymag,
                                             znear=0.05, zfar=20.0)
        yaw, elev = np.radians(yaw_deg), np.radians(elevation_deg)
        direction = np.array([np.sin(yaw) * np.cos(elev), np.sin(elev),
                              np.cos(yaw) * np.cos(elev)])  # from the target to the camera
        self._cam_offset = 8.0 * direction
        self._cam_rot = _look_rotation(-direction)
        self._cam_node = self._scene.add(camera, pose=np.eye(4))
        self._renderer = pyrender.OffscreenRenderer(self.width, self.height)

    def __enter__(self) -> SkeletonRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the OpenGL context."""
        if getattr(self, "_renderer", None) is not None:
            self._renderer.delete()
            self._renderer = None

    def render(self, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Render one pose.

        Parameters
        ----------
        pose : ndarray of shape (k,)

        Returns
        -------
        rgb : ndarray of shape (H, W, 3), uint8
        mask : ndarray of shape (H, W), bool
            Pixels covered by the animal.
        """
        p = np.asarray(pose, dtype=float)
        if p.ndim != 1:
            raise GaitInputError(f"render takes one pose of shape (k,), got {p.shape}; "
                                 "use render_clip or iter_render for several")
        return self.render_world(self.skeleton.forward_kinematics(p))

    def render_world(self, world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Render one frame from joint world transforms, shape (J, 4, 4) (see :meth:`render`)."""
        if self._renderer is None:
            raise RuntimeError("renderer is closed")
        pyrender = self._pyrender
        for node in self._mesh_nodes:
            self._scene.remove_node(node)
        positions, normals, faces = self._sphere
        self._mesh_nodes = [
            self._scene.add(pyrender.Mesh([pyrender.Primitive(
                positions=positions, normals=normals, indices=faces, color_0=rgba,
                poses=world[joints] @ local)]))
            for joints, local, rgba in self._groups
        ]
        cam = np.eye(4)
        cam[:3, :3] = self._cam_rot
        target = np.array([world[0, 0, 3] + self._follow_dx, self._target_y, 0.0])
        cam[:3, 3] = target + self._cam_offset
        self._cam_node.matrix = cam
        rgb, depth = self._renderer.render(self._scene, self._pyrender.RenderFlags.FLAT)
        return rgb, depth > 0


def iter_render(skeleton: Skeleton, poses: np.ndarray, *, width: int = 320, height: int = 240,
                yaw_deg: float = 0.0, elevation_deg: float = 0.0,
                view_height_m: float = DEFAULT_VIEW_HEIGHT_M,
                progress: Progress | None = None) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Render poses one at a time (see :func:`render_clip` for the parameters).

    Yields
    ------
    rgb : ndarray of shape (H, W, 3), uint8
    mask : ndarray of shape (H, W), bool
    """
    p = np.asarray(poses, dtype=float)
    if p.ndim != 2 or p.shape[0] == 0:
        raise GaitInputError(f"poses must have shape (n, k) with n >= 1, got {p.shape}")
    world = skeleton.forward_kinematics(p)
    with SkeletonRenderer(skeleton, width=width, height=height, yaw_deg=yaw_deg,
                          elevation_deg=elevation_deg, view_height_m=view_height_m) as r:
        for i, w in enumerate(world):
            report(progress, i, len(p), f"rendering cancelled at frame {i} of {len(p)}")
            yield r.render_world(w)
    if progress is not None:
        progress(len(p), len(p))


def render_clip(skeleton: Skeleton, poses: np.ndarray, *, width: int = 320, height: int = 240,
                yaw_deg: float = 0.0, elevation_deg: float = 0.0,
                view_height_m: float = DEFAULT_VIEW_HEIGHT_M,
                progress: Progress | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Render a clip of poses from the side.

    Parameters
    ----------
    skeleton : Skeleton
    poses : ndarray of shape (n, k)
        Pose vectors laid out as ``skeleton.channel_names`` (metres, degrees).
    width, height : int
        Image size in pixels.
    yaw_deg, elevation_deg : float
        Camera offsets from the pure side view, degrees (see :class:`SkeletonRenderer`).
    view_height_m : float
        World height covered by the image.
    progress : callable (done, total) -> bool, optional
        Called before each frame; returning False cancels.

    Returns
    -------
    rgb : ndarray of shape (n, H, W, 3), uint8
        Shaded renders on a plain background.
    masks : ndarray of shape (n, H, W), bool
        True where the animal covers the pixel (depth > 0).

    Raises
    ------
    GaitInputError
        Bad poses or rendering options.
    Cancelled
        ``progress`` returned False.

    Notes
    -----
    The synthetic input of the paper's Section 4: a horse of ellipsoids seen from the side.
    Everything is kept in memory (n * H * W * 4 bytes); stream long clips with
    :func:`iter_render`.
    """
    n = np.asarray(poses).shape[0] if np.ndim(poses) == 2 else 0
    rgb = np.empty((n, height, width, 3), np.uint8)
    masks = np.empty((n, height, width), bool)
    for i, (c, m) in enumerate(iter_render(skeleton, poses, width=width, height=height,
                                           yaw_deg=yaw_deg, elevation_deg=elevation_deg,
                                           view_height_m=view_height_m, progress=progress)):
        rgb[i], masks[i] = c, m
    return rgb, masks


def _look_rotation(forward: np.ndarray) -> np.ndarray:
    """Camera rotation (columns x, y, z) looking along ``forward`` with Y up (OpenGL: -z)."""
    z = -forward / np.linalg.norm(forward)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])
