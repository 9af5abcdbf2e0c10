"""The gaitcore command: the contracts in docs/command.md and one-line errors with exit status 2."""

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from gaitcore.cli import main
from tests.gaitcore.walker import walker_clip, write_mask_folder


@pytest.fixture(scope="module")
def masks(tmp_path_factory) -> Path:
    return write_mask_folder(tmp_path_factory.mktemp("walker") / "masks", walker_clip(100))


@pytest.fixture(scope="module")
def analysis_dir(masks, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("analysis")
    assert main(["analyze", str(masks), "--out", str(out)]) == 0
    return out


def _error_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    assert len(err.splitlines()) == 1, err
    return err


def test_analyze_writes_the_contract_fields(analysis_dir):
    data = json.loads((analysis_dir / "analysis.json").read_text())
    assert data["n_frames"] == 100
    assert len(data["variance_ratio"]) >= 2
    assert len(data["correlations"]) >= 5
    assert isinstance(data["usable"], bool)
    assert data["period_frames"] > 0
    assert data["key_frames"] == sorted(data["key_frames"]) and len(data["key_frames"]) == 4
    assert data["condition_number"] >= 1.0
    assert data["exact"] is True
    assert np.asarray(data["projections"]).shape == (100, 2)


def test_analyze_json_on_stdout_and_switching(masks, tmp_path, capsys):
    assert main(["analyze", str(masks), "--out", str(tmp_path), "--switching", "--pcs", "3",
                 "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["alternate_frames"]) == 4
    assert np.asarray(data["projections"]).shape == (100, 3)
    for k, a in zip(data["key_frames"], data["alternate_frames"]):
        assert abs(k - a) >= 3


def _write_keys(path: Path, frames, values) -> Path:
    lines = ["frame,hip.rz,knee.rz"] + [f"{f},{v[0]},{v[1]}" for f, v in zip(frames, values)]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_animate_is_exact_at_keys(analysis_dir, tmp_path):
    keys = json.loads((analysis_dir / "analysis.json").read_text())["key_frames"]
    values = [(10.0 * i, -5.0 * i) for i in range(len(keys))]
    kp = _write_keys(tmp_path / "keys.csv", keys, values)
    out = tmp_path / "curves.csv"
    assert main(["animate", str(analysis_dir / "analysis.json"), "--key-poses", str(kp),
                 "--out", str(out)]) == 0
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    assert rows.shape == (100, 3)
    assert out.read_text().splitlines()[0] == "frame,hip.rz,knee.rz"
    np.testing.assert_allclose(rows[keys, 1:], values, atol=1e-9)


def test_console_script_reports_bad_input_without_traceback(tmp_path):
    exe = Path(sys.executable).with_name("gaitcore")
    out = subprocess.run([str(exe), "analyze", str(tmp_path / "missing"), "--out", str(tmp_path)],
                         capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    assert "does not exist" in out.stderr


def _masks(folder: Path, frames) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i, m in enumerate(frames):
        cv2.imwrite(str(folder / f"{i:05d}.png"), m)
    return folder


def test_fewer_frames_than_keys(tmp_path, capsys):
    folder = _masks(tmp_path / "m", walker_clip(4))
    assert main(["analyze", str(folder), "--out", str(tmp_path / "o"), "--keys", "5"]) == 2
    assert "key" in _error_line(capsys)


def test_all_frames_identical(tmp_path, capsys):
    folder = _masks(tmp_path / "m", [walker_clip(1)[0]] * 12)
    assert main(["analyze", str(folder), "--out", str(tmp_path / "o")]) == 2
    assert "identical" in _error_line(capsys)


def test_fewer_than_two_distinct_frames_for_keys(tmp_path, capsys):
    a, b = walker_clip(13)[[0, 6]]
    folder = _masks(tmp_path / "m", [a] * 10 + [b] * 10)
    assert main(["analyze", str(folder), "--out", str(tmp_path / "o"), "--keys", "3",
                 "--pcs", "1"]) == 2
    assert "distinct" in _error_line(capsys)


def test_images_of_different_sizes(tmp_path, capsys):
    clip = walker_clip(10)
    folder = _masks(tmp_path / "m",
                    list(clip[:5]) + [np.zeros((50, 50), np.uint8)] + list(clip[6:]))
    assert main(["analyze", str(folder), "--out", str(tmp_path / "o")]) == 2
    assert "size" in _error_line(capsys)


def test_empty_folder(tmp_path, capsys):
    (tmp_path / "m").mkdir()
    assert main(["analyze", str(tmp_path / "m"), "--out", str(tmp_path / "o")]) == 2
    assert "empty" in _error_line(capsys)


def test_non_image_files(tmp_path, capsys):
    folder = _masks(tmp_path / "m", walker_clip(10))
    (folder / "notes.txt").write_text("hello")
    assert main(["analyze", str(folder), "--out", str(tmp_path / "o")]) == 2
    assert "not images" in _error_line(capsys)


def test_nan_in_key_poses(analysis_dir, tmp_path, capsys):
    keys = json.loads((analysis_dir / "analysis.json").read_text())["key_frames"]
    kp = _write_keys(tmp_path / "k.csv", keys,
                     [(1.0, float("nan"))] + [(0.0, 0.0)] * (len(keys) - 1))
    assert main(["animate", str(analysis_dir / "analysis.json"), "--key-poses", str(kp),
                 "--out", str(tmp_path / "c.csv")]) == 2
    assert "NaN" in _error_line(capsys)


def test_key_poses_missing_a_key_frame(analysis_dir, tmp_path, capsys):
    keys = json.loads((analysis_dir / "analysis.json").read_text())["key_frames"]
    kp = _write_keys(tmp_path / "k.csv", keys[:-1], [(0.0, 0.0)] * (len(keys) - 1))
    assert main(["animate", str(analysis_dir / "analysis.json"), "--key-poses", str(kp),
                 "--out", str(tmp_path / "c.csv")]) == 2
    assert f"lack frame(s) [{keys[-1]}]" in _error_line(capsys)


def test_key_poses_with_a_frame_that_is_not_a_key(analysis_dir, tmp_path, capsys):
    keys = json.loads((analysis_dir / "analysis.json").read_text())["key_frames"]
    extra = next(f for f in range(100) if f not in keys)
    kp = _write_keys(tmp_path / "k.csv", keys + [extra], [(0.0, 0.0)] * (len(keys) + 1))
    assert main(["animate", str(analysis_dir / "analysis.json"), "--key-poses", str(kp),
                 "--out", str(tmp_path / "c.csv")]) == 2
    assert "not key-images" in _error_line(capsys)


def test_malformed_analysis_file(tmp_path, capsys):
    (tmp_path / "a.json").write_text("{not json")
    kp = _write_keys(tmp_path / "k.csv", [0], [(0.0, 0.0)])
    assert main(["animate", str(tmp_path / "a.json"), "--key-poses", str(kp),
                 "--out", str(tmp_path / "c.csv")]) == 2
    assert "a.json is not valid JSON (line 1, column 2)" in _error_line(capsys)


def test_colour_footage_without_rectangles(tmp_path, capsys):
    folder = tmp_path / "colour"
    folder.mkdir()
    rng = np.random.default_rng(0)
    for i in range(5):
        cv2.imwrite(str(folder / f"{i}.png"), rng.integers(0, 255, (20, 30, 3), dtype=np.uint8))
    assert main(["analyze", str(folder), "--out", str(tmp_path / "o")]) == 2
    assert "--subject" in _error_line(capsys)


def test_bad_option_is_one_line(capsys):
    assert main(["analyze"]) == 2
    assert "required" in _error_line(capsys)


def test_a_folder_without_fps_says_the_rate_is_unknown_and_fps_times_the_files(masks, tmp_path,
                                                                                capsys):
    assert main(["analyze", str(masks), "--out", str(tmp_path / "a")]) == 0
    assert "frame rate: unknown" in capsys.readouterr().out
    assert json.loads((tmp_path / "a" / "analysis.json").read_text())["fps"] is None
    assert main(["analyze", str(masks), "--out", str(tmp_path / "b"), "--fps", "15"]) == 0
    assert "frame rate: unknown" not in capsys.readouterr().out
    data = json.loads((tmp_path / "b" / "analysis.json").read_text())
    assert data["fps"] == 15.0 and data["period_s"] == pytest.approx(data["period_frames"] / 15)


def test_pose_writes_a_key_pose_csv_that_animate_takes(analysis_dir, tmp_path, capsys):
    from gaitcore.io.pose_table import read_pose_table
    from gaitcore.rig.templates import load_template

    keys = tmp_path / "keys.csv"
    assert main(["pose", str(analysis_dir / "analysis.json"), "--out", str(keys)]) == 0
    table = read_pose_table(keys)
    data = json.loads((analysis_dir / "analysis.json").read_text())
    horse = load_template("horse")
    assert list(table.frames) == data["key_frames"]
    assert table.columns == tuple(horse.channel_names)
    assert np.allclose(table.values, horse.rest_pose())
    assert "gaitcore animate" in capsys.readouterr().out
    out = tmp_path / "curves.csv"
    assert main(["animate", str(analysis_dir / "analysis.json"), "--key-poses", str(keys),
                 "--out", str(out)]) == 0
    assert len(read_pose_table(out).frames) == data["n_frames"]
    assert main(["pose", str(tmp_path / "missing.json"), "--out", str(keys)]) == 2
    assert "missing.json" in _error_line(capsys)
