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


MUYBRIDGE_INPUTS = [
    ["--subject", "300,240,160,60", "--background", "0,0,450,60", "--background", "0,440,280,60"],
    ["--subject", "560,150,120,50", "--background", "0,0,960,90", "--background",
     "650,330,300,150"],
    ["--box", "110,30,760,420"],
]


@pytest.mark.slow
@pytest.mark.parametrize("drawn", MUYBRIDGE_INPUTS, ids=["why", "neck", "box"])
def test_muybridge_race_horse_whatever_the_user_drew(shared_data, tmp_path, drawn):
    """Issue 11: the result must not depend on where the rectangles fall (the first set used
    to flood the ground from frame 24 on, r2 = 0.34)."""
    video = shared_data / "muybridge-race-horse" / "race_horse_loop.mp4"
    assert main(["analyze", str(video), "--out", str(tmp_path), *drawn]) == 0
    data = json.loads((tmp_path / "analysis.json").read_text())
    assert abs(data["period_frames"] - 36.0) <= 1.0
    assert min(data["correlations"][:2]) >= 0.8, data["correlations"]
    states = json.loads((tmp_path / "segmentation.json").read_text())["frames"]
    assert len(states) == 540 and not any(s["lost"] for s in states)


@pytest.mark.slow
@pytest.mark.parametrize("clip", ["bear", "dog", "goat"])
def test_davis_from_one_box_and_scripted_strokes(shared_data, clip):
    """From the reference box alone, then one scripted stroke per 10 frames: the box alone
    must find most of the animal, and the strokes must not lower the clip by more than the
    0.01 that chance moves a clip (docs/segmentation.md; with the salient-object network the
    bear reads 0.953 from the box and 0.952 after the strokes: a stroke has little left to mend;
    figures in docs/benchmarks.md, where the issue's targets, 0.85 and 0.92, are not all met
    yet). How fast a correction runs is the segmentation benchmark's to measure, not a timed
    assertion here."""
    from gaitcore.bench.scripted_user import padded_box, run_scripted_user
    from gaitcore.footage.image_folder import read_mask_folder
    from gaitcore.footage.sources import open_frames
    from gaitcore.silhouettes.roto import RotoSegmentation

    root = shared_data / f"davis-{clip}"
    refs = [m > 0 for m in read_mask_folder(root / "Annotations")]
    seg = RotoSegmentation(open_frames(root / "JPEGImages"), box=padded_box(refs[0]))
    seg.run()
    run = run_scripted_user(seg, refs, len(refs) // 10)
    assert run.ious[0].mean() >= 0.8
    assert run.ious[-1].mean() >= run.ious[0].mean() - 0.01
