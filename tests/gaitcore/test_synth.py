"""Rendering the synthetic horse and the ``gaitcore synth`` subcommand (needs EGL)."""

from __future__ import annotations

import argparse
import csv
import json

import cv2
import numpy as np
import pytest

from gaitcore.bench import GAITS, generate_gait
from gaitcore.bench.synth_command import add_parser
from gaitcore.errors import GaitInputError
from gaitcore.progress import Cancelled
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def horse() -> Skeleton:
    return load_template("horse")


@pytest.fixture(scope="module")
def walk_clip(horse):
    from gaitcore.rig.render import render_clip

    poses = generate_gait(horse, "walk", 80)[::10]  # two cycles, 8 frames
    return poses, *render_clip(horse, poses, width=160, height=120)


def test_render_clip_shapes_and_masks(walk_clip):
    poses, rgb, masks = walk_clip
    assert rgb.shape == (len(poses), 120, 160, 3) and rgb.dtype == np.uint8
    assert masks.shape == (len(poses), 120, 160) and masks.dtype == bool
    share = masks.mean(axis=(1, 2))
    assert np.all((share > 0.08) & (share < 0.4)), share  # a sensible part of the frame
    assert not masks[:, 0, :].any() and not masks[:, :, 0].any()  # never cut by the border
    assert not masks[:, :, -1].any()
    # the mask is exactly where the render differs from the plain background
    background = rgb[0, 0, 0]
    differs = np.any(rgb != background, axis=-1)
    agree = np.mean(differs == masks)
    assert agree > 0.98


def test_silhouette_moves_but_camera_follows(walk_clip):
    _, _, masks = walk_clip
    changed = [np.mean(masks[i] ^ masks[i + 1]) for i in range(len(masks) - 1)]
    assert min(changed) > 0.005  # legs move between frames
    cols = [np.flatnonzero(m.any(axis=0)).mean() for m in masks]
    assert np.ptp(cols) < 8  # the horse stays in frame while it walks 3 m
    feet = [np.flatnonzero(m.any(axis=1)).max() for m in masks]
    assert np.ptp(feet) <= 2  # the ground line stays put
    np.testing.assert_array_equal(masks[0], masks[4])  # one cycle later: same image


def test_camera_offsets_change_the_view(horse):
    from gaitcore.rig.render import SkeletonRenderer

    pose = horse.rest_pose()
    with SkeletonRenderer(horse, width=96, height=72) as side:
        _, m0 = side.render(pose)
    with SkeletonRenderer(horse, width=96, height=72, yaw_deg=40, elevation_deg=20) as turned:
        _, m1 = turned.render(pose)
    assert m0.any() and m1.any()
    assert np.mean(m0 ^ m1) > 0.02
    with pytest.raises(GaitInputError, match="yaw"):
        SkeletonRenderer(horse, yaw_deg=95)
    with pytest.raises(GaitInputError, match="size"):
        SkeletonRenderer(horse, width=4)


def test_progress_can_cancel(horse):
    from gaitcore.rig.render import render_clip

    seen = []

    def progress(done, total):
        seen.append((done, total))
        return done < 2

    with pytest.raises(Cancelled):
        render_clip(horse, np.zeros((5, horse.n_channels)), width=64, height=48,
                    progress=progress)
    assert seen[-1] == (2, 5)


def test_contact_sheet(horse, artifacts_dir):
    """Four frames per gait, one row each, for a person to look at."""
    from gaitcore.rig.render import render_clip

    rows, clips = [], []
    for gait, spec in GAITS.items():
        picks = np.linspace(0, spec.period_frames, 6, endpoint=False).astype(int)
        clips.append(generate_gait(horse, gait, spec.period_frames)[picks])
    rgb, masks = render_clip(horse, np.concatenate(clips), width=200, height=150)
    for g, gait in enumerate(GAITS):
        tiles = []
        for k in range(6):
            tile = cv2.cvtColor(rgb[6 * g + k], cv2.COLOR_RGB2BGR)
            cv2.putText(tile, f"{gait} {k}/6", (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                        (0, 0, 0), 1, cv2.LINE_AA)
            tiles.append(tile)
        rows.append(np.hstack(tiles))
    path = artifacts_dir / "synth_contact_sheet.png"
    assert cv2.imwrite(str(path), np.vstack(rows))
    assert cv2.imwrite(str(artifacts_dir / "synth_contact_sheet_masks.png"),
                       np.vstack([np.hstack(list(masks[6 * g: 6 * g + 6])) for g in range(4)])
                       .astype(np.uint8) * 255)
    assert masks.mean() > 0.05


def _run(argv):
    parser = argparse.ArgumentParser(prog="gaitcore")
    add_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.run(args)


def test_synth_command_writes_the_clip(tmp_path, horse):
    out = tmp_path / "clip"
    (out / "images").mkdir(parents=True)
    cv2.imwrite(str(out / "images" / "00009.png"), np.zeros((4, 4), np.uint8))  # stale frame
    assert _run(["synth", "--gait", "canter", "--frames", "3", "--out", str(out),
                 "--width", "96", "--height", "72", "--noise", "0.5", "--seed", "3",
                 "--overwrite"]) == 0
    images = sorted(p.name for p in (out / "images").iterdir())
    assert images == ["00000.png", "00001.png", "00002.png"]
    assert sorted(p.name for p in (out / "masks").iterdir()) == images
    img = cv2.imread(str(out / "images" / "00001.png"), cv2.IMREAD_UNCHANGED)
    mask = cv2.imread(str(out / "masks" / "00001.png"), cv2.IMREAD_UNCHANGED)
    assert img.shape == (72, 96, 3) and mask.shape == (72, 96) and mask.dtype == np.uint8
    assert set(np.unique(mask)) == {0, 255} and 0.05 < np.mean(mask > 0) < 0.5
    with (out / "poses.csv").open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["frame", *horse.channel_names]
    assert [r[0] for r in rows[1:]] == ["0", "1", "2"]
    values = np.array(rows[1:], float)[:, 1:]
    np.testing.assert_allclose(values, generate_gait(horse, "canter", 3, noise_deg=0.5, seed=3))
    again = Skeleton.from_json(out / "skeleton.json")
    assert again.channel_names == horse.channel_names
    assert json.loads((out / "skeleton.json").read_text())["version"] == 1


def test_synth_command_rejects_bad_input(tmp_path):
    with pytest.raises(GaitInputError, match="frames"):
        _run(["synth", "--gait", "walk", "--frames", "0", "--out", str(tmp_path)])
    with pytest.raises(GaitInputError, match="period"):
        _run(["synth", "--gait", "walk", "--frames", "2", "--out", str(tmp_path),
              "--period", "2"])
    (tmp_path / "file").write_text("x")
    with pytest.raises(GaitInputError, match="folder"):
        _run(["synth", "--gait", "walk", "--frames", "2", "--out", str(tmp_path / "file")])
    with pytest.raises(GaitInputError, match="finite"):
        _run(["synth", "--gait", "walk", "--frames", "2", "--out", str(tmp_path / "n"),
              "--noise", "nan"])


def test_synth_never_writes_into_a_folder_with_files_unless_told(tmp_path):
    own = tmp_path / "photos" / "00001.png"
    own.parent.mkdir()
    own.write_bytes(b"the user's own picture")
    with pytest.raises(GaitInputError, match="not empty.*--overwrite"):
        _run(["synth", "--gait", "walk", "--frames", "2", "--out", str(own.parent)])
    assert own.read_bytes() == b"the user's own picture"
