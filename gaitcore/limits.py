"""Ceilings on what gaitcore reads, set before any library can allocate for it, and the
memory a job may still take."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

from gaitcore.errors import GaitInputError

MAX_IMAGE_PIXELS = 100_000_000
"""The most pixels an image file may decode to (an 8K frame has 33 million): a small file
that claims more (an image bomb) is refused before OpenCV allocates it."""

MiB = 1 << 20
GiB = 1 << 30
UNCHECKED_BYTES = 64 * MiB
"""Jobs needing less are never checked: the memory left is only read for larger ones (it
costs a few reads of /proc, and every small file would pay them)."""


def free_memory() -> int | None:
    """Bytes this process may still allocate, None where nothing says.

    The smallest of: the memory the system has available, what is left under this process's
    address-space limit (``ulimit -v``), and what is left under its control group's limit (a
    container's).
    """
    bounds = []
    meminfo = _read("/proc/meminfo")
    if (found := re.search(r"^MemAvailable:\s+(\d+) kB", meminfo, re.M)):
        bounds.append(int(found.group(1)) << 10)
    size = re.search(r"^VmSize:\s+(\d+) kB", _read("/proc/self/status"), re.M)
    if (soft := _address_space_limit()) is not None and size:
        bounds.append(max(0, soft - (int(size.group(1)) << 10)))
    limit, current = _read("/sys/fs/cgroup/memory.max").strip(), _read(
        "/sys/fs/cgroup/memory.current").strip()
    if limit.isdigit() and current.isdigit():
        bounds.append(max(0, int(limit) - int(current)))
    return min(bounds) if bounds else None


def check_memory(needed: int, *, job: str, advice: Callable[[float], str]) -> None:
    """Refuse a job that needs more memory than :func:`free_memory` says is left.

    Parameters
    ----------
    needed : int
        The job's estimate, bytes.
    job : str
        What needs it ("analysing 20,000 frames of 143 × 86 pixels").
    advice : callable(fraction) -> str
        What to do, given the fraction of the job that fits.

    Raises
    ------
    GaitInputError
        With both figures and the advice.
    """
    if needed < UNCHECKED_BYTES:
        return
    free = free_memory()
    if free is not None and needed > free:
        raise GaitInputError(f"{job} needs about {_size(needed)} of memory and "
                             f"{_size(free)} is free: {advice(free / needed)}")


def _size(n: int) -> str:
    return f"{n / GiB:.1f} GB" if n >= GiB else f"{n / MiB:.0f} MB"


def _address_space_limit() -> int | None:
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        return None if soft in (resource.RLIM_INFINITY, -1) else int(soft)
    except (ImportError, OSError, ValueError):
        return None


def _read(path: str) -> str:
    try:
        return Path(path).read_text(encoding="ascii", errors="replace")
    except OSError:
        return ""
