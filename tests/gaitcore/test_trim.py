"""Trim and frame rate in the command: source frame numbers in, source frame numbers out."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gaitcore.cli import main
from gaitcore.io.pose_table import read_pose_table
from tests.gaitcore.walker import walker_clip, write_mask_folder


@pytest.fixture(scope="module")
def masks(tmp_path_factory):
    return write_mask_folder(tmp_path_factory.mktemp("walker") / "masks", walker_clip(160))


def analyze(masks, out, *extra):
    assert main(["analyze", str(masks), "--out", str(out), "--key-time-limit", "5", *extra]) == 0
    return json.loads((out / "analysis.json").read_text())


def test_trimmed_analysis_numbers_frames_from_the_source(masks, tmp_path, capsys):
    data = analyze(masks, tmp_path / "a", "--start", "40", "--stop", "136", "--fps", "30")
    assert data["n_frames"] == 96 and data["first_frame"] == 40
    assert len(data["projections"]) == 96
    assert all(40 <= f < 136 for f in data["key_frames"])
    assert data["fps"] == 30 and data["period_s"] == pytest.approx(data["period_frames"] / 30)
    assert all(40 <= c["start"] < c["stop"] <= 136 for c in data["cycles"])
    assert "frames: 96, 40 to 135" in capsys.readouterr().out


def test_animate_keeps_source_frames_and_the_clip_rate(masks, tmp_path):
    data = analyze(masks, tmp_path / "a", "--start", "40", "--stop", "136", "--fps", "30")
    keys = tmp_path / "keys.csv"
    keys.write_text("frame,a\n" + "".join(f"{f},{i}\n" for i, f in enumerate(data["key_frames"])))
    out = tmp_path / "curves.csv"
    assert main(["animate", str(tmp_path / "a" / "analysis.json"), "--key-poses", str(keys),
                 "--out", str(out), "--csv-time"]) == 0
    table = read_pose_table(out)
    np.testing.assert_array_equal(table.frames, np.arange(40, 136))
    header, first = out.read_text().splitlines()[:2]
    assert header.startswith("frame,time_s") and first.startswith("40,1.333333")
    curves, a = table.as_dict(), list(table.columns).index("a")
    for i, f in enumerate(data["key_frames"]):
        assert curves[f][a] == pytest.approx(i)  # exact at the keys, by source frame


def test_bad_ranges_are_one_line(masks, tmp_path, capsys):
    for args in (["--start", "150", "--stop", "120"], ["--stop", "999"], ["--fps", "-3"]):
        assert main(["analyze", str(masks), "--out", str(tmp_path), *args]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and ("frames" in err or "fps" in err), err


def test_bvh_frame_time_has_ten_significant_digits(tmp_path):
    from gaitcore.io.bvh.writer import write_bvh
    from gaitcore.io.pose_table import PoseTable
    from gaitcore.rig.templates import load_template

    skeleton = load_template("horse")
    table = PoseTable(np.arange(2), skeleton.channel_names,
                      np.zeros((2, len(skeleton.channel_names))))
    write_bvh(tmp_path / "a.bvh", skeleton, table, fps=29.97)
    line = next(s for s in (tmp_path / "a.bvh").read_text().splitlines()
                if s.startswith("Frame Time"))
    assert line == "Frame Time: 0.033366700033"


def test_a_video_whose_header_claims_too_many_frames_is_analysed_whole(tmp_path):
    import cv2

    from tests.gaitcore.test_frames import _claim_frames

    clip = walker_clip(72)
    path = tmp_path / "walker.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 24.0, clip.shape[2:0:-1])
    for m in clip:
        writer.write(cv2.cvtColor(m, cv2.COLOR_GRAY2BGR))
    writer.release()
    _claim_frames(path, 90)
    out = tmp_path / "out"
    assert main(["analyze", str(path), "--out", str(out), "--subject", "70,35,60,30",
                 "--background", "0,0,40,20", "--key-time-limit", "5"]) == 0
    data = json.loads((out / "analysis.json").read_text())
    assert data["n_frames"] == 72 and data["fps"] == 24.0
    assert len(list((out / "masks").glob("*.png"))) == 72
