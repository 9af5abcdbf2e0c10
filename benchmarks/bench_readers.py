"""File reader benchmark: big rigs read in linear time (issue #15).

- ``read_bvh`` of rigs of 10,000 and 20,000 joints, all children of the root ("flat") or one
  chain ("nested"), one motion frame; and of a mocap-shaped file (100 joints, 5,000 frames).
- ``load_project`` of a project holding a 20,000-joint skeleton (flat and nested).
- Baselines in the same process: the least any reader does with the same file, that is
  reading its text and splitting it into tokens (BVH), or ``json.loads`` (project). Times
  are the best of three, as wall clock and as this process's CPU time (the steadier figure
  on a shared machine); memory is the peak of Python and NumPy allocations (tracemalloc)
  over the file's size.

Run ``python -m benchmarks readers``.
"""

from __future__ import annotations

import json
import tempfile
import time
import tracemalloc
from pathlib import Path

from benchmarks import Section
from gaitcore.io.bvh.reader import read_bvh
from gaitcore.project.document import Project
from gaitcore.project.storage import load_project, save_project
from gaitcore.rig.skeleton import Joint, Skeleton

ROOT_CHANNELS = "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"


def run() -> list[Section]:
    """All sections of this benchmark."""
    with tempfile.TemporaryDirectory() as tmp:
        return [bvh_speed(Path(tmp)), project_speed(Path(tmp))]


def bvh_text(n_joints: int, *, nested: bool, frames: int = 1) -> str:
    """A BVH rig of ``n_joints`` (a chain when ``nested``) with ``frames`` zero frames."""
    lines = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0", ROOT_CHANNELS]
    for i in range(1, n_joints):
        lines += [f"JOINT j{i}", "{", "OFFSET 0 1 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
        lines += [] if nested else ["}"]
    lines += ["}"] * (n_joints if nested else 1)
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.04"]
    lines += [" ".join(["0.000000"] * (3 * n_joints + 3))] * frames
    return "\n".join(lines) + "\n"


def _best(fn, repeat: int = 3, clock=time.perf_counter) -> float:
    times = []
    for _ in range(repeat):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return min(times)


def _peak(fn) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _row(label: str, path: Path, read, baseline) -> list[str]:
    size = path.stat().st_size
    t, base = _best(lambda: read(path)), _best(lambda: baseline(path))
    cpu = _best(lambda: read(path), clock=time.process_time)
    return [label, f"{size / 1e6:.2f}", f"{t:.3f}", f"{cpu:.3f}", f"{base:.3f}",
            f"{t / base:.0f}", f"{_peak(lambda: read(path)) / size:.0f}x"]


def _tokens(path: Path) -> int:
    return len(path.read_text().split())


def bvh_speed(folder: Path) -> Section:
    rows = []
    for n, nested, frames in ((10_000, False, 1), (20_000, False, 1), (10_000, True, 1),
                              (20_000, True, 1), (100, False, 5_000)):
        path = folder / f"rig_{n}_{nested}_{frames}.bvh"
        path.write_text(bvh_text(n, nested=nested, frames=frames))
        shape = "nested" if nested else "flat"
        rows.append(_row(f"{n:,} joints, {shape}, {frames:,} frame(s)", path, read_bvh, _tokens))
    return Section(
        "read_bvh on big rigs",
        ["file", "MB", "read_bvh s", "CPU s", "baseline s (text + split)", "ratio",
         "peak memory / file"],
        rows,
        ["Before issue #15: 10,000 flat joints 12 s, 20,000: 57 s (quadratic), about 20x the "
         "file in memory; more than about 1,000 nested joints raised RecursionError.",
         "Target: 20,000 joints in under 1 s."])


def _project_file(folder: Path, n: int, nested: bool) -> Path:
    joints = [Joint("j0", None, (0.0, 0.0, 0.0), ("tx", "ty", "tz", "rz", "rx", "ry"))]
    joints += [Joint(f"j{i}", f"j{i - 1}" if nested else "j0", (0.0, 0.1, 0.0), ("rz", "rx", "ry"))
               for i in range(1, n)]
    path = folder / f"rig_{n}_{nested}.gaitproj"
    save_project(Project(skeleton=Skeleton("big", tuple(joints))), path)
    return path


def project_speed(folder: Path) -> Section:
    rows = []
    for nested in (False, True):
        path = _project_file(folder, 20_000, nested)
        shape = "nested" if nested else "flat"
        rows.append(_row(f"20,000 joints, {shape}", path, load_project,
                         lambda p: json.loads(p.read_text())))
    return Section(
        "load_project with a 20,000-joint skeleton",
        ["project", "MB", "load_project s", "CPU s", "baseline s (json.loads)", "ratio",
         "peak memory / file"],
        rows,
        ["Before issue #15: 25 s for a nested 20,000-joint rig (quadratic hierarchy check).",
         "Target: under 2 s."])
