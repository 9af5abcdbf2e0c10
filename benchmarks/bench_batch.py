"""Batch benchmark: ``gaitcore batch`` on 2 worker processes against 1, in the same run.

- The library: 16 colour videos of a rendered horse (canter and gallop at two periods each,
  shifted across the frame at four speeds), 300 frames of 265 x 120, each with its box: every
  clip is decoded, segmented from the box's rectangles, tracked and analysed (a few seconds
  of one core each).
- The same library is run by :func:`gaitcore.project.batch_run.run_batch` on a local Dask
  cluster of 1, then 2 single-threaded worker processes, into fresh output folders.
- Times: "total" includes starting and stopping the cluster; "tasks" runs from the moment
  the cluster is up to the last clip's result. The speed-up is the ratio of 1 worker to 2.

Run ``python -m benchmarks batch`` (from the repository root).
"""

from __future__ import annotations

import os
import resource
import tempfile
import time
from pathlib import Path

from benchmarks import Section
from gaitcore.bench.clip_library import make_library, write_manifest
from gaitcore.project.batch_run import run_batch
from gaitcore.project.manifest import read_manifest

GAITS = {"canter": (18.0, 24.0), "gallop": (14.0, 20.0)}
SPEEDS = (0.0, 0.15, 0.25, 0.35)
N_FRAMES = 300
WORKERS = (1, 2)


def run() -> list[Section]:
    """All sections of this benchmark."""
    return [speed_up()]


def _children_cpu_s() -> float:
    """CPU seconds of the child processes that have ended (the cluster's workers)."""
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def _timed_batch(manifest, out: Path, workers: int) -> tuple[float, float, float, int]:
    """(total s, tasks s, workers' CPU s, usable clips) of a batch on ``workers`` processes."""
    up: list[float] = []

    def notify(line: str) -> None:
        if line.startswith("local cluster"):
            up.append(time.perf_counter())

    cpu0, t0 = _children_cpu_s(), time.perf_counter()
    result = run_batch(manifest, out, workers=workers, notify=notify)
    t1 = time.perf_counter()
    return t1 - t0, t1 - up[0], _children_cpu_s() - cpu0, sum(bool(r.usable) for r in result.rows)


def speed_up() -> Section:
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        lib = root / "lib"
        lib.mkdir()
        clips = make_library(lib, gaits=GAITS, speeds=SPEEDS, n_frames=N_FRAMES, videos_every=1)
        manifest = read_manifest(write_manifest(lib / "manifest.csv", clips))
        runs = {n: _timed_batch(manifest, root / f"out{n}", n) for n in WORKERS}
    base_total, base_tasks, _, _ = runs[WORKERS[0]]
    rows = [[n, len(clips), usable, f"{total:.1f}", f"{tasks:.1f}", f"{cpu:.1f}",
             f"{base_total / total:.2f}x", f"{base_tasks / tasks:.2f}x"]
            for n, (total, tasks, cpu, usable) in runs.items()]
    return Section(
        title=f"gaitcore batch: {len(clips)} colour clips of {N_FRAMES} frames, "
              "1 vs 2 worker processes",
        headers=["workers", "clips", "usable", "total s", "tasks s", "workers' CPU s",
                 "speed-up (total)", "speed-up (tasks)"],
        rows=rows,
        notes=[
            "Local Dask cluster (processes, 1 thread each; OpenCV limited to 1 thread per task).",
            "'total' includes starting and closing the cluster; 'tasks' starts once it is up.",
            "'workers' CPU s': CPU time of the worker processes; equal in both runs means that "
            "the work splits without overhead, so on an idle machine 2 workers approach 2x.",
            "Target: speed-up >= 1.7x with 2 workers on a 2-core machine "
            "(measured on a quiet machine).",
            f"Load average when the run started: {load:.1f} "
            "(more than ~0.5 means other work shared the cores).",
        ],
    )
