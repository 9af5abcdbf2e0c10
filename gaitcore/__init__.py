"""gaitcore: the algorithms of "Animal gaits from video" (Favreau et al., SCA 2004).

Pure numpy/scipy/OpenCV code with no GUI dependency. The GUI in ``app`` and the ``gaitcore``
command are both thin layers over this package.

The names below are imported when first used (PEP 562), not with the package: every
``gaitcore`` command imports it, and ``gaitcore segment`` needs none of them (importing them,
with scipy, was 0.35 s of its start).
"""

from __future__ import annotations

import os
from importlib import import_module
from typing import TYPE_CHECKING

from gaitcore.errors import GaitInputError
from gaitcore.limits import MAX_IMAGE_PIXELS

os.environ.setdefault("OPENCV_IO_MAX_IMAGE_PIXELS", str(MAX_IMAGE_PIXELS))

if TYPE_CHECKING:
    from gaitcore.analysis.image_pca import ImagePCA
    from gaitcore.analysis.keyimages import KeySelection, condition_curve, select_key_images
    from gaitcore.analysis.spectrum import Diagnosis, diagnose
    from gaitcore.analysis.verdict import Verdict
    from gaitcore.animation.rbf import RBFPoseMap

_HOMES = {
    "Diagnosis": "gaitcore.analysis.spectrum",
    "ImagePCA": "gaitcore.analysis.image_pca",
    "KeySelection": "gaitcore.analysis.keyimages",
    "RBFPoseMap": "gaitcore.animation.rbf",
    "Verdict": "gaitcore.analysis.verdict",
    "condition_curve": "gaitcore.analysis.keyimages",
    "diagnose": "gaitcore.analysis.spectrum",
    "select_key_images": "gaitcore.analysis.keyimages",
}

__all__ = [
    "Diagnosis",
    "GaitInputError",
    "ImagePCA",
    "KeySelection",
    "RBFPoseMap",
    "Verdict",
    "condition_curve",
    "diagnose",
    "select_key_images",
]


def __getattr__(name: str) -> object:
    if name not in _HOMES:
        raise AttributeError(f"module 'gaitcore' has no attribute {name!r}")
    return getattr(import_module(_HOMES[name]), name)
