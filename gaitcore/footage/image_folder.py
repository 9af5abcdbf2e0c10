"""Folders of images and of binary masks: listing in name order, sizes, reading, and writing
masks.

A folder is a clip when it holds only image files (hidden files, subfolders and the junk
files of operating systems are ignored), listed in natural name order (``f2.png`` before
``f10.png``) and all of one size; checking sizes reads only the PNG or JPEG headers where it
can. Every failure becomes a one-line ``GaitInputError`` saying which file and what to do.
"""

from __future__ import annotations

import os
import re
import struct
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.footage.threads import InOrder
from gaitcore.limits import MAX_IMAGE_PIXELS

IMAGE_SUFFIXES = frozenset(
    {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".pgm", ".ppm", ".pbm", ".jp2"}
)
# Files that operating systems and tools drop into folders; never frames, silently skipped.
_JUNK_NAMES = frozenset({"thumbs.db", "desktop.ini"})


def list_image_files(folder: Path) -> list[Path]:
    """Image files of ``folder`` sorted by name, subfolders and hidden files ignored.

    Numbers in names compare by value, so ``f2.png`` comes before ``f10.png``.

    Raises
    ------
    GaitInputError
        When the folder holds no image, or holds files that are not images.
    """
    images: list[Path] = []
    others: list[Path] = []
    for entry in sorted(folder.iterdir(), key=_natural_key):
        if entry.is_dir() or entry.name.startswith(".") or entry.name.lower() in _JUNK_NAMES:
            continue
        (images if entry.suffix.lower() in IMAGE_SUFFIXES else others).append(entry)
    if others:
        names = ", ".join(q.name for q in others[:3]) + (" ..." if len(others) > 3 else "")
        raise GaitInputError(
            f"folder {folder} holds {len(others)} file(s) that are not images ({names}): "
            "move them out so that only the frames remain"
        )
    if not images:
        raise GaitInputError(f"folder {folder} is empty: put the frames in it as image files")
    return images


def read_mask_folder(path: str | os.PathLike) -> np.ndarray:
    """Read a folder of binary masks, one image per frame, in name order.

    Parameters
    ----------
    path : str or PathLike
        Folder of images where the subject is white (any colour channel above 127) and the
        background black; palette PNGs work too.

    Returns
    -------
    ndarray of shape (n, rows, cols), bool
        The whole stack in memory (n * rows * cols bytes): for long clips prefer
        :func:`iter_mask_folder`, which ``crop_rois`` consumes one mask at a time.

    Raises
    ------
    GaitInputError
        Missing or empty folder, non-image files, unreadable images, images of different sizes.
    """
    files = _mask_files(path)
    first = _read_mask(files[0])
    out = np.empty((len(files),) + first.shape, dtype=bool)
    for k, m in enumerate(_iter_masks(files, first)):
        out[k] = m
    return out


def iter_mask_folder(path: str | os.PathLike) -> Iterator[np.ndarray]:
    """Stream the masks of a folder, as ``read_mask_folder`` does but one at a time.

    The folder's listing and the first mask are checked at once; a mask of another size
    raises ``GaitInputError`` when reached.

    Yields
    ------
    ndarray of shape (rows, cols), bool
    """
    files = _mask_files(path)
    return _iter_masks(files, _read_mask(files[0]))


def _mask_files(path: str | os.PathLike) -> list[Path]:
    p = Path(path)
    if not p.is_dir():
        raise GaitInputError(f"{p} is not a folder: give the folder that holds the mask images")
    return list_image_files(p)


def _iter_masks(files: list[Path], first: np.ndarray) -> Iterator[np.ndarray]:
    yield first
    for f in files[1:]:
        m = _read_mask(f)
        if m.shape != first.shape:
            raise GaitInputError(
                f"mask {f.name} is {m.shape[1]}x{m.shape[0]} but {files[0].name} is "
                f"{first.shape[1]}x{first.shape[0]}: all masks must have the same size"
            )
        yield m


def _natural_key(p: Path) -> list:
    return [(0, int(part), "") if part.isdigit() else (1, 0, part.lower())
            for part in re.split(r"(\d+)", p.name)]


def check_size(img: np.ndarray, size: tuple[int, int] | None, what: str) -> None:
    """Raise when ``img`` is not ``size`` (width, height) pixels; ``what`` names it."""
    if size is not None and (img.shape[1], img.shape[0]) != size:
        raise GaitInputError(
            f"{what} is {img.shape[1]}x{img.shape[0]} but the clip is {size[0]}x{size[1]}: "
            "all frames must have the same size; resize or remove it"
        )


def decoded(f: Path, flags: int) -> np.ndarray | None:
    """``cv2.imread`` of ``f``, None where it cannot be decoded; an image of more pixels than
    :data:`gaitcore.limits.MAX_IMAGE_PIXELS` is refused before it is decoded (from its
    header for PNG and JPEG, by OpenCV's own ceiling for the others)."""
    size = _header_size(f)
    too_big = (f"image {f} has more than {MAX_IMAGE_PIXELS:,} pixels, more than a frame can: "
               "is it the right file?")
    if size is not None and size[0] * size[1] > MAX_IMAGE_PIXELS:
        raise GaitInputError(too_big)
    try:
        return cv2.imread(str(f), flags)
    except cv2.error:
        raise GaitInputError(too_big) from None


def read_image(f: Path, size: tuple[int, int] | None) -> np.ndarray:
    """Decode ``f`` as BGR, checking its size against ``size`` unless None."""
    img = decoded(f, cv2.IMREAD_COLOR)
    if img is None:
        raise GaitInputError(f"image {f} cannot be read: it is damaged or not an image; "
                             "replace or remove it")
    check_size(img, size, f"image {f.name}")
    return img


def _read_mask(f: Path) -> np.ndarray:
    img = decoded(f, cv2.IMREAD_UNCHANGED)
    if img is None:
        raise GaitInputError(f"mask {f} cannot be read: it is damaged or not an image; "
                             "replace or remove it")
    if img.ndim == 3:
        img = img[:, :, :3].max(axis=2)
    if img.dtype != np.uint8:
        scale = 255.0 / np.iinfo(img.dtype).max if img.dtype.kind in "ui" else 255.0
        img = img.astype(np.float32) * scale
    return img > 127


def check_folder_sizes(files: list[Path], size: tuple[int, int]) -> None:
    """Compare every image's size with ``size``, reading only headers where possible."""
    for f in files[1:]:
        got = _header_size(f)
        if got != size:  # unusual format, or a mismatch to confirm: decode it
            img = decoded(f, cv2.IMREAD_UNCHANGED)
            if img is None:
                raise GaitInputError(f"image {f} cannot be read: it is damaged or not an image; "
                                     "replace or remove it")
            got = (int(img.shape[1]), int(img.shape[0]))
        if got != size:
            raise GaitInputError(
                f"image {f.name} is {got[0]}x{got[1]} but {files[0].name} is {size[0]}x{size[1]}: "
                "all frames of a folder must have the same size"
            )


def _header_size(f: Path) -> tuple[int, int] | None:
    """(width, height) from a PNG or JPEG header without decoding, None if not found."""
    try:
        with open(f, "rb") as fh:
            head = fh.read(26)
            if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
                w, h = struct.unpack(">II", head[16:24])
                return int(w), int(h)
            if head[:2] != b"\xff\xd8":
                return None
            fh.seek(2)
            while True:
                marker = fh.read(2)
                if len(marker) < 2 or marker[0] != 0xFF:
                    return None
                code = marker[1]
                if code == 0xFF:  # fill byte
                    fh.seek(-1, 1)
                    continue
                if code in (0xD8, 0x01) or 0xD0 <= code <= 0xD7:
                    continue
                (length,) = struct.unpack(">H", fh.read(2))
                if 0xC0 <= code <= 0xCF and code not in (0xC4, 0xC8, 0xCC):
                    _, h, w = struct.unpack(">BHH", fh.read(5))
                    return int(w), int(h)
                fh.seek(length - 2, 1)
    except (OSError, struct.error):
        return None


class MaskWriter:
    """Writes masks as ``folder/00000.png``... (named by frame) on a thread of its own, so
    that compressing one overlaps making the next; at most ``ahead`` wait.

    Use it as a context manager: leaving it waits for every mask, or, on an error, for the
    one being written only.

    Raises
    ------
    GaitInputError
        The folder cannot be made, or a mask cannot be written (from the call after it
        failed, or on leaving).
    """

    def __init__(self, folder: str | os.PathLike, ahead: int = 8) -> None:
        self.folder = Path(folder)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise GaitInputError(f"cannot make the masks folder {self.folder}: "
                                 f"{exc.strerror or exc}; choose a folder you can write "
                                 "to") from None
        self._writer = InOrder("mask-writer", ahead)

    def __call__(self, frame: int, mask: np.ndarray) -> None:
        """Write ``mask`` (rows, cols) uint8 0/255 as frame ``frame``'s PNG."""
        self._writer.submit(_write_mask, self.folder / f"{frame:05d}.png", mask)

    def __enter__(self) -> MaskWriter:
        return self

    def __exit__(self, *exc) -> None:
        self._writer.__exit__(*exc)


def _write_mask(path: Path, mask: np.ndarray) -> None:
    if not cv2.imwrite(str(path), mask):
        raise GaitInputError(f"cannot write the mask {path}: choose a folder you can write to "
                             "with room on its disk")
