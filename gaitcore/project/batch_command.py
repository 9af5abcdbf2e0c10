"""The ``gaitcore batch`` subcommand: analyse every clip of a manifest on Dask.

Prints the dashboard's address, a progress bar on a terminal (one line per clip
otherwise), the rows of the manifest that cannot run, and a last line counting the
verdicts. Exit status 0 when the batch ran (failed clips are lines of the summary), 2 for
a manifest that cannot be read as a whole or has no row that can run, 130 when interrupted
(the summary is consistent and a rerun goes on where this one stopped).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path
from typing import TextIO

from gaitcore.errors import GaitInputError

BAR_WIDTH = 30


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``batch`` on an argparse subparsers object (``set_defaults(run=...)``)."""
    p = subparsers.add_parser(
        "batch",
        help="analyse every clip of a manifest, on a local or remote Dask cluster",
        description="Analyse every clip of MANIFEST (CSV: path, box or subject/background, "
        "start, stop, fps; one row per clip) as 'analyze' does, each into OUT/<clip>/, and "
        "write OUT/summary.csv and OUT/summary.json. Clips already done are skipped.",
    )
    p.add_argument("manifest", type=Path, help="CSV manifest, one row per clip")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a running Dask scheduler (tcp://host:8786); default: a local cluster")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--settings", type=Path, default=None, metavar="FILE.json",
                   help="the segmentation profile of every clip ('gaitcore segment "
                   "--save-settings' writes one); clips done with another run again")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run the batch; returns the exit status."""
    from gaitcore.project.batch_run import run_batch
    from gaitcore.project.manifest import read_manifest
    from gaitcore.silhouettes.settings import SegmentationSettings, read_settings

    if args.workers is not None and args.workers < 1:
        raise GaitInputError(f"--workers must be at least 1, got {args.workers}")
    if args.workers is not None and args.scheduler:
        raise GaitInputError("--workers sizes the local cluster: leave it out with --scheduler")
    segmentation = (SegmentationSettings() if args.settings is None
                    else read_settings(args.settings))
    manifest = read_manifest(args.manifest)
    for problem in manifest.problems:
        print(f"gaitcore: {args.manifest} {problem}", file=sys.stderr)
    if not manifest.clips:
        raise GaitInputError(f"none of the {len(manifest.problems)} rows of {args.manifest} can "
                             "run: fix the rows reported above")
    bar = TerminalBar(sys.stderr)
    result = run_batch(manifest, args.out, scheduler=args.scheduler, workers=args.workers,
                       segmentation=segmentation, progress=bar.update, notify=bar.line)
    bar.close()
    counts = Counter(row.verdict if row.status == "done" else row.status for row in result.rows)
    parts = ", ".join(f"{n} {what}" for what, n in sorted(counts.items()))
    print(f"{len(result.rows)} rows: {parts}; {result.computed} analysed, {result.skipped} "
          f"skipped; summary: {Path(args.out) / 'summary.csv'}")
    return 0


class TerminalBar:
    """A progress bar redrawn on one terminal line; plain lines when not on a terminal."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self._tty = stream.isatty()
        self._start = time.monotonic()
        self._shown = ""

    def update(self, done: int, total: int) -> bool:
        filled = BAR_WIDTH * done // max(total, 1)
        elapsed = int(time.monotonic() - self._start)
        self._shown = (f"[{'#' * filled}{'.' * (BAR_WIDTH - filled)}] {done}/{total} clips "
                       f"{elapsed // 60}:{elapsed % 60:02d}")
        if self._tty:
            self._stream.write("\r" + self._shown)
            self._stream.flush()
        return True

    def line(self, text: str) -> None:
        if self._tty:
            self._stream.write("\r" + " " * len(self._shown) + "\r")
        self._stream.write(text + "\n")
        if self._tty and self._shown:
            self._stream.write(self._shown)
        self._stream.flush()

    def close(self) -> None:
        if self._tty and self._shown:
            self._stream.write("\n")
            self._stream.flush()
