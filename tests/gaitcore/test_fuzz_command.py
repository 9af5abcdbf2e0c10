"""Fuzzed command lines: the command ends with status 0, or 2 and one line (issue #15).

Valid ``animate``, ``analyze`` and ``synth`` command lines are mutated (values replaced by
1e400, NaN, negative or malformed numbers, options dropped, repeated or unknown). Outputs
always go to the test's folder, and ``synth`` is pointed at a folder that is not empty, so
no case renders.
"""

from __future__ import annotations

import json
import random

import numpy as np
import pytest

from gaitcore.cli import main
from gaitcore.io.pose_table import PoseTable, write_pose_table
from gaitcore.rig.templates import load_template
from tests.fuzzing import DEFAULT_CASES, FUZZ_CASES, SPECIAL_NUMBERS

VALUES = SPECIAL_NUMBERS + ("-1", "0", "", "abc", "1,2", "-10,-10,50,50", "1e300", "nan",
                            "inf", "0,0,0,0", "3,-4,5,6", "--", "-", "1.5", "99999999999",
                            "2", "25", "1,2,3,4", "0.5,1")


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
    t = str(tmp_path)
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
        if r < 0.8:
            argv[rng.choice(values)] = rng.choice(VALUES)
        elif r < 0.9:
            i = rng.choice(options)
            has_value = i + 1 < len(argv) and not argv[i + 1].startswith("--")
            argv[i:i + 1 + has_value] = ["--csv-time"] if argv[0] == "animate" else ["--json"]
        else:
            argv.append(rng.choice(("--bogus", "--pcs", "1", "--")))
    return argv


@pytest.mark.parametrize("n_cases", [
    DEFAULT_CASES, pytest.param(FUZZ_CASES, marks=pytest.mark.fuzz)])
def test_fuzzed_command_lines_exit_0_or_2_with_one_line(templates, n_cases, capsys):
    rng = random.Random(7)
    for case in range(n_cases):
        argv = _mutate(rng.choice(templates), rng)
        status = main(argv)
        err = capsys.readouterr().err
        assert status in (0, 2), f"case {case}: {argv} exited {status}: {err}"
        if status == 2:
            assert err.count("\n") == 1, f"case {case}: {argv}: {err}"
            assert "unexpected" not in err, f"case {case}: {argv}: {err}"
