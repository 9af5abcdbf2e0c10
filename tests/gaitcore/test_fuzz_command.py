"""Fuzzed command lines: the command ends with status 0, or 2 and one line (issues #15, #64).

Valid ``animate``, ``analyze`` and ``synth`` command lines are mutated (values replaced by
1e400, NaN, negative or malformed numbers, paths naming a pipe, ``/dev/zero``, a loop of
links or holding bytes that are not UTF-8, options dropped, repeated or unknown), each run
in a forked child with a time and memory limit (:mod:`tests.fuzzing`). Outputs always go to
the test's folder, and ``synth`` is pointed at a folder that is not empty, so no case renders.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import random
from pathlib import Path

import numpy as np
import pytest
from hypothesis import strategies as st

from gaitcore.cli import main
from gaitcore.io.pose_table import PoseTable, write_pose_table
from gaitcore.rig.templates import load_template
from tests.fuzzing import CASE_COUNTS, SPECIAL_NUMBERS, fuzz

VALUES = SPECIAL_NUMBERS + ("-1", "0", "", "abc", "1,2", "-10,-10,50,50", "1e300", "nan",
                            "inf", "0,0,0,0", "3,-4,5,6", "--", "-", "1.5", "99999999999",
                            "2", "25", "1,2,3,4", "0.5,1")
HOSTILE: list[str] = []
"""Paths that are no files: filled in by the fixture (they live in its folder)."""


@pytest.fixture
def templates(tmp_path):
    horse = load_template("horse")
    n = 6
    analysis = {"format": "gaitstudio-analysis", "version": 1, "n_frames": n, "alpha": 0.69,
                "key_frames": [1, 4], "projections": [[0.1 * i, 0.01 * i * i - 0.2 * i]
                                                      for i in range(n)],
                "loop_angle": [0.1 * i for i in range(n)]}
    (tmp_path / "a.json").write_text(json.dumps(analysis))
    write_pose_table(tmp_path / "k.csv", PoseTable(np.array([1, 4]), horse.channel_names,
                                                   np.zeros((2, horse.n_channels))))
    horse.to_json(tmp_path / "s.json")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "keep.txt").write_text("not synth's")
    (tmp_path / "masks").mkdir()
    os.mkfifo(tmp_path / "pipe")
    (tmp_path / "loop").symlink_to("loop")
    t = str(tmp_path)
    HOSTILE[:] = [f"{t}/pipe", "/dev/zero", f"{t}/loop", os.fsdecode(b"img\xff"), "a\x00b",
                  "n" * 5000]
    return [
        ["animate", f"{t}/a.json", "--key-poses", f"{t}/k.csv", "--out", f"{t}/c.csv",
         "--fps", "24", "--clamp", "-0.2,1.2", "--bvh", f"{t}/o.bvh", "--skeleton", f"{t}/s.json",
         "--csv-time"],
        ["analyze", f"{t}/masks", "--out", f"{t}/an", "--pcs", "2", "--keys", "4", "--subject",
         "1,2,3,4", "--background", "0,0,5,5", "--pin", "1,2", "--forbid", "3",
         "--key-time-limit", "5"],
        ["synth", "--gait", "walk", "--frames", "4", "--out", f"{t}/full", "--width", "64",
         "--height", "48", "--period", "20", "--noise", "1", "--seed", "2", "--yaw", "5",
         "--elevation", "3", "--lead", "left"],
    ]


def _mutate(argv: list[str], rng: random.Random) -> list[str]:
    """Mostly one value replaced; sometimes an option dropped, or an unknown one added."""
    argv = list(argv)
    for _ in range(rng.choice((1, 1, 1, 2))):
        fixed = {i + 1 for i, a in enumerate(argv) if a in ("--out", "--bvh")}  # outputs stay
        values = [i for i in range(1, len(argv)) if not argv[i].startswith("--") and i not in fixed]
        options = [i for i in range(1, len(argv))
                   if argv[i].startswith("--") and i + 1 not in fixed]
        r = rng.random()
        if r < 0.7:
            argv[rng.choice(values)] = rng.choice(VALUES)
        elif r < 0.8:
            argv[rng.choice(values)] = rng.choice(HOSTILE)
        elif r < 0.9:
            i = rng.choice(options)
            has_value = i + 1 < len(argv) and not argv[i + 1].startswith("--")
            argv[i:i + 1 + has_value] = ["--csv-time"] if argv[0] == "animate" else ["--json"]
        else:
            argv.append(rng.choice(("--bogus", "--pcs", "1", "--")))
    return argv


def _run(path: Path) -> None:
    """Run the command line stored at ``path``; exit 0, or 2 and one line."""
    argv = json.loads(path.read_text())
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = main(argv)
    said = err.getvalue()
    assert status in (0, 2), f"{argv} exited {status}: {said}"
    if status == 2:
        assert said.count("\n") == 1, f"{argv}: {said}"
        assert "unexpected" not in said, f"{argv}: {said}"


@CASE_COUNTS
def test_fuzzed_command_lines_exit_0_or_2_with_one_line(templates, n_cases, tmp_path):
    def write(seed: int, folder: Path) -> Path:
        rng = random.Random(seed)
        argv = _mutate(rng.choice(templates), rng)
        (folder / "argv.json").write_text(json.dumps(argv))
        return folder / "argv.json"

    fuzz(st.integers(0, 2**32), write, _run, tmp_path / "cases", n_cases=n_cases, hostile=0)
