"""The cycle finder: stretches of steady gait, their ends and their gait cycle."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from gaitcore.analysis.cycles import Cycle, find_cycles
from gaitcore.bench.scenes import stand_walk_turn
from gaitcore.cli import main
from gaitcore.silhouettes.tracking import RoiClip, crop_rois
from tests.gaitcore.walker import walker_clip, walker_frame


def test_a_clip_of_the_walker_between_two_still_stretches():
    still = walker_frame(0.0)
    walking = [walker_frame(t) for t in range(96)]  # 4 cycles of 24 frames
    clip = np.stack([still] * 40 + walking + [walker_frame(96.0)] * 40)
    cycles = find_cycles(crop_rois(clip))
    assert len(cycles) == 1
    c = cycles[0]
    assert abs(c.start - 40) <= 5 and abs(c.stop - 136) <= 5
    assert c.period_frames == pytest.approx(24.0, abs=1.0)  # the gait cycle, not the bob
    assert c.usable and c.to_dict(100)["start"] == c.start + 100


def _slow_start_clip(n: int, period: float = 36.0) -> RoiClip:
    """A disc round a small circle, four times slower in the quarter period after frame 0
    than in the quarter before it (one side of every frame moves little)."""
    crops = np.zeros((n, 60, 60), np.uint8)
    for t in range(n):
        p = t / period
        turn = p - 0.8 / (2 * np.pi) * (np.sin(2 * np.pi * (p - 0.125)) + np.sin(np.pi / 4))
        centre = np.round(30 + 8 * np.array([np.cos(2 * np.pi * turn), np.sin(2 * np.pi * turn)]))
        cv2.circle(crops[t], tuple(int(v) for v in centre), 18, 1, -1)
    return RoiClip(crops > 0, np.zeros((n, 2)), np.zeros(n, bool))


def test_a_clip_that_starts_on_a_slow_moment_of_its_gait_keeps_its_first_frames():
    # The frames a quarter period after frame 0 look alike; the quarter before, which a clip's
    # first frames lack, would not: the frame of that phase one period on stands in for it.
    cycles = find_cycles(_slow_start_clip(144))
    assert len(cycles) == 1
    assert (cycles[0].start, cycles[0].stop) == (0, 144)
    assert cycles[0].period_frames == pytest.approx(36.0, abs=1.0)


def test_no_rhythm_no_cycle():
    rng = np.random.default_rng(0)
    noise = rng.random((120, 40, 60)) < 0.3
    roi = RoiClip(noise, np.zeros((120, 2)), np.zeros(120, bool))
    assert find_cycles(roi) == ()


def test_lost_frames_cut_a_stretch():
    roi = crop_rois(walker_clip(192, drift_px=0.0))
    lost = roi.lost.copy()
    lost[90:110] = True
    cut = find_cycles(RoiClip(roi.crops, roi.centers_xy, lost, roi.scale))
    assert all(c.stop <= 90 or c.start >= 110 for c in cut)


def test_ranking_prefers_usable_then_long():
    short, long_ = Cycle(0, 60, 24.0, 0.9, 0.9), Cycle(100, 300, 24.0, 0.8, 0.8)
    bad = Cycle(400, 700, 24.0, 0.9, 0.3)
    ranked = sorted([bad, short, long_],
                    key=lambda c: (not c.usable, -c.n_cycles * min(c.r1, c.r2)))
    assert ranked == [long_, short, bad]


@pytest.mark.slow
def test_standing_walking_side_on_then_turning_away():
    scene = stand_walk_turn()  # stands 45, walks 110 (2.75 cycles of 40), turns away
    roi = crop_rois(scene.masks, max_side=160)
    cycles = find_cycles(roi)
    assert cycles, "the walking stretch was not found"
    best = cycles[0]
    assert abs(best.start - scene.gait_start) <= 5, best
    assert abs(best.stop - scene.gait_stop) <= 5, best
    assert abs(best.period_frames - scene.period_frames) <= 1.0, best


@pytest.mark.slow
def test_muybridge_race_horse_one_stretch_and_a_trimmed_analysis(shared_data, tmp_path):
    video = shared_data / "muybridge-race-horse" / "race_horse_loop.mp4"
    rects = ["--subject", "300,200,200,80", "--subject", "620,130,150,60",
             "--background", "20,20,300,120", "--background", "650,330,250,120",
             "--background", "0,420,250,80"]
    assert main(["analyze", str(video), "--out", str(tmp_path / "all"), *rects]) == 0
    whole = json.loads((tmp_path / "all" / "analysis.json").read_text())
    assert len(whole["cycles"]) == 1
    c = whole["cycles"][0]
    assert (c["start"], c["stop"]) == (0, 540) and abs(c["period_frames"] - 36) <= 1
    assert whole["fps"] == pytest.approx(23.976, abs=0.01)
    masks = tmp_path / "all" / "masks"
    assert main(["analyze", str(masks), "--out", str(tmp_path / "cut"),
                 "--start", "100", "--stop", "400"]) == 0
    cut = json.loads((tmp_path / "cut" / "analysis.json").read_text())
    assert cut["n_frames"] == 300 and cut["first_frame"] == 100
    assert abs(cut["period_frames"] - 36) <= 1
    assert all(100 <= f < 400 for f in cut["key_frames"])
    assert [(c["start"], c["stop"]) for c in cut["cycles"]] == [(100, 400)]
