"""Checked reading of the files gaitcore opens: text, JSON values and ``.npy`` arrays.

Every reader of a file a user may hand over (projects, analyses, pose tables, BVH, skeletons,
scribbles) goes through these helpers, so that whatever a file holds, the only exception
that leaves a reader is :class:`~gaitcore.errors.GaitInputError`, with one line naming the
file, the place in it and what is expected:

- :func:`read_text` refuses what is not a regular file (a FIFO would block the open, a
  folder is not a file), files larger than a bound, and undecodable bytes;
- :func:`parse_json` refuses damaged JSON, nesting deeper than the interpreter can follow
  and integers too long to convert; it returns a :class:`JsonValue`, whose accessors check
  the type, finiteness, range and size of a value at a path (``strokes[3].width_px``);
- :func:`read_npy` checks an array's header (dtype, dimensions, shape against the bytes
  present) before allocating anything, and never loads pickles.

Examples
--------
>>> doc = parse_json('{"fps": 25, "rects": [[0, 0, 4, 4]]}', what="project p.gaitproj")
>>> doc.key("fps").number(lo=0, lo_open=True)
25.0
>>> doc.key("rects").items(max_len=10)[0].integers(length=4)
(0, 0, 4, 4)
>>> doc.key("fps").boolean()
Traceback (most recent call last):
...
gaitcore.errors.GaitInputError: project p.gaitproj: fps must be true or false, got 25
"""

from __future__ import annotations

import json
import math
import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal, NoReturn, overload

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.limits import MiB, check_memory

_MAX_NPY_HEADER = 10_000
MAX_FPS = 10_000.0
"""Highest frame rate accepted anywhere (footage, projects, BVH, the command's --fps):
high-speed cameras stay below it, and 1 / MAX_FPS still prints as a plain BVH frame time."""
MIN_FPS = 0.001
"""Lowest frame rate accepted anywhere: one frame in a thousand seconds (a time-lapse);
below, periods and frame times overflow the arithmetic."""


def fps_ok(fps: float) -> bool:
    """True for a frame rate within [MIN_FPS, MAX_FPS]."""
    return math.isfinite(fps) and MIN_FPS <= fps <= MAX_FPS


def check_fps(fps: float, *, what: str) -> float:
    """``fps`` when :func:`fps_ok`, else GaitInputError naming ``what``."""
    if not fps_ok(fps):
        raise GaitInputError(f"{what} must be a number of frames per second from {MIN_FPS:g} "
                             f"to {MAX_FPS:g}, got {fps:g}")
    return float(fps)
_MISSING = object()
TEXT_MEMORY_PER_BYTE = 10
"""Memory a reader takes per byte of a text file it parses (the text, its lines or JSON
values, the numbers): an upper bound, checked by a test."""


# -- files ---------------------------------------------------------------------------------
MAX_NAME_BYTES = 255
MAX_PATH_BYTES = 4096
"""The longest file name and path accepted, bytes of UTF-8 (what Linux file systems take)."""


def check_path(path: str | os.PathLike, *, what: str) -> Path:
    """``path`` as a :class:`Path` once it is safe to hand to the file system and to the
    libraries that open files (OpenCV, FFmpeg): UTF-8, no NUL byte, names and the whole of a
    length a file system takes, no loop of symbolic links, and not a pipe, socket or device
    (which would block or never end).

    Raises
    ------
    GaitInputError
        Naming ``what`` (``--out``, ``footage``) and what is wrong with the path.
    """
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    shown = text.encode("utf-8", "backslashreplace").decode("utf-8")
    try:
        raw = text.encode("utf-8")
    except UnicodeEncodeError:
        raise GaitInputError(f"{what} {shown}: the name holds bytes that are not UTF-8 text; "
                             "rename it") from None
    if b"\0" in raw:
        raise GaitInputError(f"{what} {shown!r}: the name holds a NUL byte; give another name")
    if len(raw) > MAX_PATH_BYTES or any(len(part) > MAX_NAME_BYTES for part in raw.split(b"/")):
        raise GaitInputError(f"{what}: the name is too long ({len(raw)} bytes); shorten it")
    p = Path(text)
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        return p  # an output not yet written, or a missing input its reader names
    except OSError as exc:
        raise GaitInputError(f"{what} {shown}: {exc.strerror or exc} (a loop of symbolic "
                             "links?); give another path") from None
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        raise GaitInputError(f"{what} {shown} is a pipe, socket or device, not a file or "
                             "folder: give a file or folder")
    return p


def open_regular(path: str | os.PathLike, *, what: str):
    """Open ``path`` for binary reading, refusing anything that is not a regular file.

    The file is opened without blocking and checked with ``fstat`` on the open descriptor,
    so a FIFO or a device never blocks the caller.

    Returns
    -------
    file object opened ``"rb"`` (the caller closes it)

    Raises
    ------
    GaitInputError
        Missing, unreadable, a folder, or not a regular file.
    """
    p = Path(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(p, flags)
    except FileNotFoundError:
        raise GaitInputError(f"{what} not found: {p}; check the path") from None
    except IsADirectoryError:
        raise GaitInputError(f"{what} {p} is a folder, not a file: choose a file") from None
    except OSError as exc:
        raise GaitInputError(f"cannot read {what} {p}: {exc.strerror or exc}") from None
    except ValueError:  # a NUL byte, which no file name can hold
        raise GaitInputError(f"{what} {str(p)!r}: the name holds a NUL byte; give another "
                             "name") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        kind = "a folder" if stat.S_ISDIR(mode) else "not a regular file (a pipe or a device)"
        raise GaitInputError(f"{what} {p} is {kind}: choose a file")
    if hasattr(os, "set_blocking"):
        os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


def read_bytes(path: str | os.PathLike, *, what: str, max_bytes: int,
               memory_per_byte: int = 1) -> bytes:
    """The bytes of a regular file of at most ``max_bytes`` (GaitInputError otherwise), when
    ``memory_per_byte`` times its size is free (what its reader will take)."""
    with open_regular(path, what=what) as fh:
        size = os.fstat(fh.fileno()).st_size
        if size > max_bytes:
            raise GaitInputError(f"{what} {path} is {size / MiB:.0f} MiB, more than the "
                                 f"{max_bytes / MiB:.0f} MiB such a file can hold: is it the "
                                 "right file?")
        check_memory(size * memory_per_byte, job=f"reading {what} {path}",
                     advice=lambda _: "is it the right file?")
        try:
            data = fh.read(size)
            grew = fh.read(1)
        except OSError as exc:
            raise GaitInputError(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    if grew or len(data) != size:
        raise GaitInputError(f"{what} {path} changed while it was read: try again once it is "
                             "written")
    return data


def read_text(path: str | os.PathLike, *, what: str, max_bytes: int,
              encoding: str = "utf-8", fallback: str | None = None) -> str:
    """The text of a regular file of at most ``max_bytes``, refused up front when parsing
    it would take more memory than is free (:data:`TEXT_MEMORY_PER_BYTE`).

    Parameters
    ----------
    what : str
        What the file is, for messages ("project file", "pose file"...).
    encoding : str
        ``"utf-8-sig"`` also drops a byte-order mark.
    fallback : str, optional
        Encoding tried when ``encoding`` fails (e.g. ``"latin-1"``, which never fails).
    """
    data = read_bytes(path, what=what, max_bytes=max_bytes, memory_per_byte=TEXT_MEMORY_PER_BYTE)
    for enc in (encoding, fallback):
        if enc is None:
            continue
        try:
            return data.decode(enc)
        except UnicodeDecodeError as exc:
            error = exc
    raise GaitInputError(f"{what} {path} is not {encoding} text (byte {error.start}): it is "
                         "damaged or not the right kind of file")


# -- JSON ----------------------------------------------------------------------------------
def parse_json(text: str, *, what: str, advice: str = "") -> JsonValue:
    """Parse JSON text into a checked :class:`JsonValue`.

    ``NaN`` and ``Infinity`` (and numbers too large for a float, read as infinity) are kept
    here and refused by the accessors that want finite numbers, with their path.

    Parameters
    ----------
    what : str
        Names the document in messages: ``"project file /x/p.gaitproj"``.
    advice : str
        What to do, appended to every message ("restore it from a backup").

    Raises
    ------
    GaitInputError
        Damaged JSON, nesting too deep to follow, an integer of thousands of digits.
    """
    tail = f"; {advice}" if advice else ""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise GaitInputError(f"{what} is not valid JSON (line {exc.lineno}, column "
                             f"{exc.colno}){tail}") from None
    except RecursionError:
        raise GaitInputError(f"{what} nests lists or objects too deeply{tail}") from None
    except ValueError:  # an integer of more than sys.get_int_max_str_digits() digits
        raise GaitInputError(f"{what} holds an integer of thousands of digits{tail}") from None
    return JsonValue(value, what, advice)


def read_json(path: str | os.PathLike, *, what: str, max_bytes: int,
              advice: str = "") -> JsonValue:
    """:func:`read_text` then :func:`parse_json`; ``what`` is followed by the path."""
    text = read_text(path, what=what, max_bytes=max_bytes)
    return parse_json(text, what=f"{what} {path}", advice=advice)


def dump_json(value: Any, *, what: str, **options: Any) -> str:
    """JSON text of ``value`` (``json.dumps`` with ``options``), refusing non-finite numbers.

    JSON has no NaN or infinity; a writer that met one would write a file no reader takes.

    Raises
    ------
    GaitInputError
        Naming ``what`` and the place of the first number that is not finite
        (``clips[3].r1``).
    """
    try:
        return json.dumps(value, allow_nan=False, **options)
    except ValueError:
        raise GaitInputError(f"{what} was not written: {_first_non_finite(value)} is not a "
                             "finite number; check the inputs it came from") from None


def _first_non_finite(value: Any, path: str = "") -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return f"{path or 'the value'} ({value})"
    items: Any = (value.items() if isinstance(value, dict)
                  else enumerate(value) if isinstance(value, (list, tuple)) else ())
    for key, child in items:
        found = _first_non_finite(child, f"{path}[{key}]" if isinstance(key, int)
                                  else f"{path}.{key}" if path else str(key))
        if found:
            return found
    return ""


class JsonValue:
    """A parsed JSON value that knows where it is, with checked accessors.

    Each accessor returns a plain Python value (or more :class:`JsonValue`) when the value
    has the expected type, size and range, and raises :class:`GaitInputError` naming the
    document and the path (``settings.pinned[2]``) otherwise. The path is only spelled out
    when a message needs it, so walking a large document stays cheap.

    Parameters
    ----------
    value : object
        What ``json.loads`` gave.
    what : str
        The document, for messages.
    advice : str
        What to do, appended to messages.
    """

    __slots__ = ("value", "what", "advice", "_parent", "_step")

    def __init__(self, value: Any, what: str, advice: str = "", *,
                 _parent: JsonValue | None = None, _step: str | int = "") -> None:
        self.value = value
        self.what = what
        self.advice = advice
        self._parent = _parent
        self._step = _step

    @property
    def path(self) -> str:
        """Where the value sits in the document: ``""``, ``"strokes[3].width_px"``..."""
        steps, node = [], self
        while node._parent is not None:
            steps.append(node._step)
            node = node._parent
        out = ""
        for step in reversed(steps):
            out += f"[{step}]" if isinstance(step, int) else (f".{step}" if out else str(step))
        return out

    def fail(self, expected: str) -> GaitInputError:
        """The error for a value that is not ``expected`` ("a number from 0 to 1")."""
        place = self.path or "the document"
        tail = f"; {self.advice}" if self.advice else ""
        return GaitInputError(f"{self.what}: {place} must be {expected}, got "
                              f"{describe(self.value)}{tail}")

    def missing(self) -> GaitInputError:
        """The error for a required value that is absent."""
        tail = f"; {self.advice}" if self.advice else ""
        return GaitInputError(f"{self.what}: {self.path} is missing{tail}")

    def _child(self, value: Any, step: str | int) -> JsonValue:
        return JsonValue(value, self.what, self.advice, _parent=self, _step=step)

    # -- containers ------------------------------------------------------------------------
    def is_null(self) -> bool:
        return self.value is None

    def has(self, name: str) -> bool:
        """True when this is an object with key ``name``."""
        return isinstance(self.value, dict) and name in self.value

    def key(self, name: str, default: Any = _MISSING) -> JsonValue:
        """The value at key ``name`` of this object; ``default`` (wrapped) when absent."""
        if not isinstance(self.value, dict):
            raise self.fail("an object")
        if name not in self.value:
            if default is _MISSING:
                raise self._child(None, name).missing()
            return self._child(default, name)
        return self._child(self.value[name], name)

    def items(self, *, max_len: int, min_len: int = 0) -> list[JsonValue]:
        """The elements of this list, between ``min_len`` and ``max_len`` of them."""
        if not isinstance(self.value, list):
            raise self.fail("a list")
        if not min_len <= len(self.value) <= max_len:
            count = min_len if min_len == max_len else f"{min_len} to {max_len}"
            raise self.fail(f"a list of {count} elements")
        return [self._child(v, i) for i, v in enumerate(self.value)]

    def entries(self, *, max_len: int) -> Iterator[tuple[str, JsonValue]]:
        """``(key, value)`` pairs of this object, at most ``max_len`` of them."""
        if not isinstance(self.value, dict):
            raise self.fail("an object")
        if len(self.value) > max_len:
            raise self.fail(f"an object of at most {max_len} entries, not {len(self.value)}")
        return ((k, self._child(v, k)) for k, v in self.value.items())

    # -- scalars ---------------------------------------------------------------------------
    @overload
    def number(self, *, lo: float = ..., hi: float = ..., lo_open: bool = ...,
               optional: Literal[False] = ...) -> float: ...

    @overload
    def number(self, *, lo: float = ..., hi: float = ..., lo_open: bool = ...,
               optional: bool) -> float | None: ...

    def number(self, *, lo: float = -math.inf, hi: float = math.inf, lo_open: bool = False,
               optional: bool = False) -> float | None:
        """A finite number within [lo, hi] (or (lo, hi] with ``lo_open``); None when null
        and ``optional``."""
        v = self.value
        if optional and v is None:
            return None
        ok = isinstance(v, (int, float)) and not isinstance(v, bool)
        if ok:
            try:
                f = float(v)
            except OverflowError:  # an integer too large for a float
                ok = False
            else:
                ok = math.isfinite(f) and (lo < f if lo_open else lo <= f) and f <= hi
        if not ok:
            raise self.fail(_range_words("a number", lo, hi, lo_open)
                            + (" or null" if optional else ""))
        return f

    @overload
    def integer(self, *, lo: int, hi: int, optional: Literal[False] = ...) -> int: ...

    @overload
    def integer(self, *, lo: int, hi: int, optional: bool) -> int | None: ...

    def integer(self, *, lo: int, hi: int, optional: bool = False) -> int | None:
        """A whole number within [lo, hi] (``3`` or ``3.0``); None when null and ``optional``."""
        v = self.value
        if optional and v is None:
            return None
        ok = isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi
        if isinstance(v, float) and math.isfinite(v) and v.is_integer() and lo <= v <= hi:
            ok, v = True, int(v)
        if not ok:
            raise self.fail(_range_words("a whole number", lo, hi, False)
                            + (" or null" if optional else ""))
        return v

    def boolean(self) -> bool:
        if not isinstance(self.value, bool):
            raise self.fail("true or false")
        return self.value

    def text(self, *, max_len: int = 4096, choices: tuple[str, ...] | None = None,
             optional: bool = False) -> str | None:
        """A string of at most ``max_len`` characters, one of ``choices`` when given."""
        v = self.value
        if optional and v is None:
            return None
        if not isinstance(v, str) or len(v) > max_len:
            raise self.fail(f"a string of at most {max_len} characters")
        if choices is not None and v not in choices:
            raise self.fail("one of " + ", ".join(repr(c) for c in choices))
        return v

    # -- numeric lists ---------------------------------------------------------------------
    def integers(self, *, length: int | None = None, max_len: int = 1 << 20,
                 lo: int = -(1 << 31), hi: int = (1 << 31) - 1) -> tuple[int, ...]:
        """A list of whole numbers in [lo, hi] (exactly ``length`` of them when given)."""
        n = length if length is not None else max_len
        items = self.items(max_len=n, min_len=length or 0)
        return tuple(item.integer(lo=lo, hi=hi) for item in items)

    def floats(self, *, length: int) -> tuple[float, ...]:
        """Exactly ``length`` finite numbers, as a tuple (for short fixed-size lists)."""
        v = self.value
        if (type(v) is list and len(v) == length
                and all(type(x) is float or type(x) is int for x in v)):
            try:
                out = tuple(map(float, v))
            except OverflowError:  # an integer too large for a float
                out = ()
            if len(out) == length and all(map(math.isfinite, out)):
                return out
        return tuple(item.number() for item in self.items(min_len=length, max_len=length))

    def array(self, *, columns: int | None = None, max_rows: int = 1 << 20,
              min_rows: int = 0) -> np.ndarray:
        """A list of finite numbers as shape (n,), or of rows of ``columns`` numbers as
        shape (n, columns), float64, with ``min_rows <= n <= max_rows``."""
        rows = self.value
        if not (isinstance(rows, list) and min_rows <= len(rows) <= max_rows):
            self.items(min_len=min_rows, max_len=max_rows)  # raises with the right words
        flat = rows
        if columns is not None:
            if not all(type(r) is list and len(r) == columns for r in rows):
                for r in self.items(min_len=min_rows, max_len=max_rows):
                    r.items(min_len=columns, max_len=columns)
            flat = [x for r in rows for x in r]
        arr = None
        if all(type(x) is float or type(x) is int for x in flat):  # bool is neither
            try:
                arr = np.array(flat, dtype=np.float64)
            except OverflowError:  # an integer too large for a float
                arr = None
        if arr is None or not np.all(np.isfinite(arr)):
            self._first_bad_number(columns)
        return arr if columns is None else arr.reshape(len(rows), columns)

    def _first_bad_number(self, columns: int | None) -> NoReturn:
        """Raise for the first element that is not a finite number."""
        for row in self.items(max_len=len(self.value)):
            for cell in ([row] if columns is None else row.items(max_len=columns)):
                cell.number()
        raise self.fail("a list of finite numbers")


def _range_words(kind: str, lo: float, hi: float, lo_open: bool) -> str:
    words = ["a finite number" if kind == "a number" else kind]
    if not math.isinf(lo):
        words.append(f"{'above' if lo_open else 'from'} {_plain(lo)}")
    if not math.isinf(hi):
        words.append(f"{'up to' if math.isinf(lo) else 'to'} {_plain(hi)}")
    return " ".join(words)


def _plain(x: float) -> str:
    """``100000000`` rather than ``1e+08`` for whole bounds."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


def describe(value: Any) -> str:
    """A short description of a JSON value for a message."""
    if isinstance(value, (dict, list)):
        kind = "an object" if isinstance(value, dict) else "a list"
        return f"{kind} of {len(value)} element(s)"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**15:
        return ("an integer of "
                f"{len(str(abs(value))) if abs(value) < 10**4000 else 'thousands of'} digits")
    text = (json.dumps(value) if not isinstance(value, float) or math.isfinite(value)
            else repr(value))
    return text if len(text) <= 40 else text[:37] + "..."


# -- arrays --------------------------------------------------------------------------------
def read_npy(path: str | os.PathLike, *, what: str, kind: str, ndim: int,
             max_bytes: int) -> np.ndarray:
    """Read a ``.npy`` array after checking its header against the bytes present.

    Parameters
    ----------
    kind : str
        Allowed ``dtype.kind`` letters ("b" bool, "u" unsigned, "f" float...).
    ndim : int
        Required number of dimensions.
    max_bytes : int
        Largest array accepted.

    Raises
    ------
    GaitInputError
        Not a regular file, an empty or truncated file, a damaged header, another dtype
        or number of dimensions (object arrays, that is pickles, included), or a shape that
        the file's size does not hold.
    """
    p = Path(path)
    with open_regular(p, what=what) as fh:
        size = os.fstat(fh.fileno()).st_size
        try:
            version = np.lib.format.read_magic(fh)
            width = 2 if version == (1, 0) else 4
            length = int.from_bytes(fh.read(width), "little")  # numpy reads it all, unchecked
            if length > min(_MAX_NPY_HEADER, size):
                raise ValueError(f"a header of {length} bytes")
            fh.seek(-width, os.SEEK_CUR)
            read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                           else np.lib.format.read_array_header_2_0)
            shape, fortran, dtype = read_header(fh, max_header_size=_MAX_NPY_HEADER)
        except Exception as exc:  # noqa: BLE001 - numpy parses the header with ast and
            # tokenize, which raise SyntaxError, TokenError, ValueError... on damaged bytes
            why = " ".join(str(exc).split())[:120]
            raise GaitInputError(f"{what} {p} is damaged (not a NumPy array file: {why}); "
                                 "restore it from a backup") from None
        if dtype.hasobject or dtype.kind not in kind or len(shape) != ndim:
            raise GaitInputError(f"{what} {p} holds a {len(shape)}-D {dtype} array, not the "
                                 "expected data: it is damaged; restore it from a backup")
        count = math.prod(shape)
        nbytes = count * dtype.itemsize
        if nbytes > max_bytes or nbytes != size - fh.tell():
            raise GaitInputError(f"{what} {p} is damaged: its header declares shape {shape} "
                                 f"({nbytes} bytes) but it holds {size - fh.tell()}; restore "
                                 "it from a backup")
        flat = np.empty(count, dtype=dtype)
        got = fh.readinto(memoryview(flat.view(np.uint8)))  # no second copy of the data
    if got != nbytes:
        raise GaitInputError(f"{what} {p} is truncated; restore it from a backup")
    return flat.reshape(shape, order="F" if fortran else "C")


def is_number(text: str) -> bool:
    """Whether ``text`` reads as a number (a cell of a CSV or BVH motion line)."""
    try:
        float(text)
    except ValueError:
        return False
    return True
