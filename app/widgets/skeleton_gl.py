"""The OpenGL scene of the pose viewport: ellipsoid bones, joints, reference plane, ground grid.

:class:`SkeletonGLView` is pyqtgraph's GL view (orbit with the left button, pan with the
middle button or Ctrl, zoom with the wheel) on a ``QOpenGLWindow``, embedded in the widgets
with ``QWidget.createWindowContainer``. Not a ``QOpenGLWidget``: with one of those in it, Qt
composites the whole main window through OpenGL at every repaint of any widget, which costs
about 35 ms per frame on a software renderer (llvmpipe) and would halve playback.

The skeleton lives in gaitcore's frame (Y up, X forward, side camera on +Z); pyqtgraph's is
Z up, so every item is drawn through :data:`Y_UP_TO_GL` (a rotation of +90 degrees about X).
Each bone is one unit-sphere mesh whose item transform carries it, so a new pose only sets
40-odd 4x4 matrices.

Joints are picked without GL picking: their positions are projected with the view's own
projection and view matrices (:meth:`SkeletonGLView.project`) and the nearest within
:data:`PICK_RADIUS_PX` wins. Pressing on a joint selects it and dragging then rotates it about
the view axis (signals); pressing elsewhere orbits as usual.
"""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph.opengl as gl
from OpenGL import GL
from pyqtgraph.opengl import shaders
from pyqtgraph.opengl.GLViewWidget import GLViewMixin
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import (
    QGuiApplication,
    QImage,
    QMatrix4x4,
    QOffscreenSurface,
    QOpenGLContext,
    QVector3D,
)
from PySide6.QtOpenGL import QOpenGLFramebufferObject, QOpenGLWindow

from gaitcore.rig.skeleton import Skeleton

PICK_RADIUS_PX = 9.0
DRAG_START_PX = 12.0
Y_UP_TO_GL = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
"""gaitcore world (Y up) -> pyqtgraph world (Z up): (x, y, z) -> (x, -z, y)."""
VIEWS = {"side": (0.0, -90.0), "front": (0.0, 0.0), "back": (0.0, 180.0), "top": (89.9, -90.0)}
"""Camera presets as (elevation, azimuth) in pyqtgraph's degrees; side = from gaitcore's +Z."""
FOV_DEG = 30.0
BACKGROUND_RGB = (62, 66, 72)
SELECTED_RGBA = (1.0, 0.55, 0.0, 1.0)
JOINT_RGBA = (0.1, 0.3, 0.9, 1.0)

_HEADLIGHT = shaders.ShaderProgram("gaitstudio-headlight", [
    shaders.VertexShader("""
        uniform mat4 u_mvp;
        uniform mat3 u_normal;
        attribute vec4 a_position;
        attribute vec3 a_normal;
        attribute vec4 a_color;
        varying vec4 v_color;
        varying vec3 v_normal;
        void main() {
            v_normal = normalize(u_normal * a_normal);
            v_color = a_color;
            gl_Position = u_mvp * a_position;
        }
    """),
    shaders.FragmentShader("""
        #ifdef GL_ES
        precision mediump float;
        #endif
        varying vec4 v_color;
        varying vec3 v_normal;
        void main() {
            float p = max(dot(normalize(v_normal), normalize(vec3(-0.3, 0.5, 1.0))), 0.0);
            gl_FragColor = vec4(min(v_color.rgb * (0.55 + 0.9 * p) + 0.06, 1.0), v_color.a);
        }
    """),
])

_ON_TOP = {GL.GL_DEPTH_TEST: False, GL.GL_BLEND: True, GL.GL_CULL_FACE: False,
           "glBlendFunc": (GL.GL_SRC_ALPHA, GL.GL_ONE_MINUS_SRC_ALPHA)}


def share_gl_resources() -> None:
    """Let every GL widget share textures and programs; call before the QApplication exists.

    pyqtgraph compiles each shader program once per process, so a second viewport (another
    window, a test, a benchmark) needs the programs of the first one's context.
    """
    from PySide6.QtCore import QCoreApplication

    QCoreApplication.setAttribute(Qt.ApplicationAttribute.AA_ShareOpenGLContexts, True)


NO_GL_WINDOW_PLATFORMS = ("offscreen", "minimal", "vnc", "linuxfb")
"""Qt platforms that cannot show GL windows (offscreen may create a context, yet not draw)."""


def opengl_available() -> bool:
    """True when this Qt platform can show the GL view (not so with ``offscreen``)."""
    global _GL_OK
    if _GL_OK is None and QGuiApplication.platformName() in NO_GL_WINDOW_PLATFORMS:
        _GL_OK = False
    if _GL_OK is None:
        context = QOpenGLContext()
        surface = QOffscreenSurface()
        surface.create()
        _GL_OK = bool(context.create() and surface.isValid() and context.makeCurrent(surface))
        if _GL_OK:
            context.doneCurrent()
    return _GL_OK


_GL_OK: bool | None = None


def qmatrix(m: np.ndarray) -> QMatrix4x4:
    """A QMatrix4x4 of the row-major 4x4 array ``m``."""
    return QMatrix4x4(*np.asarray(m, dtype=float).ravel().tolist())


def numpy_matrix(m: QMatrix4x4) -> np.ndarray:
    """The row-major 4x4 array of a QMatrix4x4 (``data()`` is column-major)."""
    return np.array(m.data(), dtype=float).reshape(4, 4).T


class SkeletonGLView(GLViewMixin, QOpenGLWindow):
    """GL scene of one skeleton, its joints and the footage behind it.

    Signals
    -------
    jointPressed(int)
        A joint was clicked (index into ``skeleton.joints``).
    jointDragged(int, float)
        While dragging from that joint: total rotation about the view axis so far, degrees
        (positive counterclockwise as seen on screen).
    dragFinished()
    """

    jointPressed = Signal(int)
    jointDragged = Signal(int, float)
    dragFinished = Signal()

    def __init__(self) -> None:
        super().__init__()
        self.frames_drawn = 0
        self._preset: tuple | None = None
        self.setBackgroundColor(BACKGROUND_RGB)
        self.opts["fov"] = FOV_DEG
        self._skeleton: Skeleton | None = None
        self._bones: list[tuple[int, np.ndarray, gl.GLMeshItem]] = []
        self._bone_child: list[int] = []
        self._colors: list[tuple[float, ...]] = []
        self._world = np.zeros((0, 4, 4))
        self._selected = -1
        self._drag: tuple[int, np.ndarray, np.ndarray | None] | None = None
        self.camera_moved = False
        self._follow_dx = 0.0
        self._sphere = gl.MeshData.sphere(rows=10, cols=16)
        self.grid = gl.GLGridItem(size=QVector3D(12, 12, 1))
        self.grid.setSpacing(0.5, 0.5, 1)
        self.grid.setColor((170, 170, 170, 110))
        self.addItem(self.grid)
        self.reference = gl.GLImageItem(np.zeros((2, 2, 4), np.uint8), smooth=True,
                                        glOptions="translucent")
        self.reference.setDepthValue(-10)  # drawn first: the skeleton stays in front
        self.addItem(self.reference)
        self.joints = gl.GLScatterPlotItem(pos=np.zeros((1, 3)), size=7, color=JOINT_RGBA,
                                           pxMode=True, glOptions=_ON_TOP)
        self.joints.setDepthValue(10)
        self.addItem(self.joints)
        self.links = gl.GLLinePlotItem(pos=np.zeros((2, 3)), mode="lines", width=1.5,
                                       color=(0.1, 0.1, 0.2, 0.6), glOptions=_ON_TOP)
        self.links.setDepthValue(9)
        self.addItem(self.links)
        self.joints.setTransform(qmatrix(Y_UP_TO_GL))
        self.links.setTransform(qmatrix(Y_UP_TO_GL))

    def devicePixelRatioF(self) -> float:  # noqa: N802 - what GLViewMixin calls on a widget
        return self.devicePixelRatio()

    def paintGL(self) -> None:  # noqa: N802 - Qt API
        self.frames_drawn += 1
        super().paintGL()

    def render_image(self) -> QImage:
        """Draw the scene now into an offscreen buffer and return it (device pixels).

        ``grabFramebuffer`` returns whatever was last presented; this is the current state.
        """
        self.makeCurrent()
        w, h = max(self.deviceWidth(), 1), max(self.deviceHeight(), 1)
        fbo = QOpenGLFramebufferObject(w, h, QOpenGLFramebufferObject.Attachment.CombinedDepthStencil)
        try:
            fbo.bind()
            GL.glViewport(0, 0, w, h)
            region = self.getViewport()
            self.paint(region=region, viewport=region)
            return fbo.toImage()
        finally:
            fbo.release()
            self.doneCurrent()

    def resizeGL(self, w: int, h: int) -> None:  # noqa: N802 - Qt API
        if self._preset is not None and not self.camera_moved:
            self.set_view(*self._preset)  # keep the preset framing until the artist orbits

    # -- scene -------------------------------------------------------------------------------
    def set_skeleton(self, skeleton: Skeleton) -> None:
        """Build one ellipsoid item per bone of ``skeleton`` (replacing the previous rig)."""
        for _, _, item in self._bones:
            self.removeItem(item)
        self._bones = []
        self._skeleton = skeleton
        for bone in skeleton.bone_ellipsoids():
            local = np.eye(4)
            local[:3, :3] = bone.axes * bone.radii
            local[:3, 3] = bone.center
            item = gl.GLMeshItem(meshdata=self._sphere, smooth=True, shader=_HEADLIGHT,
                                 color=(*bone.color, 1.0), glOptions="opaque")
            self.addItem(item)
            self._bones.append((bone.joint, local, item))
        self._bone_child = [b.child for b in skeleton.bone_ellipsoids()]
        self._colors = [(*b.color, 1.0) for b in skeleton.bone_ellipsoids()]
        self._world = skeleton.forward_kinematics(skeleton.rest_pose())
        self._selected = -1
        self._update_items()

    def set_pose(self, pose: np.ndarray) -> None:
        """Show pose vector ``pose`` of the current skeleton."""
        if self._skeleton is not None:
            self._world = self._skeleton.forward_kinematics(pose)
            self._update_items()

    def set_selected(self, joint: int) -> None:
        """Highlight joint ``joint`` (-1: none) and the bone that ends at it."""
        if joint != self._selected:
            self._selected = joint
            for (_, _, item), child, color in zip(self._bones, self._bone_child, self._colors):
                item.setColor(SELECTED_RGBA if child == joint else color)
            self._update_joints()

    def set_reference(self, rgba_xy: np.ndarray | None, transform: np.ndarray | None = None) -> None:
        """Show an image (x, y, RGBA uint8, see GLImageItem) placed by the gaitcore-frame
        ``transform`` (4x4 from image units to metres); None hides it."""
        self.reference.setVisible(rgba_xy is not None)
        if rgba_xy is not None:
            self.reference.setData(rgba_xy)
            self.place_reference(transform)

    def place_reference(self, transform: np.ndarray) -> None:
        """Move the reference image (same texture) by a new texel -> world transform."""
        self.reference.setTransform(qmatrix(Y_UP_TO_GL @ transform))

    def follow_x(self, dx: float) -> None:
        """Keep the camera on a skeleton whose root moved to ``dx`` along X (keeps any pan)."""
        centre = self.opts["center"]
        self.opts["center"] = QVector3D(centre.x() + dx - self._follow_dx, centre.y(), centre.z())
        self._follow_dx = dx
        self.update()

    def set_view(self, name: str, center_xy: tuple[float, float],
                 size_m: tuple[float, float, float]) -> None:
        """Look from a preset (``VIEWS``) at ``center_xy`` so that a box of ``size_m`` (width
        and height on screen, depth along the view) fits in the view, its near face included."""
        elevation, azimuth = VIEWS[name]
        self._preset = (name, center_xy, size_m)
        tan_x = math.tan(math.radians(self.opts["fov"]) / 2)  # pyqtgraph's fov is horizontal
        tan_y = tan_x * max(self.height(), 1) / max(self.width(), 1)
        distance = max(0.5 * size_m[0] / tan_x, 0.5 * size_m[1] / tan_y) + 0.5 * size_m[2]
        cx, cy = center_xy
        self.camera_moved = False
        self.setCameraPosition(pos=QVector3D(cx + self._follow_dx, 0.0, cy), distance=distance,
                               elevation=elevation, azimuth=azimuth)

    def _update_items(self) -> None:
        for joint, local, item in self._bones:
            item.setTransform(qmatrix(Y_UP_TO_GL @ self._world[joint] @ local))
        if self._skeleton is not None:
            pos = self._world[:, :3, 3]
            parents = self._skeleton.parents
            pairs = [(parents[j], j) for j in range(len(parents)) if parents[j] >= 0]
            self.links.setData(pos=pos[np.array(pairs).ravel()] if pairs else np.zeros((2, 3)))
        self._update_joints()

    def _update_joints(self) -> None:
        pos = self._world[:, :3, 3]
        if not len(pos):
            return
        colors = np.tile(JOINT_RGBA, (len(pos), 1))
        sizes = np.full(len(pos), 7.0)
        if 0 <= self._selected < len(pos):
            colors[self._selected] = SELECTED_RGBA
            sizes[self._selected] = 15.0
        self.joints.setData(pos=pos, color=colors, size=sizes)

    # -- picking -----------------------------------------------------------------------------
    def joint_positions(self) -> np.ndarray:
        """World positions (gaitcore frame) of the joints as shown, shape (J, 3)."""
        return self._world[:, :3, 3].copy()

    def project(self, points: np.ndarray) -> np.ndarray:
        """Widget pixel coordinates (x right, y down) of gaitcore-frame points (n, 3)."""
        w, h = max(self.width(), 1), max(self.height(), 1)
        region = (0, 0, w, h)
        m = numpy_matrix(self.projectionMatrix(region, region)) @ numpy_matrix(self.viewMatrix())
        p = np.c_[np.asarray(points, float).reshape(-1, 3), np.ones(len(points))]
        clip = (m @ Y_UP_TO_GL @ p.T).T
        ndc = clip[:, :3] / clip[:, 3:4]
        return np.column_stack([(ndc[:, 0] + 1) * 0.5 * w, (1 - ndc[:, 1]) * 0.5 * h])

    def pick(self, xy: tuple[float, float], radius_px: float = PICK_RADIUS_PX) -> int:
        """Index of the joint shown nearest to widget point ``xy`` within ``radius_px``; -1."""
        if not len(self._world):
            return -1
        d = np.hypot(*(self.project(self.joint_positions()) - np.asarray(xy, float)).T)
        best = int(np.argmin(d))
        return best if d[best] <= radius_px else -1

    def view_axis(self) -> np.ndarray:
        """Unit vector from the scene centre towards the camera, gaitcore frame."""
        cam = self.cameraPosition()
        centre = self.opts["center"]
        v = np.array([cam.x() - centre.x(), cam.y() - centre.y(), cam.z() - centre.z()])
        v = Y_UP_TO_GL[:3, :3].T @ v
        return v / (np.linalg.norm(v) or 1.0)

    # -- mouse -------------------------------------------------------------------------------
    def mousePressEvent(self, ev) -> None:  # noqa: N802 - Qt API
        pos = ev.position()
        joint = -1
        if ev.button() == Qt.MouseButton.LeftButton and not ev.modifiers():
            joint = self.pick((pos.x(), pos.y()))
        if joint < 0:
            self._drag = None
            super().mousePressEvent(ev)
            return
        self._drag = (joint, self.project(self.joint_positions()[joint:joint + 1])[0], None)
        self.jointPressed.emit(joint)
        ev.accept()

    def mouseMoveEvent(self, ev) -> None:  # noqa: N802 - Qt API
        if self._drag is None:
            self.camera_moved = self.camera_moved or ev.buttons() != Qt.MouseButton.NoButton
            super().mouseMoveEvent(ev)
            return
        joint, centre, start = self._drag
        pos = ev.position()
        b = np.array([pos.x() - centre[0], centre[1] - pos.y()])  # y up
        if start is None:  # the angle is measured from where the cursor first leaves the joint
            if np.linalg.norm(b) >= DRAG_START_PX:
                self._drag = (joint, centre, b)
            return
        angle = math.degrees(math.atan2(start[0] * b[1] - start[1] * b[0], start @ b))
        self.jointDragged.emit(joint, angle)

    def wheelEvent(self, ev) -> None:  # noqa: N802 - Qt API
        self.camera_moved = True
        super().wheelEvent(ev)

    def mouseReleaseEvent(self, ev) -> None:  # noqa: N802 - Qt API
        if self._drag is not None:
            self._drag = None
            self.dragFinished.emit()
        super().mouseReleaseEvent(ev)
