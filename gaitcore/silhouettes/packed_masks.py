"""Working-size masks of a whole clip kept as packed bits (what the segmentation engine of
:mod:`gaitcore.silhouettes.roto` stores for each direction it carried masks in)."""

from __future__ import annotations

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
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

    @property
    def frames(self) -> tuple[int, ...]:
        """The frames kept, in order."""
        return tuple(sorted(self._items))

    def to_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """Every kept frame as two arrays a file can hold (:meth:`from_arrays` reads them).

        Returns
        -------
        table : ndarray of shape (k, 6), float64
            One row per kept frame, in frame order: frame, x, y, w, h (the mask's bounding
            box at the working size) and confidence.
        bits : ndarray of shape (m,), uint8
            The packed bits of each box, one frame after the other.
        """
        frames = self.frames
        table = np.array([[t, *self._items[t][1:]] for t in frames], np.float64).reshape(-1, 6)
        bits = [self._items[t][0] for t in frames]
        return table, np.concatenate(bits) if bits else np.zeros(0, np.uint8)

    @classmethod
    def from_arrays(cls, shape: tuple[int, int], table: np.ndarray, bits: np.ndarray, *,
                    n_frames: int) -> PackedMasks:
        """The masks :meth:`to_arrays` gave, checked against the working size ``shape``
        (rows, cols) and a clip of ``n_frames`` frames.

        Raises
        ------
        GaitInputError
            The arrays do not describe masks of that size in that clip (a damaged file).
        """
        rows, cols = shape
        if (table.ndim != 2 or table.shape[1] != 6 or bits.ndim != 1 or bits.dtype != np.uint8
                or not np.isfinite(table).all() or (np.abs(table[:, :5]) >= 2**31).any()
                or (table[:, :5] != np.round(table[:, :5])).any()):
            raise GaitInputError("saved masks are not a table of whole-pixel boxes and packed "
                                 "bits: the file is damaged")
        t, x, y, w, h = table[:, :5].astype(np.int64).T
        conf = table[:, 5]
        sizes = (w * h + 7) // 8
        if (len(np.unique(t)) != len(t) or (t < 0).any() or (t >= n_frames).any()
                or (x < 0).any() or (y < 0).any() or (w < 0).any() or (h < 0).any()
                or (x + w > cols).any() or (y + h > rows).any()
                or (conf < 0).any() or (conf > 1).any() or sizes.sum() != len(bits)):
            raise GaitInputError(f"saved masks do not fit {n_frames} frames of {cols}x{rows} "
                                 "pixels: the file is damaged")
        out = cls(shape)
        ends = np.cumsum(sizes)
        for i, end in enumerate(ends):
            out._items[int(t[i])] = (bits[end - sizes[i] : end], int(x[i]), int(y[i]),
                                     int(w[i]), int(h[i]), float(conf[i]))
        return out
