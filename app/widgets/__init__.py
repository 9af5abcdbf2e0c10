"""Widgets of the main window. Importing the package configures pyqtgraph once.

Images are row-major (row, col) everywhere, as numpy and OpenCV index them.
"""

import os

os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")

import pyqtgraph as pg  # noqa: E402 - after choosing the binding

pg.setConfigOptions(imageAxisOrder="row-major", antialias=True, background="w", foreground="k")
