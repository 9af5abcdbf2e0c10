"""The command on hostile input: every failure is exit status 2 and one line (issue #15).

The first eleven cases are the command lines that ended in a traceback before: rectangles
of infinite size, a negative seed, analysis files with a wrong-typed version, an infinite
frame count or deep nesting, a CSV cell over the csv module's limit, and BVH skeletons with
``Frames: inf``/``nan`` or more than a thousand nested joints.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gaitcore.cli import main

ROOT = Path(__file__).resolve().parents[2]

ANALYSIS = {"format": "gaitstudio-analysis", "version": 1, "n_frames": 6, "alpha": 0.69,
            "key_frames": [1, 4],
            "projections": [[0.1 * i, 0.01 * i * i - 0.2 * i] for i in range(6)],
            "loop_angle": [0.1 * i for i in range(6)]}


def bvh(n_joints: int, *, frames: str = "1", nested: bool = False) -> str:
    """A rig of ``n_joints`` (a chain when ``nested``, else all children of the root)."""
    lines = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0",
             "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for i in range(1, n_joints):
        lines += [f"JOINT j{i}", "{", "OFFSET 0 1 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
        lines += [] if nested else ["}"]
    lines += ["}"] * (n_joints if nested else 1)
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.04",
              " ".join(["0"] * (3 * n_joints + 3))]
    return "\n".join(lines) + "\n"


@pytest.fixture
def files(tmp_path):
    def write(name: str, text: str) -> str:
        (tmp_path / name).write_text(text)
        return str(tmp_path / name)

    good = json.dumps(ANALYSIS)
    (tmp_path / "masks").mkdir()
    return {
        "dir": str(tmp_path), "masks": str(tmp_path / "masks"), "out": str(tmp_path / "c.csv"),
        "analysis": write("a.json", good),
        "keys": write("k.csv", "frame,j0.rz\n1,0\n4,1\n"),
        "v_str": write("v_str.json", json.dumps(dict(ANALYSIS, version="1"))),
        "v_null": write("v_null.json", json.dumps(dict(ANALYSIS, version=None))),
        "n_inf": write("n_inf.json", good.replace('"n_frames": 6', '"n_frames": 1e400')),
        "deep": write("deep.json", "[" * 100_000 + "]" * 100_000),
        "big_cell": write("big.csv", "frame,j0.rz\n1," + "1" * 131_073 + "\n4,1\n"),
        "frames_inf": write("inf.bvh", bvh(3, frames="inf")),
        "frames_nan": write("nan.bvh", bvh(3, frames="nan")),
        "nested": write("nested.bvh", bvh(1_200, nested=True)),
    }


def _animate(f, analysis="analysis", keys="keys", *extra):
    return ["animate", f[analysis], "--key-poses", f[keys], "--out", f["out"], *extra]


def _skeleton(f, name):
    return _animate(f, "analysis", "keys", "--bvh", f["dir"] + "/o.bvh", "--skeleton", f[name])


CASES = {
    "subject inf": lambda f: ["analyze", f["masks"], "--out", f["dir"], "--subject", "inf,0,10,10"],
    "subject 1e400": lambda f: ["analyze", f["masks"], "--out", f["dir"], "--subject",
                                "1e400,0,9,9"],
    "synth seed -1": lambda f: ["synth", "--gait", "walk", "--frames", "2", "--out",
                                f["dir"] + "/s", "--noise", "1", "--seed", "-1"],
    "version string": lambda f: _animate(f, "v_str"),
    "version null": lambda f: _animate(f, "v_null"),
    "n_frames 1e400": lambda f: _animate(f, "n_inf"),
    "deep analysis": lambda f: _animate(f, "deep"),
    "CSV cell > 131072": lambda f: _animate(f, "analysis", "big_cell"),
    "BVH Frames: inf": lambda f: _skeleton(f, "frames_inf"),
    "BVH Frames: nan": lambda f: _skeleton(f, "frames_nan"),
    "BVH 1200 nested joints": lambda f: _skeleton(f, "nested"),
    "fps 1e300": lambda f: _animate(f, "analysis", "keys", "--fps", "1e300"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_input_exits_2_with_one_line(files, case, capsys):
    assert main(CASES[case](files)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("gaitcore: error: ")
    assert "Traceback" not in err and "unexpected" not in err


def test_negative_rectangles_need_no_equals_sign(files, capsys):
    assert main(["analyze", files["masks"], "--out", files["dir"], "--subject",
                 "-10,-10,50,50"]) == 2
    assert "is empty" in capsys.readouterr().err  # parsed: the empty folder is the problem


def test_an_unexpected_error_is_still_one_line(monkeypatch, capsys):
    import gaitcore.bench.evaluate

    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug\nover two lines")

    monkeypatch.setattr(gaitcore.bench.evaluate, "evaluate_gait", broken)
    assert main(["evaluate", "--gait", "walk"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "ZeroDivisionError (a bug over two lines)" in err


def test_a_damaged_video_prints_one_line_not_the_decoder_log(shared_data, tmp_path):
    video = shared_data / "muybridge-race-horse" / "race_horse_loop.mp4"
    data = np.frombuffer(video.read_bytes(), np.uint8).copy()
    rng = np.random.default_rng(1)
    spots = rng.integers(len(data) // 10, len(data), 3000)
    data[spots] = rng.integers(0, 256, len(spots), dtype=np.uint8)  # as a bad disk or download
    (tmp_path / "damaged.mp4").write_bytes(data.tobytes())
    run = subprocess.run([sys.executable, "-m", "gaitcore.cli", "analyze",
                          str(tmp_path / "damaged.mp4"),
                          "--out", str(tmp_path / "out"), "--subject", "10,10,50,50",
                          "--background", "0,0,5,5"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300,
                         env={k: v for k, v in os.environ.items() if not k.startswith("OPENCV_")})
    assert run.returncode == 2
    assert len(run.stderr.splitlines()) == 1, run.stderr[:500]


def _refused(argv: list[str], capsys, says: str) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and says in err, err


@pytest.mark.skipif(sys.platform != "linux", reason="names of any bytes: a Linux file system")
def test_paths_that_would_crash_block_or_loop_are_refused_in_one_line(tmp_path, capsys):
    """A name not UTF-8 once crashed the process (exit 139); a FIFO blocked for ever; a
    loop of links and a device are no files either."""
    os.chdir(tmp_path)
    _refused(["synth", "--gait", "walk", "--out", os.fsdecode(b"o\xff\xfe"), "--frames", "4"],
             capsys, "not UTF-8")
    os.mkfifo("fifo.json")
    _refused(["analyze", "masks", "--out", "an", "--scribbles", "fifo.json"], capsys,
             "pipe, socket or device")
    os.symlink("loop_b", "loop_a")
    os.symlink("loop_a", "loop_b")
    _refused(["analyze", "loop_a", "--out", "an"], capsys, "symbolic links")
    _refused(["analyze", "masks", "--out", "a" * 300], capsys, "too long")
    _refused(["evaluate", "--gait", "walk", "--height", "9007199254740993"], capsys,
             "--height must be")
    (tmp_path / "an.json").write_text(json.dumps(ANALYSIS))
    (tmp_path / "keys.csv").write_text("frame,a.rz\n1,0\n4,1\n")
    for extra, says in ((["--root", "footage"], "needs --skeleton"),
                        (["--speed", "nan"], "--speed must be")):
        _refused(["animate", "an.json", "--key-poses", "keys.csv", "--out", "c.csv", *extra],
                 capsys, says)


def test_an_image_bomb_and_huge_numbers_are_refused_before_the_arithmetic(tmp_path, capsys):
    import cv2

    folder = tmp_path / "bomb"
    folder.mkdir()
    cv2.imwrite(str(folder / "00000.png"), np.zeros((12_000, 9_000), np.uint8))  # 108 Mpx
    _refused(["analyze", str(folder), "--out", str(tmp_path / "an")], capsys, "pixels")
    huge = dict(ANALYSIS, projections=[[1e300, 0.0]] + ANALYSIS["projections"][1:])
    (tmp_path / "huge.json").write_text(json.dumps(huge))
    (tmp_path / "keys.csv").write_text("frame,a.rz\n1,0\n4,1\n")
    _refused(["animate", str(tmp_path / "huge.json"), "--key-poses", str(tmp_path / "keys.csv"),
              "--out", str(tmp_path / "c.csv")], capsys, "at most")
    wide = {"scribbles": [{"frame": 0, "label": "subject", "width": 1e400, "points": [[1, 1]]}]}
    (tmp_path / "wide.json").write_text(json.dumps(wide).replace("Infinity", "1e400"))
    small = tmp_path / "small"
    small.mkdir()
    cv2.imwrite(str(small / "00000.png"), np.full((30, 40, 3), (20, 90, 160), np.uint8))
    _refused(["segment", str(small), "--out", str(tmp_path / "s"), "--scribbles",
              str(tmp_path / "wide.json")], capsys, "width")


def test_a_clip_too_large_for_the_memory_left_is_refused_with_the_figures(tmp_path, capsys,
                                                                         monkeypatch):
    """20,000 masks once ended in "unexpected MemoryError ... this is a bug" under a 1 GiB
    limit; the estimate now refuses such a clip before the analysis allocates."""
    import gaitcore.limits
    from tests.gaitcore.walker import walker_clip, write_mask_folder

    masks = write_mask_folder(tmp_path / "masks", walker_clip(500))  # over UNCHECKED_BYTES
    monkeypatch.setattr(gaitcore.limits, "free_memory", lambda: 100_000)
    _refused(["analyze", str(masks), "--out", str(tmp_path / "an")], capsys,
             "analysing 500 frames of")
    monkeypatch.setattr(gaitcore.limits, "free_memory", lambda: None)  # nothing says: run
    assert main(["analyze", str(masks), "--out", str(tmp_path / "an")]) == 0


@pytest.mark.parametrize("n", [1500, 4000])
def test_the_memory_estimate_bounds_what_the_analysis_takes(n):
    """An upper bound that does not refuse what fits: within three times the peak, on a
    clip the dense PCA takes and on one it streams."""
    import tracemalloc

    from gaitcore.analysis.analyze import analyze_silhouettes, memory_needed
    from gaitcore.silhouettes.tracking import crop_rois
    from tests.gaitcore.walker import walker_clip

    roi = crop_rois(np.resize(walker_clip(48), (n, 120, 260)), max_side=160)
    tracemalloc.start()
    try:
        analyze_silhouettes(roi)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= memory_needed(*roi.crops.shape) <= 3 * peak


def test_a_frame_rate_too_small_to_compute_with_is_refused(tmp_path, capsys):
    """Found by the widened fuzzer: ``animate --fps 5e-324`` overflowed a division."""
    (tmp_path / "keys.csv").write_text("frame,a.rz\n1,0\n4,1\n")
    (tmp_path / "an.json").write_text(json.dumps(ANALYSIS))
    _refused(["animate", str(tmp_path / "an.json"), "--key-poses", str(tmp_path / "keys.csv"),
              "--out", str(tmp_path / "c.csv"), "--fps", "5e-324"], capsys, "from 0.001 to")
