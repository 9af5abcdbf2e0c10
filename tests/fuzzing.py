"""Fuzzing of everything the product reads: the strategies and the harness the fuzz tests share.

A case is drawn by Hypothesis from a valid file the product wrote:

- :func:`json_cases`: one to three mutations of a JSON document, each at a path of the
  document: a value replaced by any JSON value (:func:`json_values`: nested lists and
  objects, huge and tiny numbers, integers of hundreds of digits, ``NaN`` and
  ``Infinity``, long and odd text), nesting up to 100,000 deep, a key deleted; the text is
  sometimes truncated;
- :func:`text_cases`: for line formats (CSV, BVH), one to three line or token mutations
  drawing on the format's own words;
- :func:`hostile_files`: the file replaced by what a path can name besides a file: a pipe,
  a folder, a loop of symbolic links, a link to ``/dev/zero``, an empty file, a sparse file
  of gigabytes; and names that are not UTF-8, hold a NUL byte or are too long.

:func:`fuzz` runs a reader on each case in a forked child under an alarm of
:data:`MAX_CASE_S` and an address-space limit :data:`MAX_CASE_BYTES` above the parent's: the
case passes when the reader returns (and ``check`` accepts what it returned) or raises
:class:`GaitInputError` with one line. A crash (a signal such as SIGSEGV), a hang, running
out of memory and any other exception fail the test with the falsifying example, which
Hypothesis prints and replays. Where there is no ``fork``, and for the application's
window, the case runs in the process.

:data:`DEFAULT_CASES` per reader in the default run, :data:`FUZZ_CASES` under ``-m fuzz``.
"""

from __future__ import annotations

import json
import os
import re
import resource
import shutil
import signal
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gaitcore.errors import GaitInputError

MAX_CASE_S = 10
MAX_CASE_BYTES = 1 << 30
DEFAULT_CASES = 300
"""Cases per reader in the default run; ``-m fuzz`` runs FUZZ_CASES."""
FUZZ_CASES = 4000
CASE_COUNTS = pytest.mark.parametrize("n_cases", [
    DEFAULT_CASES, pytest.param(FUZZ_CASES, marks=pytest.mark.fuzz)])
"""Runs a fuzz test taking ``n_cases`` twice: DEFAULT_CASES, and FUZZ_CASES under ``-m fuzz``."""

BIG_INT = "9" * 400
SPECIAL_NUMBERS = ("1e400", "-1e400", BIG_INT, "-" + BIG_INT, "NaN", "Infinity", "-Infinity",
                   "1e-400", "-0", "9007199254740993", "1e308", "-1e308", "5e-324")
NESTING_DEPTHS = (50, 1_000, 100_000)
HOSTILE_KINDS = ("pipe", "folder", "link loop", "dev zero", "empty", "sparse 3 GB",
                 "not UTF-8 name", "NUL in name", "long name")


# -- strategies --------------------------------------------------------------------------
_RAW = "@raw{}@"


def json_values() -> st.SearchStrategy:
    """Any JSON value, leaning to what breaks readers; special numbers are raw tokens."""
    scalars = st.one_of(
        st.none(), st.booleans(),
        st.integers(min_value=-(2**70), max_value=2**70),
        st.floats(allow_nan=False, allow_infinity=False),
        st.sampled_from(SPECIAL_NUMBERS).map(lambda t: _RAW.format(t)),
        st.text(max_size=20),
        st.sampled_from(("", "x" * 5000, "\x00", "../../etc/passwd", "\udcff".encode(
            "utf-8", "surrogatepass").decode("utf-8", "replace"), "1,2,3,4", "-1")),
    )
    return st.recursive(scalars, lambda kids: st.one_of(
        st.lists(kids, max_size=4), st.dictionaries(st.text(max_size=8), kids, max_size=4)),
        max_leaves=12)


def _paths(doc, prefix=()):
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc[:8]):  # the first elements stand for the rest
            yield from _paths(v, prefix + (i,))


def _parent(doc, path):
    for step in path[:-1]:
        doc = doc[step]
    return doc


@st.composite
def json_cases(draw, doc: object) -> str:
    """JSON text of ``doc`` after one to three mutations."""
    doc = json.loads(json.dumps(doc))
    raw: dict[str, str] = {}
    for m in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        kind = draw(st.sampled_from(("delete", "value", "value", "value", "nesting")))
        if kind == "delete":
            del _parent(doc, path)[path[-1]]
            continue
        if kind == "nesting":
            depth = draw(st.sampled_from(NESTING_DEPTHS))
            value = f"@{m}@"
            raw[value] = "[" * depth + "]" * depth
        else:
            value = draw(json_values())
        _parent(doc, path)[path[-1]] = value
    text = json.dumps(doc)
    for token, value in raw.items():
        text = text.replace(json.dumps(token), value)
    text = re.sub(r'"@raw(.*?)@"', r"\1", text)
    if draw(st.integers(0, 19)) == 0:
        text = text[:draw(st.integers(0, len(text)))]
    return text


@st.composite
def text_cases(draw, text: str, pieces: tuple[str, ...]) -> str:
    """``text`` after one to three line or token mutations drawing on ``pieces``."""
    lines = text.split("\n")
    piece = st.one_of(st.sampled_from(pieces), st.sampled_from(SPECIAL_NUMBERS),
                      st.text(max_size=12))
    for _ in range(draw(st.integers(1, 3))):
        if not lines:
            lines = [draw(piece)]
            continue
        i = draw(st.integers(0, len(lines) - 1))
        kind = draw(st.sampled_from(("token", "delete", "insert", "duplicate", "cut line",
                                     "splice", "truncate")))
        if kind == "token" and lines[i].split():
            tokens = lines[i].split()
            tokens[draw(st.integers(0, len(tokens) - 1))] = draw(piece)
            lines[i] = " ".join(tokens)
        elif kind == "delete":
            del lines[i]
        elif kind == "insert":
            lines.insert(i, draw(piece))
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        elif kind == "cut line":
            lines[i] = lines[i][:draw(st.integers(0, len(lines[i])))]
        elif kind == "splice":
            j = draw(st.integers(0, len(lines[i])))
            lines[i] = lines[i][:j] + draw(piece) + lines[i][j:]
        else:
            lines = lines[:draw(st.integers(0, len(lines)))]
    return "\n".join(lines)


def hostile_files() -> st.SearchStrategy[str]:
    """What a path may name instead of the file (see :func:`make_hostile`)."""
    return st.sampled_from(HOSTILE_KINDS)


def make_hostile(path: Path, kind: str) -> Path:
    """Put ``kind`` at ``path`` (or beside it, for a hostile name); return what to read."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()
    if kind == "pipe":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    elif kind == "link loop":
        path.symlink_to(path.name)
    elif kind == "dev zero":
        path.symlink_to("/dev/zero")
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "sparse 3 GB":
        with path.open("wb") as fh:
            fh.truncate(3 << 30)
    elif kind == "not UTF-8 name":
        odd = os.fsencode(path.parent) + b"/" + os.fsencode(path.stem) + b"\xff\xfe" + \
            os.fsencode(path.suffix)
        with open(odd, "w") as fh:
            fh.write("{}")
        return Path(os.fsdecode(odd))
    elif kind == "NUL in name":
        return path.with_name(path.stem + "\x00" + path.suffix)
    elif kind == "long name":
        return path.with_name("n" * 300 + path.suffix)
    return path


# -- the harness ---------------------------------------------------------------------------
@dataclass
class Escape(AssertionError):
    """A case that got out: what the reader did instead of returning or refusing."""

    what: str

    def __str__(self) -> str:
        return self.what


def run_isolated(read: Callable[[Path], object], path: Path,
                 check: Callable[[object], None] | None = None) -> None:
    """Run ``read(path)`` (then ``check`` on its result) in a forked child under the time
    and memory limits; raise :class:`Escape` on anything but success or one-line
    :class:`GaitInputError`."""
    if not hasattr(os, "fork"):
        _outcome(read, path, check)
        return
    r, w = os.pipe()
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        os.close(r)
        code = 0
        try:
            _limit()
            _outcome(read, path, check)
        except BaseException as exc:  # noqa: BLE001 - reported to the parent
            os.write(w, str(exc).encode("utf-8", "replace")[:4000])
            code = 1
        os._exit(code)
    os.close(w)
    with os.fdopen(r, "rb") as fh:
        said = fh.read().decode("utf-8", "replace")
    _, status = os.waitpid(pid, 0)
    if os.WIFSIGNALED(status):
        sig = signal.Signals(os.WTERMSIG(status)).name
        what = (f"took more than {MAX_CASE_S} s" if sig == "SIGALRM"
                else f"the process died of {sig}")
        raise Escape(f"{path.name}: {what}")
    if os.WEXITSTATUS(status) != 0:
        raise Escape(f"{path.name}: {said}")


def _limit() -> None:
    size = re.search(r"^VmSize:\s+(\d+) kB", Path("/proc/self/status").read_text(), re.M)
    if size:
        limit = (int(size.group(1)) << 10) + MAX_CASE_BYTES
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    signal.signal(signal.SIGALRM, signal.SIG_DFL)
    signal.alarm(MAX_CASE_S)


def _outcome(read: Callable[[Path], object], path: Path,
             check: Callable[[object], None] | None) -> None:
    try:
        result = read(path)
    except GaitInputError as exc:
        if "\n" in str(exc):
            raise Escape(f"a message of several lines: {exc}") from None
        return
    except Exception as exc:  # noqa: BLE001 - the point of the harness
        tail = traceback.format_exc().strip().splitlines()[-4:]
        raise Escape(f"{type(exc).__name__} escaped: {str(exc)[:300]} | "
                     + " | ".join(tail)) from None
    if check is not None:
        check(result)


def fuzz(cases: st.SearchStrategy, write: Callable[[object, Path], Path],
         read: Callable[[Path], object], folder: Path, *, n_cases: int,
         check: Callable[[object], None] | None = None, hostile: float = 0.1,
         isolate: bool = True) -> None:
    """Run ``read`` on ``n_cases`` cases drawn from ``cases``.

    Parameters
    ----------
    cases : strategy
        Draws a case (the text of a file, a list of arguments...).
    write : callable
        ``write(case, folder)`` writes the case into the empty ``folder`` and returns the
        path to read.
    read : callable
        The reader under test, run isolated (:func:`run_isolated`).
    check : callable, optional
        Asserts that what ``read`` accepted holds nothing the application would trip over.
    hostile : float
        Share of the cases where the path names a pipe, a folder, a link loop... instead.
    isolate : bool
        Run each case in a forked child; False runs it in the process (a Qt window cannot
        be forked), failing a case slower than :data:`MAX_CASE_S` once it returns.
    """
    @settings(max_examples=n_cases, deadline=None, database=None, derandomize=True,
              suppress_health_check=list(HealthCheck), print_blob=False)
    @given(case=cases, odd=st.floats(0, 1), kind=hostile_files())
    def one(case, odd, kind):
        work = folder / "case"
        if work.exists():
            shutil.rmtree(work)
        work.mkdir(parents=True)
        path = write(case, work)
        if odd < hostile:
            path = make_hostile(path, kind)
        if isolate:
            run_isolated(read, path, check)
            return
        start = time.monotonic()
        _outcome(read, path, check)
        if time.monotonic() - start > MAX_CASE_S:
            raise Escape(f"{path.name}: took more than {MAX_CASE_S} s")

    one()
