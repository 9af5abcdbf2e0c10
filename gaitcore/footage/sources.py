"""Frame sources: video files, animated GIFs and folders of images (paper Section 2.2 input).

A :class:`FrameSource` gives random access to the frames of a clip, with a small bounded
cache, and streams them in order without holding the clip in memory. ``open_frames`` picks
the backend from the path; every failure to read becomes a one-line ``GaitInputError``.

A video is decoded forward once when it is opened: its length is the number of frames that
decode, whatever its header says (a header that counts more or fewer frames than the stream
holds only earns a ``note``), and the timestamp of every frame is kept so that a seek which
lands on another frame than asked is caught and completed by decoding forward.

Frames are BGR ``uint8`` arrays of shape (rows, cols, 3), numbered from 0 at the first frame
of the (possibly trimmed) clip; ``FrameSource.source_index`` maps back to the file.
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.footage.image_folder import (
    check_folder_sizes,
    check_size,
    list_image_files,
    read_image,
)
from gaitcore.footage.threads import prefetched
from gaitcore.schema import check_fps, fps_ok

# FFmpeg prints every decoding error of a damaged video on stderr (thousands of lines before
# our one-line error), and OpenCV its own "[ERROR:0@...]" lines: every failure becomes a
# GaitInputError here, so both are silenced unless the user asked for their logs.
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET, read at first open
if "OPENCV_LOG_LEVEL" not in os.environ:
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)


class _VideoReader:
    """Decoder over one ``cv2.VideoCapture`` that seeks only when it must, and checks where
    every seek landed against the timestamps found by decoding forward.

    A container's seek may land on another frame than asked (a wrong index, a header that
    undercounts), or fail; the frame's timestamp then tells where the decoder stands, and it
    decodes forward from there (or from the start) to the frame asked for.
    """

    def __init__(self, path: Path, timestamps_ms: np.ndarray | None = None) -> None:
        self.path = path
        self.cap = cv2.VideoCapture(str(path))
        if not self.cap.isOpened():
            if path.suffix.lower() == ".gif":
                raise GaitInputError(
                    f"cannot open GIF {path}: it is damaged, or this OpenCV has no FFmpeg "
                    "backend (needed for GIF); export its frames (ffmpeg -i IN.gif %05d.png) "
                    "and open the folder"
                )
            raise GaitInputError(
                f"cannot open video {path}: the file is truncated, damaged or in a container "
                "OpenCV cannot read; re-encode it (e.g. ffmpeg -i IN -c:v libx264 OUT.mp4)"
            )
        self.next_index = 0
        self.timestamps_ms = timestamps_ms
        # Seeking is checked by timestamp, so it needs distinct, increasing ones.
        self.seekable = timestamps_ms is not None and bool(np.all(np.diff(timestamps_ms) > 0))

    def scan(self) -> tuple[np.ndarray | None, np.ndarray]:
        """Decode the whole file forward from the start: (first frame, timestamp per frame)."""
        ok, first = self.cap.read()
        if not ok:
            return None, np.zeros(0)
        stamps = [self.cap.get(cv2.CAP_PROP_POS_MSEC)]
        while self.cap.grab():
            stamps.append(self.cap.get(cv2.CAP_PROP_POS_MSEC))
        self.next_index = -1
        return first, np.asarray(stamps, dtype=float)

    def read(self, index: int) -> np.ndarray | None:
        if index != self.next_index and self.seekable:
            self.cap.set(cv2.CAP_PROP_POS_FRAMES, index)
            ok, frame = self.cap.read()
            landed = self._index_at(self.cap.get(cv2.CAP_PROP_POS_MSEC)) if ok else None
            if landed == index:
                self.next_index = index + 1
                return frame
            self.next_index = -1 if landed is None or landed > index else landed + 1
        if not 0 <= self.next_index <= index:  # decode again from the start
            self.cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
            self.next_index = 0
        while self.next_index < index:
            if not self.cap.grab():
                self.next_index = -1
                return None
            self.next_index += 1
        ok, frame = self.cap.read()
        self.next_index = index + 1 if ok else -1
        return frame if ok else None

    def _index_at(self, stamp_ms: float) -> int | None:
        """The frame whose forward-decoded timestamp is ``stamp_ms`` (None: no such frame)."""
        stamps = self.timestamps_ms
        k = int(np.searchsorted(stamps, stamp_ms - 0.5))
        return k if k < len(stamps) and abs(stamps[k] - stamp_ms) <= 0.5 else None

    def close(self) -> None:
        self.cap.release()


DEFAULT_FPS = 24.0
"""Frames per second assumed when the footage does not say (image folders, GIFs): film's rate."""


class FrameSource:
    """Frames of a clip with random access, a bounded cache and streaming iteration.

    Use :func:`open_frames` to make one.

    Attributes
    ----------
    path : Path
        The video file or image folder.
    start, stop : int
        The clip is source frames ``start`` (included) to ``stop`` (excluded).
    fps : float or None
        Frame rate from the video header; None for image folders unless given.
    note : str or None
        What the user should know about how the file was read (its header promised another
        number of frames than decode), None otherwise.

    Notes
    -----
    Thread safety: ``frame`` may be called from one thread while another iterates, because
    iteration opens its own decoder.
    """

    def __init__(
        self,
        path: Path,
        *,
        files: list[Path] | None,
        n_source: int,
        size: tuple[int, int],
        fps: float | None,
        start: int,
        stop: int,
        cache_frames: int,
        timestamps_ms: np.ndarray | None = None,
        note: str | None = None,
    ) -> None:
        self.path = path
        self.note = note
        self._timestamps_ms = timestamps_ms
        self._files = files
        self.n_source = n_source
        self._size = size
        self.fps = fps
        self.start = start
        self.stop = stop
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()
        self._cache_frames = max(0, int(cache_frames))
        self._lock = threading.Lock()
        self._reader: _VideoReader | None = None

    # -- basic properties -------------------------------------------------------------
    def __len__(self) -> int:
        return self.stop - self.start

    @property
    def size(self) -> tuple[int, int]:
        """Frame size as (width, height) in pixels."""
        return self._size

    @property
    def shape(self) -> tuple[int, int, int]:
        """Shape of one frame array: (rows, cols, 3)."""
        return self._size[1], self._size[0], 3

    @property
    def is_video(self) -> bool:
        return self._files is None

    def source_index(self, i: int) -> int:
        """Index in the file or folder of clip frame ``i``."""
        return self.start + i

    def __repr__(self) -> str:
        kind = "video" if self.is_video else "image folder"
        return (
            f"FrameSource({kind} {self.path.name!r}, frames {self.start}:{self.stop}, "
            f"size {self._size[0]}x{self._size[1]}, fps {self.fps})"
        )

    # -- access -----------------------------------------------------------------------
    def frame(self, i: int) -> np.ndarray:
        """Return clip frame ``i`` (negative counts from the end).

        Returns
        -------
        ndarray of shape (rows, cols, 3), uint8
            BGR image. Treat it as read-only: it may be shared with the cache.

        Raises
        ------
        IndexError
            When ``i`` is outside the clip.
        GaitInputError
            When the frame cannot be decoded.
        """
        n = len(self)
        if not -n <= i < n:
            raise IndexError(f"frame {i} is outside the clip of {n} frames")
        i = int(i) % n
        with self._lock:
            hit = self._cache.get(i)
            if hit is not None:
                self._cache.move_to_end(i)
                return hit
            if self._files is not None:
                img = read_image(self._files[self.start + i], self._size)
            else:
                if self._reader is None:
                    self._reader = _VideoReader(self.path, self._timestamps_ms)
                img = self._decoded(self._reader, i)
            img.flags.writeable = False
            if self._cache_frames:
                self._cache[i] = img
                while len(self._cache) > self._cache_frames:
                    self._cache.popitem(last=False)
            return img

    def __getitem__(self, i: int) -> np.ndarray:
        return self.frame(i)

    def __iter__(self) -> Iterator[np.ndarray]:
        for _, img in self.iter_frames():
            yield img

    def iter_frames(
        self, start: int = 0, stop: int | None = None, *, prefetch: int = 0
    ) -> Iterator[tuple[int, np.ndarray]]:
        """Stream ``(i, frame)`` for clip frames ``start <= i < stop`` in order.

        Frames are decoded one at a time by a decoder of their own (not the random-access
        one), so memory stays constant whatever the clip length.

        Parameters
        ----------
        start, stop : int
            Clip frame range (``stop=None``: to the end).
        prefetch : int
            When positive, decode on a background thread up to this many frames ahead, so
            that decoding overlaps the caller's work (OpenCV releases the GIL).

        Raises
        ------
        GaitInputError
            When a frame cannot be decoded (truncated file).
        """
        if prefetch > 0:
            return prefetched(self._iter_frames(start, stop), prefetch)
        return self._iter_frames(start, stop)

    def _decoded(self, reader: _VideoReader, i: int) -> np.ndarray:
        """Clip frame ``i`` decoded by ``reader``, checked for its size.

        Raises
        ------
        GaitInputError
            The frame no longer decodes (the file changed or is damaged since it was opened).
        """
        img = reader.read(self.start + i)
        if img is None:
            raise GaitInputError(
                f"frame {self.start + i} of {self.path} cannot be decoded any more (it "
                "did when the file was opened): the file changed or is damaged; "
                "open it again or re-encode it"
            )
        check_size(img, self._size, f"frame {self.start + i} of {self.path}")
        return img

    def _iter_frames(self, start: int, stop: int | None) -> Iterator[tuple[int, np.ndarray]]:
        n = len(self)
        stop = n if stop is None else min(int(stop), n)
        start = max(0, int(start))
        if self._files is not None:
            for i in range(start, stop):
                yield i, read_image(self._files[self.start + i], self._size)
            return
        reader = _VideoReader(self.path, self._timestamps_ms)
        try:
            for i in range(start, stop):
                yield i, self._decoded(reader, i)
        finally:
            reader.close()

    def close(self) -> None:
        """Release the random-access decoder and empty the cache."""
        with self._lock:
            if self._reader is not None:
                self._reader.close()
                self._reader = None
            self._cache.clear()

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_frames(
    path: str | os.PathLike,
    *,
    start: int = 0,
    stop: int | None = None,
    fps: float | None = None,
    cache_frames: int = 16,
) -> FrameSource:
    """Open a video file, an animated GIF or a folder of images as a clip.

    Parameters
    ----------
    path : str or PathLike
        A video file (anything OpenCV's FFmpeg backend decodes, GIF included) or a folder of
        images (PNG, JPEG, BMP, TIFF, WebP...) read in name order.
    start, stop : int
        Trim the clip to source frames ``start <= f < stop`` (``stop=None``: to the end),
        e.g. to keep only the part showing the gait.
    fps : float, optional
        Frame rate to use instead of the file's (image folders have none).
    cache_frames : int
        How many decoded frames ``FrameSource.frame`` keeps (least recently used dropped).

    Returns
    -------
    FrameSource

    Raises
    ------
    GaitInputError
        Missing path; unreadable or undecodable file; zero frames; empty folder;
        non-image files or images of different sizes in a folder; a bad frame range; a frame
        rate outside [MIN_FPS, MAX_FPS]; a path that is neither a file nor a folder.
    """
    p = Path(path)
    if not p.exists():
        raise GaitInputError(f"{p} does not exist: give the path of a video file or image folder")
    if not (p.is_dir() or p.is_file()):
        raise GaitInputError(f"{p} is neither a video file nor a folder (a pipe or a device?): "
                             "give the path of a video file or image folder")
    if fps is not None:
        check_fps(fps, what="the frame rate")
    if p.is_dir():
        files = list_image_files(p)
        first = read_image(files[0], None)
        size = (int(first.shape[1]), int(first.shape[0]))
        check_folder_sizes(files, size)
        n_source = len(files)
        s0, s1 = _check_range(start, stop, n_source, p)
        return FrameSource(p, files=files, n_source=n_source, size=size, fps=fps,
                           start=s0, stop=s1, cache_frames=cache_frames)
    return _open_video(p, start, stop, fps, cache_frames)


def video_fps(path: str | os.PathLike) -> float | None:
    """The frame rate a video's header gives (None when it gives none), without decoding it.

    Raises
    ------
    GaitInputError
        When the file cannot be opened.
    """
    reader = _VideoReader(Path(path))
    try:
        fps = float(reader.cap.get(cv2.CAP_PROP_FPS))
    finally:
        reader.close()
    return fps if fps > 0 and np.isfinite(fps) else None


# -- helpers ---------------------------------------------------------------------------
def _open_video(p: Path, start: int, stop: int | None, fps: float | None,
                cache_frames: int) -> FrameSource:
    """Open a video by decoding it forward once: the frame count is what decodes, never what
    the header says nor what a seek to the end returns."""
    reader = _VideoReader(p)
    try:
        cap = reader.cap
        n_header = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        header_fps = float(cap.get(cv2.CAP_PROP_FPS))
        first, stamps = reader.scan()
        if first is None and n_header <= 0:
            raise GaitInputError(f"{p} holds no frames (an empty video): choose another file")
        if first is None:
            code = int(cap.get(cv2.CAP_PROP_FOURCC))
            fourcc = "".join(chr((code >> (8 * k)) & 0xFF) for k in range(4)).strip("\0 ")
            raise GaitInputError(
                f"{p} opens but none of its frames decode (codec {fourcc or 'unknown'}, or no "
                "video stream): re-encode it to H.264 or MJPEG, or export the frames as images"
            )
    finally:
        reader.close()
    n_source = len(stamps)
    note = None
    if n_header > 0 and n_header != n_source:
        note = (f"{p.name}: its header says {n_header} frames but {n_source} decode; all "
                f"{n_source} are used")
    s0, s1 = _check_range(start, stop, n_source, p)
    if fps is None and fps_ok(header_fps):
        fps = header_fps
    size = (int(first.shape[1]), int(first.shape[0]))
    return FrameSource(p, files=None, n_source=n_source, size=size, fps=fps, start=s0, stop=s1,
                       cache_frames=cache_frames, timestamps_ms=stamps, note=note)


def _check_range(start: int, stop: int | None, n: int, p: Path) -> tuple[int, int]:
    if n <= 0:
        raise GaitInputError(f"{p} holds no frames: choose another file")
    s1 = n if stop is None else int(stop)
    s0 = int(start)
    if not 0 <= s0 < s1 <= n:
        raise GaitInputError(
            f"frame range {start}:{stop} does not fit {p}, which has {n} frames: "
            f"choose 0 <= start < stop <= {n}"
        )
    return s0, s1
