"""OpenGL plumbing of the pose viewport: shared contexts, whether GL works, matrices, shaders.

Kept apart from the scene (:mod:`app.widgets.skeleton_gl`) so that the scene module reads as
what is drawn and how the artist handles it.
"""

from __future__ import annotations

import numpy as np
from OpenGL import GL
from pyqtgraph.opengl import shaders
from PySide6.QtCore import Qt
from PySide6.QtGui import QGuiApplication, QMatrix4x4, QOffscreenSurface, QOpenGLContext

HEADLIGHT_SHADER = shaders.ShaderProgram("gaitstudio-headlight", [
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

BLEND_KEEP_ALPHA = (GL.GL_SRC_ALPHA, GL.GL_ONE_MINUS_SRC_ALPHA, GL.GL_ONE,
                    GL.GL_ONE_MINUS_SRC_ALPHA)
"""Blend colours by alpha but leave the framebuffer opaque, so that grabbing the window (or
a compositor) does not show the desktop through translucent items."""
ON_TOP = {GL.GL_DEPTH_TEST: False, GL.GL_BLEND: True, GL.GL_CULL_FACE: False,
          "glBlendFuncSeparate": BLEND_KEEP_ALPHA}


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
