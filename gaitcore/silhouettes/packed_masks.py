"""Working-size masks of a whole clip kept as packed bits (what the segmentation engine of
:mod:`gaitcore.silhouettes.roto` stores for each direction it carried masks in)."""

from __future__ import annotations

import cv2
import numpy as np

from gaitcore.silhouettes.propagate import Cut


class PackedMasks:
    """Working-size 0/1 masks by frame, each stored as the packed bits of its bounding box
    (a 10,000-frame clip costs tens of megabytes).

    Parameters
    ----------
    shape : (rows, cols)
        The working size of every mask.
    """

    def __init__(self, shape: tuple[int, int]) -> None:
        self.shape = shape
        self._items: dict[int, tuple[np.ndarray, int, int, int, int, float]] = {}

    def put(self, t: int, cut: Cut) -> None:
        """Keep frame ``t``'s cut (its mask and confidence)."""
        x, y, w, h = cv2.boundingRect(cut.mask)
        bits = np.packbits(cut.mask[y : y + h, x : x + w] > 0, axis=None)
        self._items[t] = (bits, x, y, w, h, cut.confidence)

    def get(self, t: int) -> Cut | None:
        """Frame ``t``'s cut, or None when none was kept."""
        item = self._items.get(t)
        if item is None:
            return None
        bits, x, y, w, h, conf = item
        mask = np.zeros(self.shape, np.uint8)
        mask[y : y + h, x : x + w] = np.unpackbits(bits, count=w * h).reshape(h, w)
        return Cut(mask, conf)
