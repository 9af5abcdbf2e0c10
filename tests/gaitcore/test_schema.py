"""The checked reading helpers every file reader uses (gaitcore.schema)."""

from __future__ import annotations

import doctest
import os

import numpy as np
import pytest

import gaitcore.schema
from gaitcore.errors import GaitInputError
from gaitcore.schema import parse_json, read_npy, read_text


def test_the_module_examples_hold():
    assert doctest.testmod(gaitcore.schema).failed == 0


def doc(text: str):
    return parse_json(text, what="file f", advice="fix it")


@pytest.mark.parametrize("text, read, message", [
    ('{"a": {"b": [1, 2, "x"]}}', lambda d: d.key("a").key("b").array(),
     r"file f: a\.b\[2\] must be a finite number, got \"x\"; fix it"),
    ('{"a": [[1, 2], [3, 1e400]]}', lambda d: d.key("a").array(columns=2),
     r"a\[1\]\[1\] must be a finite number, got inf"),
    ('{"a": [[1, 2], [3]]}', lambda d: d.key("a").array(columns=2),
     r"a\[1\] must be a list of 2 elements, got a list of 1 element"),
    ('{"a": 9' + "9" * 400 + "}", lambda d: d.key("a").integer(lo=0, hi=10),
     "a must be a whole number from 0 to 10, got an integer of 401 digits"),
    ('{"a": true}', lambda d: d.key("a").number(), "a must be a finite number, got true"),
    ('{"a": NaN}', lambda d: d.key("a").number(lo=0, hi=1), "from 0 to 1, got nan"),
    ('{"a": 0}', lambda d: d.key("a").number(lo=0, lo_open=True), "above 0, got 0"),
    ('{"a": 2.5}', lambda d: d.key("a").integer(lo=0, hi=9), "whole number"),
    ('{"a": "x"}', lambda d: d.key("a").text(choices=("y", "z")), "one of 'y', 'z'"),
    ('{}', lambda d: d.key("a"), "file f: a is missing; fix it"),
    ('[1]', lambda d: d.key("a"), "the document must be an object, got a list of 1"),
    ('{"a": [1, 2, 3]}', lambda d: d.key("a").items(max_len=2), "a list of 0 to 2 elements"),
    ('{"a": [1, 2e400]}', lambda d: d.key("a").floats(length=2), r"a\[1\] must be a finite"),
])
def test_a_bad_value_is_named_by_its_path(text, read, message):
    with pytest.raises(GaitInputError, match=message):
        read(doc(text))


def test_good_values_come_back_as_plain_python_and_arrays():
    d = doc('{"n": 3.0, "m": null, "xy": [[1, 2.5], [3, 4]], "s": "ok", "f": [1, 2]}')
    assert d.key("n").integer(lo=0, hi=5) == 3 and d.key("m").number(optional=True) is None
    np.testing.assert_array_equal(d.key("xy").array(columns=2), [[1, 2.5], [3, 4]])
    assert d.key("s").text() == "ok" and d.key("f").floats(length=2) == (1.0, 2.0)
    assert d.key("missing", 7).integer(lo=0, hi=9) == 7


@pytest.mark.parametrize("text, words", [
    ("{", r"is not valid JSON \(line 1, column 2\); fix it"),
    ("[" * 100_000 + "]" * 100_000, "nests lists or objects too deeply"),
    ("1" * 5000, "integer of thousands of digits"),
])
def test_unparsable_json_is_one_line(text, words):
    with pytest.raises(GaitInputError, match=words) as info:
        doc(text)
    assert "\n" not in str(info.value)


def test_read_text_refuses_folders_big_files_and_bad_bytes(tmp_path):
    with pytest.raises(GaitInputError, match="is a folder"):
        read_text(tmp_path, what="pose file", max_bytes=100)
    (tmp_path / "big.txt").write_text("x" * 101)
    with pytest.raises(GaitInputError, match="MiB such a file can hold"):
        read_text(tmp_path / "big.txt", what="pose file", max_bytes=100)
    (tmp_path / "latin.txt").write_bytes(b"caf\xe9")
    with pytest.raises(GaitInputError, match="is not utf-8 text"):
        read_text(tmp_path / "latin.txt", what="pose file", max_bytes=100)
    assert read_text(tmp_path / "latin.txt", what="x", max_bytes=100, fallback="latin-1") == "café"
    with pytest.raises(GaitInputError, match="pose file not found"):
        read_text(tmp_path / "none.txt", what="pose file", max_bytes=100)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_read_text_refuses_a_pipe_without_blocking(tmp_path):
    os.mkfifo(tmp_path / "pipe")
    with pytest.raises(GaitInputError, match="not a regular file"):
        read_text(tmp_path / "pipe", what="project file", max_bytes=100)


def test_read_npy_checks_the_header_against_the_file(tmp_path):
    f = tmp_path / "a.npy"
    np.save(f, np.arange(6.0).reshape(3, 2))
    np.testing.assert_array_equal(read_npy(f, what="array", kind="f", ndim=2, max_bytes=1000),
                                  np.arange(6.0).reshape(3, 2))
    with pytest.raises(GaitInputError, match="holds a 2-D float64 array"):
        read_npy(f, what="array", kind="b", ndim=2, max_bytes=1000)
    with pytest.raises(GaitInputError, match="declares shape"):
        read_npy(f, what="array", kind="f", ndim=2, max_bytes=10)
    f.write_bytes(f.read_bytes()[:-1])
    with pytest.raises(GaitInputError,
                       match=r"declares shape \(3, 2\) \(48 bytes\) but it holds 47"):
        read_npy(f, what="array", kind="f", ndim=2, max_bytes=1000)


def test_a_footage_path_with_a_nul_byte_in_a_project_is_refused_in_one_line(tmp_path):
    import json

    from gaitcore.errors import GaitInputError
    from gaitcore.project.document import Project
    from gaitcore.project.storage import load_project, save_project
    from gaitcore.schema import check_path

    save_project(Project(), tmp_path / "p.gaitproj")
    doc = json.loads((tmp_path / "p.gaitproj").read_text())
    doc["footage"] = {"relative": "clip\u0000.mp4", "absolute": None}
    (tmp_path / "p.gaitproj").write_text(json.dumps(doc))
    with pytest.raises(GaitInputError, match="NUL byte"):
        load_project(tmp_path / "p.gaitproj")
    assert check_path(tmp_path / "new.csv", what="--out") == tmp_path / "new.csv"


def test_the_json_writer_refuses_non_finite_numbers_and_names_the_first(tmp_path):
    from gaitcore.errors import GaitInputError
    from gaitcore.project.batch import ClipSummary, write_summary
    from gaitcore.schema import dump_json

    assert dump_json({"a": [1.5]}, what="x") == '{"a": [1.5]}'
    with pytest.raises(GaitInputError, match=r"summary was not written: clips\[1\]\.r1 \(nan\)"):
        dump_json({"clips": [{"r1": 0.5}, {"r1": float("nan")}]}, what="summary")
    rows = [ClipSummary("a", "done", "x", r1=float("inf"), r2=0.5)]
    with pytest.raises(GaitInputError, match=r"clips\[0\]\.r1 \(inf\) is not a finite"):
        write_summary(tmp_path, rows, manifest=tmp_path / "m.csv")
    assert not any(tmp_path.iterdir())


def _big_inputs(folder):
    """A BVH, a pose CSV and a JSON document of some megabytes each."""
    import json

    from gaitcore.io.bvh.writer import write_bvh
    from gaitcore.io.pose_table import PoseTable, write_pose_table
    from gaitcore.rig.templates import load_template

    skel = load_template("horse")
    values = np.random.default_rng(0).normal(size=(3000, len(skel.channel_names))) * 10
    table = PoseTable(np.arange(3000), skel.channel_names, values)
    write_bvh(folder / "big.bvh", skel, table)
    write_pose_table(folder / "big.csv", table)
    doc = skel.to_dict()
    doc["joints"] *= 300
    (folder / "big.json").write_text(json.dumps(doc))


def test_text_readers_take_at_most_their_memory_per_byte(tmp_path):
    import os
    import tracemalloc

    from gaitcore.io.bvh.reader import read_bvh
    from gaitcore.io.pose_table import read_pose_table
    from gaitcore.schema import TEXT_MEMORY_PER_BYTE, read_json

    _big_inputs(tmp_path)
    for name, read in (("big.bvh", read_bvh), ("big.csv", read_pose_table),
                       ("big.json", lambda p: read_json(p, what="json", max_bytes=1 << 30))):
        path = tmp_path / name
        tracemalloc.start()
        try:
            read(path)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak <= TEXT_MEMORY_PER_BYTE * os.path.getsize(path), (name, peak)


def test_a_file_too_large_for_the_memory_left_is_refused_before_it_is_read(tmp_path,
                                                                          monkeypatch):
    """A 1.5 GB BVH once ran a 1 GiB process out of memory."""
    import gaitcore.limits
    from gaitcore.errors import GaitInputError
    from gaitcore.io.bvh.reader import read_bvh

    huge = tmp_path / "huge.bvh"
    with huge.open("wb") as fh:  # sparse: takes no disk
        fh.truncate(1_500_000_000)
    monkeypatch.setattr(gaitcore.limits, "free_memory", lambda: 1 << 30)
    with pytest.raises(GaitInputError, match=r"reading BVH file .* needs about 14\.0 GB of "
                                             r"memory and 1\.0 GB is free: is it the right"):
        read_bvh(huge)


def test_a_joint_a_billion_kilometres_away_is_refused():
    from gaitcore.errors import GaitInputError
    from gaitcore.rig.skeleton import Skeleton
    from gaitcore.rig.templates import load_template

    doc = load_template("horse").to_dict()
    doc["joints"][3]["offset"] = [1e16, 0, 0]
    with pytest.raises(GaitInputError, match="offset of 1e\\+16 m is beyond"):
        Skeleton.from_json(doc)
