"""gaitcore: the algorithms of "Animal gaits from video" (Favreau et al., SCA 2004).

Pure numpy/scipy/OpenCV code with no GUI dependency. The GUI in ``app`` and the ``gaitcore``
command are both thin layers over this package.
"""

from gaitcore.errors import GaitInputError
from gaitcore.image_pca import ImagePCA
from gaitcore.keyimages import KeySelection, condition_curve, select_key_images
from gaitcore.rbf import RBFPoseMap
from gaitcore.spectrum import Diagnosis, Verdict, diagnose

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
