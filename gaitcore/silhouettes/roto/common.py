"""What the parts of :class:`~gaitcore.silhouettes.roto.RotoSegmentation` share: the types
of a pass's frames and of the callback of final frames, and small mask helpers."""

from __future__ import annotations

from collections.abc import Callable, Collection, Generator, Iterator

import numpy as np

OnFinal = Callable[[int, np.ndarray], None]
"""Given a frame ``(t, image)`` whose mask is final (see :meth:`RotoSegmentation.run`)."""
Framed = tuple[int, np.ndarray, np.ndarray | None]
"""A frame of a pass: ``(t, small, image)``, the source ``image`` when the pass hands it on."""

_STILL_LOOK = 6
"""The frame compared with frame 0 for a first look at whether the camera held still (the
first cut's motion reads it too: the last of ``motion_offsets``)."""


def _keeping(stream: Generator[Framed, None, None], picks: Collection[int],
             kept: dict[int, np.ndarray]) -> Iterator[Framed]:
    """``stream`` as it is, its working-size frames numbered in ``picks`` kept into ``kept``
    on the way (``stream`` closed when this is, its decoding thread stopped)."""
    try:
        for t, small, image in stream:
            if t in picks:
                kept[t] = small
            yield t, small, image
    finally:
        stream.close()


def _median_under(values: np.ndarray | None, under: np.ndarray | None) -> float | None:
    """The median of ``values`` (NaN where unknown) under the pixels ``under``; None where
    none of them is known."""
    if values is None or under is None:
        return None
    known = values[under]
    known = known[~np.isnan(known)]
    return float(np.median(known)) if known.size else None


def _union(a: np.ndarray | None, b: np.ndarray | None) -> np.ndarray | None:
    if a is None:
        return b
    return a if b is None else a | b
