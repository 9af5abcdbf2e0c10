"""End to end on real footage from ../shared/data (skipped where it is absent)."""

import json

import cv2
import pytest

from gaitcore.cli import main


@pytest.mark.slow
def test_muybridge_race_horse_period_and_verdict(shared_data, tmp_path):
    video = shared_data / "muybridge-race-horse" / "race_horse_loop.mp4"
    # Rectangles drawn once on the first frame: horse's body and neck; sky, ground and the
    # space under the belly ahead of the legs.
    args = ["analyze", str(video), "--out", str(tmp_path),
            "--subject", "300,200,200,80", "--subject", "620,130,150,60",
            "--background", "20,20,300,120", "--background", "650,330,250,120",
            "--background", "0,420,250,80"]
    cv2.setRNGSeed(1)  # whatever OpenCV did before must not matter (it took r2 to 0.30)
    assert main(args) == 0
    data = json.loads((tmp_path / "analysis.json").read_text())
    assert data["n_frames"] == 540
    assert abs(data["period_frames"] - 36.0) <= 1.0  # the loop repeats every 36 frames
    assert data["correlations"][0] >= 0.6 and data["correlations"][1] >= 0.6
    assert data["usable"] is True
    assert len(list((tmp_path / "masks").glob("*.png"))) == 540
