"""Seeded mutation fuzzing of file readers: the harness the fuzz tests share.

A case starts from a valid file and applies one to three random mutations: a JSON value
replaced by another type, by ``1e400``, a 400-digit integer, ``NaN``, ``Infinity`` or
nesting up to 100,000 deep, a key deleted, the text truncated; for text formats, a token or
line replaced, inserted, duplicated, cut or deleted. :func:`check_reader` runs a reader on
each case and fails on anything but success or :class:`GaitInputError` (with one line), on
a case slower than :data:`MAX_CASE_S` or peaking above :data:`MAX_CASE_BYTES` of Python
and NumPy allocations. Every case is reproducible from its seed, which failures print.

Reused by every reader's fuzz test (project, skeleton, analysis, pose CSV, BVH, scribbles):
give :func:`check_reader` a function that writes case ``seed`` and one that reads it.
"""

from __future__ import annotations

import json
import random
import shutil
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

from gaitcore.errors import GaitInputError

MAX_CASE_S = 2.0
MAX_CASE_BYTES = 200 << 20
DEFAULT_CASES = 300
"""Cases per reader in the default run (a few seconds each); ``-m fuzz`` runs FUZZ_CASES."""
FUZZ_CASES = 4000

BIG_INT = "9" * 400
SPECIAL_NUMBERS = ("1e400", "-1e400", BIG_INT, "-" + BIG_INT, "NaN", "Infinity", "-Infinity")
PLAIN_VALUES = (None, True, False, 0, -1, 1, 2.5, -7.25, "", "x", "1", [], {}, [1, 2],
                {"a": 1}, [[1, 2], [3, 4]], 2**40, -(2**40))
NESTING_DEPTHS = (50, 1_000, 100_000)


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


def mutate_json(doc: object, rng: random.Random) -> str:
    """JSON text of ``doc`` after one to three random mutations."""
    doc = json.loads(json.dumps(doc))
    raw: dict[str, str] = {}
    for m in range(rng.randint(1, 3)):
        paths = [p for p in _paths(doc) if p]
        if not paths:
            break
        path = rng.choice(paths)
        r = rng.random()
        if r < 0.1:
            del _parent(doc, path)[path[-1]]
            continue
        if r < 0.45:
            value = f"@{m}@"
            raw[value] = rng.choice(SPECIAL_NUMBERS)
        elif r < 0.9:
            value = json.loads(json.dumps(rng.choice(PLAIN_VALUES)))
        else:
            depth = rng.choice(NESTING_DEPTHS)
            value = f"@{m}@"
            raw[value] = "[" * depth + "]" * depth
        _parent(doc, path)[path[-1]] = value
    text = json.dumps(doc)
    for token, value in raw.items():
        text = text.replace(json.dumps(token), value)
    if rng.random() < 0.05:
        text = text[:rng.randint(0, len(text))]
    return text


def mutate_text(text: str, rng: random.Random, pieces: tuple[str, ...]) -> str:
    """``text`` after one to three line or token mutations drawing on ``pieces``."""
    lines = text.split("\n")
    for _ in range(rng.randint(1, 3)):
        r = rng.random()
        i = rng.randrange(len(lines)) if lines else 0
        if not lines:
            lines = [rng.choice(pieces)]
        elif r < 0.3 and lines[i].split():
            tokens = lines[i].split()
            tokens[rng.randrange(len(tokens))] = rng.choice(pieces)
            lines[i] = " ".join(tokens)
        elif r < 0.45:
            del lines[i]
        elif r < 0.6:
            lines.insert(i, rng.choice(pieces))
        elif r < 0.7:
            lines.insert(i, lines[i])
        elif r < 0.8:
            lines[i] = lines[i][:rng.randint(0, len(lines[i]))]
        elif r < 0.9:
            j = rng.randrange(len(lines[i]) + 1)
            lines[i] = lines[i][:j] + rng.choice(pieces) + lines[i][j:]
        else:
            lines = lines[:rng.randint(0, len(lines))]
    return "\n".join(lines)


def check_reader(write_case: Callable[[random.Random, Path], Path], read: Callable[[Path], object],
                 folder: Path, *, n_cases: int, seed: int = 0,
                 check: Callable[[object], None] | None = None) -> None:
    """Run ``read`` on ``n_cases`` mutated files; raise AssertionError on the first escape.

    Parameters
    ----------
    write_case : callable
        ``write_case(rng, folder)`` writes one case into the empty ``folder`` and returns
        the path to read.
    read : callable
        The reader under test.
    check : callable, optional
        Called on what ``read`` returned when it accepted a case: asserts that the value
        holds nothing the application would trip over later.
    """
    for case in range(n_cases):
        case_seed = seed * 1_000_003 + case
        work = folder / f"case{case % 2}"
        _empty(work)
        path = write_case(random.Random(case_seed), work)
        tracemalloc.start()
        start = time.perf_counter()
        result = None
        try:
            result = read(path)
        except GaitInputError as exc:
            assert "\n" not in str(exc), f"case seed {case_seed}: message of several lines"
        except Exception as exc:  # noqa: BLE001 - the point of the test
            raise AssertionError(f"case seed {case_seed}: {type(exc).__name__} escaped: "
                                 f"{str(exc)[:200]}") from exc
        finally:
            elapsed = time.perf_counter() - start
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
        assert elapsed < MAX_CASE_S, f"case seed {case_seed} took {elapsed:.1f} s"
        assert peak < MAX_CASE_BYTES, f"case seed {case_seed} peaked at {peak >> 20} MiB"
        if result is not None and check is not None:
            check(result)


def _empty(folder: Path) -> None:
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
