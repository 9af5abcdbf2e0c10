"""The batch's manifest, its one-clip task and its summary, without Dask."""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest

from gaitcore.cli import main
from gaitcore.errors import GaitInputError
from gaitcore.project.batch import (
    ClipSummary,
    analyze_clip,
    finished_result,
    pending,
    read_summary,
    write_summary,
)
from gaitcore.project.manifest import ClipSpec, read_manifest, spec_from_dict
from gaitcore.project.storage import load_project
from gaitcore.silhouettes.annotations import Rect
from tests.gaitcore.walker import walker_clip, write_mask_folder


@pytest.fixture(scope="module")
def masks(tmp_path_factory) -> Path:
    return write_mask_folder(tmp_path_factory.mktemp("lib") / "walker", walker_clip(90))


def _manifest(folder: Path, text: str) -> Path:
    path = folder / "manifest.csv"
    path.write_text(text, encoding="utf-8")
    return path


def test_manifest_rows_are_read_relative_to_the_manifest(masks):
    path = _manifest(masks.parent, 'clip,path,box,start,stop,fps\na,walker,"1,2,30,40",5,60,12.5\n'
                     ',walker,,,,\n')
    m = read_manifest(path)
    assert m.problems == ()
    assert [c.clip for c in m.clips] == ["a", "walker"]
    a = m.clips[0]
    assert a.path == masks.absolute() and a.box == Rect(1, 2, 30, 40)
    assert (a.start, a.stop, a.fps, a.line) == (5, 60, 12.5, 2)


def test_bad_rows_are_reported_one_line_each_and_the_rest_kept(masks):
    path = _manifest(masks.parent, "clip,path,box,start,stop,fps,strat\n"
                     "ok,walker,,,,,\n"
                     "gone,missing.mp4,,,,,\n"
                     'box,walker,"1,2,3",,,,\n'
                     "col,walker,,,,,10\n"
                     "trim,walker,,9,3,,\n"
                     "rate,walker,,,,fast,\n"
                     "ok,walker,,,,,\n"
                     "many,walker,,,,,,extra\n")
    m = read_manifest(path)
    assert [c.clip for c in m.clips] == ["ok"]
    by_line = {p.line: p.message for p in m.problems}
    assert sorted(by_line) == [3, 4, 5, 6, 7, 8, 9]
    assert "missing.mp4 does not exist" in by_line[3] and m.problems[0].path == "missing.mp4"
    assert "'1,2,3' is not four integers" in by_line[4]
    assert "unknown column 'strat'" in by_line[5]
    assert "stop 3 is not after start 9" in by_line[6]
    assert "fps 'fast'" in by_line[7]
    assert "repeats line 2" in by_line[8]
    assert "cells but the header has" in by_line[9]
    assert all("\n" not in message for message in by_line.values())


@pytest.mark.parametrize("text, expected", [
    (None, "manifest not found"),
    ("clip,box\nx,1\n", "no 'path' column"),
    ("path,box\n\n", "has no clips"),
])
def test_a_manifest_that_cannot_be_read_is_one_error(tmp_path, text, expected):
    path = tmp_path / "manifest.csv"
    if text is not None:
        path.write_text(text, encoding="utf-8")
    with pytest.raises(GaitInputError, match=expected):
        read_manifest(path)


def test_the_command_exits_2_with_one_line_for_a_bad_manifest(tmp_path, capsys):
    assert main(["batch", str(tmp_path / "none.csv"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "manifest not found" in err
    only_bad = _manifest(tmp_path, "path\nmissing.mp4\n")
    assert main(["batch", str(only_bad), "--out", str(tmp_path / "out")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert "line 2: missing.mp4 does not exist" in lines[0] and "none of the 1 rows" in lines[1]


def test_analyze_clip_writes_a_whole_folder_and_a_done_row(masks, tmp_path):
    spec = ClipSpec("w", masks.absolute(), start=5, stop=85)
    row = analyze_clip(spec, tmp_path)
    assert row.status == "done" and row.frames == 80 and row.error == ""
    # The best cycle comes from the cycle finder over the whole clip: a steady walk.
    assert row.cycle_start <= 5 and row.cycle_stop >= 85
    assert row.usable is (row.r1 >= 0.6 and row.r2 >= 0.6)
    folder = tmp_path / "w"
    assert sorted(p.name for p in folder.iterdir()) == [
        "analysis.json", "clip.gaitproj", "clip.gaitproj.d", "result.json"]
    assert json.loads((folder / "analysis.json").read_text())["n_frames"] == 80
    project = load_project(folder / "clip.gaitproj")
    assert (project.frame_start, project.frame_stop) == (5, 85)
    assert project.silhouettes.n_frames == 90  # the whole clip; the trim limits the analysis
    assert [p.name for p in tmp_path.iterdir()] == ["w"]  # no temporary folder left
    assert finished_result(tmp_path, spec) == row
    assert finished_result(tmp_path, ClipSpec("w", masks.absolute(), start=6, stop=85)) is None


def test_a_clip_that_fails_is_a_row_with_one_line(tmp_path):
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"no video here" * 50)
    spec = ClipSpec("junk", junk, box=Rect(1, 1, 10, 10))
    row = analyze_clip(spec, tmp_path / "out")
    assert row.status == "failed" and "cannot open video" in row.error
    assert "\n" not in row.error
    assert finished_result(tmp_path / "out", spec) is None  # failures run again
    assert (tmp_path / "out" / "junk" / "clip.gaitproj").is_file()


def test_colour_footage_without_a_box_fails_with_advice(tmp_path):
    import cv2
    import numpy as np

    folder = tmp_path / "colour"
    folder.mkdir()
    for i in range(3):
        cv2.imwrite(str(folder / f"{i}.png"), np.full((20, 30, 3), (10 * i, 90, 30), np.uint8))
    row = analyze_clip(ClipSpec("c", folder), tmp_path / "out")
    assert row.status == "failed" and "rectangle" in row.error


def test_summary_round_trips_through_csv_and_json(masks, tmp_path):
    spec = ClipSpec("a", masks.absolute(), box=Rect(1, 2, 3, 4), start=2, stop=50, fps=25.0)
    rows = [ClipSummary("a", "done", str(spec.path), spec, frames=48, usable=True, verdict="usable",
                        period_frames=12.25, r1=0.9, r2=0.8, cycle_start=2, cycle_stop=50),
            pending(ClipSpec("b", masks.absolute())),
            ClipSummary("line-4", "bad row", "", error="line 4: bad box")]
    write_summary(tmp_path, rows, manifest=tmp_path / "m.csv")
    for name in ("summary.csv", "summary.json"):
        assert read_summary(tmp_path / name) == tuple(rows)
    assert spec_from_dict(spec.to_dict()) == spec
    with pytest.raises(GaitInputError, match="batch summary not found"):
        read_summary(tmp_path / "m.csv")


class _Terminal:
    def __init__(self, tty: bool) -> None:
        self.text, self._tty = "", tty

    def isatty(self) -> bool:
        return self._tty

    def write(self, s: str) -> None:
        self.text += s

    def flush(self) -> None:
        pass


def test_the_progress_bar_redraws_one_line_on_a_terminal_and_prints_lines_elsewhere():
    from gaitcore.project.batch_command import TerminalBar

    tty = _Terminal(True)
    bar = TerminalBar(tty)
    assert bar.update(3, 12) is True
    bar.line("w3: usable")
    bar.close()
    assert "\r[#######.......................] 3/12 clips" in tty.text
    assert "w3: usable\n" in tty.text and tty.text.endswith("\n")
    plain = _Terminal(False)
    bar = TerminalBar(plain)
    bar.update(3, 12)
    bar.line("w3: usable")
    bar.close()
    assert plain.text == "w3: usable\n"


def test_worker_count_and_an_unreachable_scheduler_are_one_line_errors(masks, tmp_path, capsys,
                                                                       monkeypatch):
    from gaitcore.project import batch_run

    manifest = _manifest(masks.parent, "path\nwalker\n")
    out = str(tmp_path / "out")
    assert main(["batch", str(manifest), "--out", out, "--workers", "0"]) == 2
    assert "--workers must be at least 1" in capsys.readouterr().err
    monkeypatch.setattr(batch_run, "CONNECT_TIMEOUT_S", 1.0)
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    assert main(["batch", str(manifest), "--out", out, "--scheduler",
                 f"tcp://127.0.0.1:{port}"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.splitlines()[-1].startswith("gaitcore: error: cannot reach the Dask scheduler")
    assert "Traceback" not in err


def test_clip_ids_never_take_the_batch_s_own_files_or_too_long_a_name(masks):
    long_id = "x" * 300
    path = _manifest(masks.parent, f"clip,path\nsummary.json,walker\n{long_id},walker\n"
                     "fine,walker\n")
    m = read_manifest(path)
    assert [c.clip for c in m.clips] == ["fine"]
    said = " ".join(p.message for p in m.problems)
    assert "the batch's own file" in said and "cannot name a folder" in said
    (masks.parent / "summary.json").mkdir(exist_ok=True)  # a clip folder named so by its path
    derived = read_manifest(_manifest(masks.parent, "clip,path\n,summary.json\n"))
    assert [c.clip for c in derived.clips] == ["summary.json-clip"]


def test_a_second_batch_into_the_same_folder_is_refused_while_the_first_holds_it(tmp_path):
    from gaitcore.project.batch_run import batch_lock

    with batch_lock(tmp_path):
        with pytest.raises(GaitInputError, match="another batch is writing"):
            with batch_lock(tmp_path):
                pass
    with batch_lock(tmp_path):  # let go when the first ended
        pass


_DONE = {"format": "gaitstudio-batch-clip", "version": 1}


@pytest.mark.parametrize("damage", [
    "box -1", "deep nesting", "integer of 5000 digits", "FIFO", "folder", "clip not a row",
    "infinite period", "unsafe clip id"])
def test_a_damaged_clip_result_runs_the_clip_again_and_never_blocks(masks, tmp_path, damage):
    import os

    spec = ClipSpec("w", masks.absolute())
    row = analyze_clip(spec, tmp_path)
    result = tmp_path / "w" / "result.json"
    stored = json.loads(result.read_text())["clip"]
    result.unlink()
    if damage == "FIFO":
        os.mkfifo(result)
    elif damage == "folder":
        result.mkdir()
    else:
        text = {
            "box -1": json.dumps({**_DONE, "clip": {**stored, "box": -1}}),
            "deep nesting": json.dumps({**_DONE, "clip": 0}).replace("0}", "[" * 100_000
                                                                      + "]" * 100_000 + "}"),
            "integer of 5000 digits": json.dumps({**_DONE, "clip": stored}).replace(
                '"frames": 90', '"frames": ' + "9" * 5000),
            "clip not a row": json.dumps({**_DONE, "clip": [stored]}),
            "infinite period": json.dumps({**_DONE, "clip": {**stored, "period": 1e400}}),
            "unsafe clip id": json.dumps({**_DONE, "clip": {**stored, "clip": "../w"}}),
        }[damage]
        result.write_text(text)
    assert finished_result(tmp_path, spec) is None
    assert analyze_clip(spec, tmp_path) == row  # the re-run replaces the damaged folder
    assert finished_result(tmp_path, spec) == row
    assert [p.name for p in tmp_path.iterdir()] == ["w"]


@pytest.mark.parametrize("clips", [
    5, [[1]], [{"clip": "a", "status": "done", "path": "x", "box": -1}],
    [{"clip": "a", "status": "done", "path": "x", "r1": {"a": 1}}],
    [{"clip": "../../etc", "status": "failed", "path": "x"}],
    [{"clip": "a", "status": "done", "path": "x", "frames": 1e400}]])
def test_a_summary_of_the_wrong_types_is_one_error(tmp_path, clips):
    path = tmp_path / "summary.json"
    path.write_text(json.dumps({"format": "gaitstudio-batch", "clips": clips}))
    with pytest.raises(GaitInputError) as caught:
        read_summary(path)
    assert "\n" not in str(caught.value)


def test_a_summary_that_is_a_fifo_or_nests_deeply_is_one_error(tmp_path):
    import os

    deep = tmp_path / "summary.json"
    deep.write_text('{"format": "gaitstudio-batch", "clips": ' + "[" * 100_000 + "]" * 100_000
                    + "}")
    with pytest.raises(GaitInputError, match="too deeply"):
        read_summary(deep)
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    with pytest.raises(GaitInputError, match="not a regular file"):
        read_summary(fifo)


def test_a_manifest_that_is_a_pipe_or_dev_zero_is_one_error_not_a_hang(tmp_path, capsys):
    import os

    os.mkfifo(tmp_path / "m.csv")
    (tmp_path / "zero.csv").symlink_to("/dev/zero")
    for name in ("m.csv", "zero.csv"):
        with pytest.raises(GaitInputError, match="not a regular file"):
            read_manifest(tmp_path / name)
        assert main(["batch", str(tmp_path / name), "--out", str(tmp_path / "out")]) == 2
        assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_a_clip_done_with_another_segmentation_profile_runs_again(masks, tmp_path, capsys):
    from gaitcore.silhouettes.settings import (
        PropagationSettings,
        SegmentationSettings,
        write_settings,
    )

    spec = ClipSpec("w", masks.absolute())
    other = SegmentationSettings(propagation=PropagationSettings(saliency_every=2))
    row = analyze_clip(spec, tmp_path / "out", segmentation=other)
    assert load_project(tmp_path / "out" / "w" / "clip.gaitproj").segmentation == other
    assert finished_result(tmp_path / "out", spec, other) == row
    assert finished_result(tmp_path / "out", spec) is None  # the default profile: again
    write_settings(tmp_path / "p.json", other)
    manifest = _manifest(tmp_path, f"clip,path\nw,{masks.absolute()}\n")
    assert main(["batch", str(manifest), "--out", str(tmp_path / "out"), "--settings",
                 str(tmp_path / "p.json"), "--workers", "1"]) == 0
    assert "0 analysed, 1 skipped" in capsys.readouterr().out


def test_a_clip_path_too_long_or_of_no_user_is_a_bad_row_not_a_crash(masks):
    """Found by the widened fuzzer: a path of 400 characters escaped as OSError."""
    long_name = "9" * 400 + "walker"
    m = read_manifest(_manifest(masks.parent, f"clip,path\na,{long_name}\nb,~nobody-here/x\n"
                                              "c,walker\n"))
    assert [c.clip for c in m.clips] == ["c"]
    said = " ".join(p.message for p in m.problems)
    assert "too long" in said and "does not exist" in said
