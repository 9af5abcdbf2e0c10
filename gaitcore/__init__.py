"""gaitcore: the algorithms of "Animal gaits from video" (Favreau et al., SCA 2004).

Pure numpy/scipy/OpenCV code with no GUI dependency. The GUI in ``app`` and the ``gaitcore``
command are both thin layers over this package.
"""

from gaitcore.analysis.image_pca import ImagePCA
from gaitcore.analysis.keyimages import KeySelection, condition_curve, select_key_images
from gaitcore.analysis.spectrum import Diagnosis, diagnose
from gaitcore.analysis.verdict import Verdict
from gaitcore.animation.rbf import RBFPoseMap
from gaitcore.errors import GaitInputError

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
