"""Export: ``gaitcore animate --bvh/--glb/--fps/--csv-time``, the exporter table and the preview
video, end to end from a synthetic canter, and one-line errors for bad skeletons and keys."""

from __future__ import annotations

import csv
import json
import struct
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh

from gaitcore.cli import main
from gaitcore.errors import GaitInputError
from gaitcore.io import export
from gaitcore.io.bvh.reader import read_bvh
from gaitcore.io.export import EXPORTERS, export_animation, write_preview_video
from gaitcore.io.pose_table import PoseTable, read_pose_table
from gaitcore.progress import Cancelled
from gaitcore.rig.templates import load_template
from tests.gaitcore.walker import walker_clip, write_mask_folder

bvhio = pytest.importorskip("bvhio")
HORSE = load_template("horse")
N_FRAMES = 60  # two canter cycles: enough to cut a loop


def _error_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    return err


def _glb_json(path: Path) -> dict:
    raw = path.read_bytes()
    (length,) = struct.unpack_from("<I", raw, 12)
    return json.loads(raw[20:20 + length])


def _write_keys(path: Path, header: list[str], rows: list[list[str]]) -> Path:
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows([header, *rows])
    return path


@pytest.fixture(scope="module")
def canter(tmp_path_factory) -> dict:
    """synth -> analyze -> KEYS.csv from the true poses of the key frames."""
    root = tmp_path_factory.mktemp("canter")
    assert main(["synth", "--gait", "canter", "--frames", str(N_FRAMES), "--out", str(root / "syn"),
                 "--width", "160", "--height", "120"]) == 0
    assert main(["analyze", str(root / "syn" / "masks"), "--out", str(root / "an")]) == 0
    keys = json.loads((root / "an" / "analysis.json").read_text())["key_frames"]
    with (root / "syn" / "poses.csv").open() as fh:
        rows = list(csv.reader(fh))
    kp = _write_keys(root / "keys.csv", rows[0], [rows[f + 1] for f in keys])
    return {"root": root, "analysis": root / "an" / "analysis.json", "keys": keys,
            "key_poses": kp, "skeleton": root / "syn" / "skeleton.json",
            "truth": read_pose_table(root / "syn" / "poses.csv")}


@pytest.mark.gl
def test_animate_exports_bvh_and_glb(canter, tmp_path):
    out = tmp_path / "curves.csv"
    assert main(["animate", str(canter["analysis"]), "--key-poses", str(canter["key_poses"]),
                 "--out", str(out), "--bvh", str(tmp_path / "a.bvh"),
                 "--glb", str(tmp_path / "a.glb"), "--skeleton", str(canter["skeleton"]),
                 "--fps", "30", "--root", "as-keys", "--no-ground-contact"]) == 0
    # The contract of docs/command.md: CURVES.csv has exactly the columns of KEYS.csv.
    header = out.read_text().splitlines()[0]
    assert header == canter["key_poses"].read_text().splitlines()[0]
    curves = read_pose_table(out)
    # BVH, by an independent reader: every rotating joint, one keyframe per frame, 1/30 s.
    bvh = bvhio.readAsBvh(str(tmp_path / "a.bvh"))
    assert bvh.FrameCount == N_FRAMES and bvh.FrameTime == pytest.approx(1 / 30, abs=1e-7)
    names = []
    stack = [bvh.Root]
    while stack:
        j = stack.pop()
        names.append(j.Name)
        stack.extend(j.Children)
    assert {j.name for j in HORSE.joints if j.channels} <= set(names)
    # ... and by ours: at the key frames the raw interpolation is the true pose.
    skel, table, fps = read_bvh(tmp_path / "a.bvh")
    assert fps == 30.0 and len(table.frames) == N_FRAMES
    keys = canter["keys"]
    np.testing.assert_allclose(skel.joint_positions(table.values[keys]),
                               skel.joint_positions(_reorder(canter["truth"], skel)[keys]),
                               atol=1e-5)
    # glTF: loads, has every joint in its skin and a key per frame at f / 30 s.
    assert isinstance(trimesh.load(tmp_path / "a.glb"), trimesh.Scene)
    doc = _glb_json(tmp_path / "a.glb")
    assert len(doc["skins"][0]["joints"]) == HORSE.n_joints
    times = doc["accessors"][doc["animations"][0]["samplers"][0]["input"]]
    assert times["count"] == N_FRAMES
    assert times["max"][0] == pytest.approx((N_FRAMES - 1) / 30, rel=1e-6)
    assert curves.values.shape == (N_FRAMES, HORSE.n_channels)


def _reorder(table: PoseTable, skel) -> np.ndarray:
    """Columns of ``table`` as ``skel.channel_names``, the root's position made absolute."""
    values = table.values[:, [table.columns.index(c) for c in skel.channel_names]].copy()
    values[:, :3] += HORSE.offsets[0] - skel.offsets[0]
    return values


@pytest.mark.gl
def test_csv_time_column_and_a_bvh_skeleton(canter, tmp_path):
    """--csv-time adds time_s; --skeleton takes a BVH, here the one just exported."""
    args = ["animate", str(canter["analysis"]), "--key-poses", str(canter["key_poses"])]
    assert main(args + ["--out", str(tmp_path / "c.csv"), "--bvh", str(tmp_path / "rig.bvh"),
                        "--skeleton", str(canter["skeleton"])]) == 0
    assert main(args + ["--out", str(tmp_path / "t.csv"), "--csv-time", "--fps", "12.5",
                        "--glb", str(tmp_path / "b.glb"),
                        "--skeleton", str(tmp_path / "rig.bvh")]) == 0
    with (tmp_path / "t.csv").open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0][:3] == ["frame", "time_s", "root.tx"] and len(rows) == N_FRAMES + 1
    np.testing.assert_allclose([float(r[1]) for r in rows[1:]], np.arange(N_FRAMES) / 12.5)
    doc = _glb_json(tmp_path / "b.glb")
    assert len(doc["skins"][0]["joints"]) == HORSE.n_joints
    assert len(doc["meshes"][0]["primitives"]) == 1  # default bone shapes for a BVH rig


@pytest.mark.gl
def test_defaults_go_forward_with_feet_on_the_ground(canter, tmp_path, capsys):
    assert main(["animate", str(canter["analysis"]), "--key-poses", str(canter["key_poses"]),
                 "--out", str(tmp_path / "c.csv"), "--bvh", str(tmp_path / "a.bvh"),
                 "--skeleton", str(canter["skeleton"])]) == 0
    out = capsys.readouterr().out
    assert "root forward" in out and "feet planted" in out and "L_fore_toe:" in out
    skel, table, _ = read_bvh(tmp_path / "a.bvh")
    world = skel.joint_positions(table.values)
    assert np.diff(world[:, 0, 0]).min() > 0  # the root never steps back
    steps = np.diff(world[:, 0, 0])
    assert np.ptp(steps) < 1e-5  # constant speed (to the BVH's 6 decimals)
    feet = [skel.joint_index(f"{s}_{leg}_hoof_end") for s in "LR" for leg in ("fore", "hind")]
    assert world[:, feet, 1].min() > -0.005


@pytest.mark.gl
def test_a_loop_closes_on_itself_in_every_format(canter, tmp_path):
    assert main(["animate", str(canter["analysis"]), "--key-poses", str(canter["key_poses"]),
                 "--out", str(tmp_path / "c.csv"), "--bvh", str(tmp_path / "a.bvh"),
                 "--glb", str(tmp_path / "a.glb"), "--skeleton", str(canter["skeleton"]),
                 "--loop", "--bone-names", "rigify"]) == 0
    period = round(json.loads(canter["analysis"].read_text())["period_frames"])
    curves = read_pose_table(tmp_path / "c.csv")
    assert len(curves.frames) == period + 1
    np.testing.assert_allclose(curves.values[-1], curves.values[0], atol=1e-12)
    _, table, _ = read_bvh(tmp_path / "a.bvh")
    assert len(table.frames) == period + 1
    np.testing.assert_allclose(table.values[-1], table.values[0], atol=1e-6)
    tx = table.values[:, table.columns.index("root.tx")]
    assert np.all(tx == tx[0])  # in place: no horizontal root motion at all
    doc = _glb_json(tmp_path / "a.glb")
    times = doc["accessors"][doc["animations"][0]["samplers"][0]["input"]]
    assert times["count"] == period + 1 and times["max"][0] == pytest.approx(period / 24)
    assert {n["name"] for n in doc["nodes"]} >= {"hip.L", "fore_toe.R", "spine1"}


# ---------------------------------------------------------------- bad input (no OpenGL)
@pytest.fixture(scope="module")
def walker_analysis(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("walker")
    masks = write_mask_folder(root / "masks", walker_clip(40))
    assert main(["analyze", str(masks), "--out", str(root / "an")]) == 0
    keys = json.loads((root / "an" / "analysis.json").read_text())["key_frames"]
    skel = root / "horse.json"
    HORSE.to_json(skel)
    full = _write_keys(root / "full.csv", ["frame", *HORSE.channel_names],
                       [[str(f)] + ["0.0"] * HORSE.n_channels for f in keys])
    partial = [c for c in HORSE.channel_names if not c.startswith(("L_hock", "tail2"))]
    part = _write_keys(root / "part.csv", ["frame", *partial],
                       [[str(f)] + ["0.0"] * len(partial) for f in keys])
    return {"analysis": root / "an" / "analysis.json", "skeleton": skel, "full": full,
            "partial": part}


def _animate(w: dict, keys: str, tmp_path: Path, *extra: str) -> int:
    return main(["animate", str(w["analysis"]), "--key-poses", str(w[keys]),
                 "--out", str(tmp_path / "c.csv"), *extra])


def test_export_without_skeleton(walker_analysis, tmp_path, capsys):
    assert _animate(walker_analysis, "full", tmp_path, "--glb", str(tmp_path / "x.glb")) == 2
    assert "--glb needs --skeleton" in _error_line(capsys)
    assert _animate(walker_analysis, "full", tmp_path, "--bvh", str(tmp_path / "x.bvh")) == 2
    assert "--bvh needs --skeleton" in _error_line(capsys)


@pytest.mark.parametrize("flag", ["--bvh", "--glb"])
def test_key_poses_missing_joints_are_listed(walker_analysis, tmp_path, capsys, flag):
    out = tmp_path / f"x{flag[1:]}"
    assert _animate(walker_analysis, "partial", tmp_path, flag, str(out),
                    "--skeleton", str(walker_analysis["skeleton"])) == 2
    err = _error_line(capsys)
    assert "lack 6 of the 117 channels" in err
    for ch in ("L_hock.rz", "L_hock.rx", "L_hock.ry", "tail2.rz", "tail2.rx", "tail2.ry"):
        assert ch in err
    assert not out.exists() and not (tmp_path / "c.csv").exists()  # checked before any work


@pytest.mark.parametrize("text, message", [
    (("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Qrotation\n}\n"
      "MOTION\nFrames: 0\nFrame Time: 0.04\n"), "line 5: unknown channel 'Qrotation'"),
    (("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\nJOINT b\n{\nOFFSET 1 0 0\n"
      "CHANNELS 1 Zrotation\n}\nMOTION\nFrames: 0\nFrame Time: 0.04\n"), "never closed"),
])
def test_bad_bvh_as_skeleton(walker_analysis, tmp_path, capsys, text, message):
    (tmp_path / "rig.bvh").write_text(text)
    assert _animate(walker_analysis, "full", tmp_path, "--bvh", str(tmp_path / "x.bvh"),
                    "--skeleton", str(tmp_path / "rig.bvh")) == 2
    assert message in _error_line(capsys)


def test_bad_fps(walker_analysis, tmp_path, capsys):
    assert _animate(walker_analysis, "full", tmp_path, "--fps", "0") == 2
    assert "--fps must be a number of frames per second from 0.001 to 10000" in _error_line(capsys)


def test_default_curves_keep_the_key_columns(walker_analysis, tmp_path):
    assert _animate(walker_analysis, "full", tmp_path, "--fps", "50") == 0
    header = (tmp_path / "c.csv").read_text().splitlines()[0]
    assert header == "frame," + ",".join(HORSE.channel_names)


# ---------------------------------------------------------------- the exporter table
def test_export_animation_picks_the_format_by_suffix(tmp_path):
    poses = np.random.default_rng(0).normal(0, 5, (4, HORSE.n_channels))
    table = PoseTable(np.arange(4), HORSE.channel_names, poses)
    assert set(EXPORTERS) == {".csv", ".bvh", ".glb"}
    export_animation(tmp_path / "a.CSV", None, table, 20.0)
    assert (tmp_path / "a.CSV").read_text().splitlines()[0].startswith("frame,time_s,root.tx,")
    export_animation(tmp_path / "a.bvh", HORSE, table, 20.0)
    assert read_bvh(tmp_path / "a.bvh")[2] == 20.0
    export_animation(tmp_path / "a.glb", HORSE, table, 20.0)
    assert _glb_json(tmp_path / "a.glb")["asset"]["version"] == "2.0"
    with pytest.raises(GaitInputError, match=r"unknown file type '\.fbx'; use one of \.csv"):
        export_animation(tmp_path / "a.fbx", HORSE, table, 20.0)
    with pytest.raises(GaitInputError, match=r"\.glb export needs a skeleton"):
        export_animation(tmp_path / "b.glb", None, table, 20.0)
    short = PoseTable(np.arange(4), HORSE.channel_names[:-20], poses[:, :-20])
    with pytest.raises(GaitInputError, match=r"lack 20 of the 117 channels.*and 8 more"):
        export_animation(tmp_path / "b.bvh", HORSE, short, 20.0)


# ---------------------------------------------------------------- preview video
def _preview_inputs(n: int):
    poses = np.zeros((n, HORSE.n_channels))
    poses[:, HORSE.channel_index("R_shoulder.rz")] = np.linspace(-30, 30, n)
    footage = (np.full((90, 120), 255 * (i % 2), np.uint8) for i in range(n + 3))
    return footage, poses


@pytest.mark.gl
def test_preview_video_puts_footage_beside_the_skeleton(tmp_path):
    footage, poses = _preview_inputs(6)
    calls = []
    result = write_preview_video(tmp_path / "p.mp4", footage, HORSE, poses, 12.0,
                                 progress=lambda d, t: calls.append((d, t)) or True)
    assert ((result.path, result.codec, result.frames, result.note)
            == (tmp_path / "p.mp4", "mp4v", 6, None))
    assert calls[0] == (0, 6) and calls[-1] == (6, 6)
    frames = _read_video(result.path)
    assert len(frames) == 6 and frames[0].shape == (90, 120 + 120, 3)  # footage at its size
    assert frames[1][45, 60].mean() > 200 and frames[0][45, 60].mean() < 30  # the footage
    panel = frames[0][:, 120:].astype(int)
    assert (np.abs(panel - panel[2, 2]).sum(axis=2) > 60).sum() > 300  # a horse on the sky


@pytest.mark.gl
def test_preview_video_draws_the_skeleton_over_the_footage_where_it_was_fitted(tmp_path):
    from gaitcore.project.document import FootageFit
    from gaitcore.project.footage_fit import footage_maps

    n, size = 3, (200, 150)
    poses = np.zeros((n, HORSE.n_channels))
    black = (np.zeros((size[1], size[0]), np.uint8) for _ in range(n))
    maps = footage_maps(range(n), HORSE, None, size)
    result = write_preview_video(tmp_path / "p.mp4", black, HORSE, poses, footage_from_world=maps)
    view = _read_video(result.path)[0][:, : size[0]].astype(int)
    drawn = np.argwhere(view.sum(axis=2) > 150)
    assert len(drawn) > 200  # bones over the black footage
    # centred as the automatic placement puts it: the skeleton's centre on the frame's
    assert abs(drawn[:, 1].mean() - size[0] / 2) < 25 and abs(drawn[:, 0].mean() - size[1] / 2) < 25
    flipped = footage_maps(range(n), HORSE, None, size, FootageFit(flip=True))
    black = (np.zeros((size[1], size[0]), np.uint8) for _ in range(n))
    result = write_preview_video(tmp_path / "q.mp4", black, HORSE, poses,
                                 footage_from_world=flipped)
    mirror = _read_video(result.path)[0][:, : size[0]].astype(int)
    assert np.abs(mirror[:, ::-1] - view).mean() < 0.5 * np.abs(mirror - view).mean()


def _read_video(path):
    cap = cv2.VideoCapture(str(path))
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    cap.release()
    return frames


@pytest.mark.gl
def test_preview_video_falls_back_to_mjpg(tmp_path, monkeypatch):
    monkeypatch.setattr(export, "VIDEO_CODECS", (("XXXX", None), ("MJPG", ".avi")))
    footage, poses = _preview_inputs(2)
    result = write_preview_video(tmp_path / "p.mp4", footage, HORSE, poses)
    assert result.path == tmp_path / "p.avi" and result.codec == "MJPG"
    assert "XXXX is not available" in result.note and "p.avi" in result.note
    assert result.path.stat().st_size > 0 and not (tmp_path / "p.mp4").exists()


@pytest.mark.gl
def test_preview_video_cancel_and_short_footage_leave_no_file(tmp_path):
    footage, poses = _preview_inputs(5)
    with pytest.raises(Cancelled, match="cancelled at frame 2"):
        write_preview_video(tmp_path / "p.mp4", footage, HORSE, poses,
                            progress=lambda d, t: d < 2)
    assert not (tmp_path / "p.mp4").exists()
    with pytest.raises(GaitInputError, match="footage has 3 frames but there are 5 poses"):
        write_preview_video(tmp_path / "p.mp4", iter(list(_preview_inputs(0)[0])), HORSE, poses)
    assert not (tmp_path / "p.mp4").exists()
