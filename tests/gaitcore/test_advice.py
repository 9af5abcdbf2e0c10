"""Advice that names the cause: each kind of bad clip gets its own cause and next step."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from gaitcore.analysis.advice import Cause, silhouette_cues
from gaitcore.analysis.analyze import AnalysisSettings, analyze_silhouettes
from gaitcore.silhouettes.tracking import crop_rois
from tests.gaitcore.walker import walker_clip, walker_frame

SETTINGS = AnalysisSettings(key_time_limit_s=5.0)


def advice_for(clip: np.ndarray):
    return analyze_silhouettes(crop_rois(clip), SETTINGS).advice


def test_a_steady_side_on_walk_needs_nothing():
    advice = advice_for(walker_clip(120))
    assert advice.cause is Cause.NONE and advice.message == "Usable."


def test_legs_missing():
    clip = walker_clip(120)
    clip[:, 62:, :] = 0  # cut at the belly: a trunk without legs
    advice = advice_for(clip)
    assert advice.cause is Cause.UNSTABLE and "legs" in advice.message
    assert "sketch" in advice.next_step


def test_area_jumps():
    clip = walker_clip(120)
    clip[::4, :, ::2] = 0  # every fourth frame loses half its pixels
    advice = advice_for(clip)
    assert advice.cause is Cause.UNSTABLE and "area jumps" in advice.message


def test_turning_away_is_not_side_on():
    frames = []
    for t in range(120):
        f = walker_frame(float(t), size=(120, 200))
        width = max(40, int(200 * (1.0 - 0.8 * min(1.0, max(0.0, (t - 50) / 30)))))
        small = cv2.resize(f, (width, 120), interpolation=cv2.INTER_NEAREST)
        canvas = np.zeros((120, 200), np.uint8)
        canvas[:, (200 - width) // 2:(200 - width) // 2 + width] = small
        frames.append(canvas)
    advice = advice_for(np.stack(frames))
    assert advice.cause is Cause.NOT_SIDE_ON, advice
    assert "Trim to frames" in advice.next_step or "side-on" in advice.next_step


def test_too_few_cycles():
    advice = advice_for(walker_clip(28, 48.0, drift_px=0.0))  # 0.6 stride: no cycle to see
    assert advice.cause is Cause.TOO_FEW_CYCLES, advice
    assert "longer clip" in advice.next_step


def test_no_rhythm():
    t = np.arange(150)
    # the legs swing to three unrelated rhythms at once: smooth, but no single cycle
    phase = (4 * np.sin(2 * np.pi * t / 17) + 1.5 * np.sin(2 * np.pi * t / 7.3 + 1)
             + 4 * np.sin(2 * np.pi * t / 29 + 2))
    frames = [walker_frame(float(p)) for p in phase]
    advice = advice_for(np.stack(frames))
    assert advice.cause is Cause.NO_RHYTHM, advice


def test_cues_of_empty_and_tiny_clips():
    assert silhouette_cues(np.zeros((1, 8, 8), bool)).box_spread == 1.0
    cues = silhouette_cues(np.zeros((3, 8, 8), bool))
    assert (cues.area_jumps, cues.lower_width) == (0.0, 0.0)


@pytest.mark.parametrize("cause", list(Cause))
def test_every_cause_reads_as_words(cause):
    assert cause.value and cause.value == cause.value.lower()
