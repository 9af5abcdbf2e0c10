import numpy as np
import pytest

from gaitcore import GaitInputError
from gaitcore.io.pose_table import PoseTable, read_pose_table, write_pose_table


def test_round_trip(tmp_path):
    t = PoseTable(np.array([3, 7]), ("a.rz", "b.rz"), np.array([[1.5, -2.0], [0.1, 1e-7]]))
    write_pose_table(tmp_path / "p.csv", t)
    back = read_pose_table(tmp_path / "p.csv")
    assert back.columns == t.columns
    np.testing.assert_array_equal(back.frames, t.frames)
    np.testing.assert_array_equal(back.values, t.values)


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "empty"),
        ("time,a\n1,2\n", "first column must be 'frame'"),
        ("frame\n1\n", "no channel columns"),
        ("frame,a\n1,x\n", "'x' is not a number"),
        ("frame,a\n1,nan\n", "missing or NaN"),
        ("frame,a\n1,\n", "not a number"),
        ("frame,a\n1,2\n1,3\n", "listed twice"),
        ("frame,a\n1.5,2\n", "whole numbers"),
        ("frame,a,b\n1,2\n", "2 values for 3 columns"),
        ("frame,a,a\n1,2,3\n", "duplicate column"),
    ],
)
def test_bad_files(tmp_path, text, message):
    (tmp_path / "p.csv").write_text(text)
    with pytest.raises(GaitInputError, match=message):
        read_pose_table(tmp_path / "p.csv")


def test_missing_file(tmp_path):
    with pytest.raises(GaitInputError, match="not found"):
        read_pose_table(tmp_path / "nope.csv")


def test_a_motion_that_is_not_a_number_is_never_written(tmp_path):
    from gaitcore.errors import GaitInputError
    from gaitcore.io.pose_table import PoseTable

    with pytest.raises(GaitInputError, match="frame 12, b.rz"):
        PoseTable(np.array([11, 12]), ("a.rz", "b.rz"), np.array([[0.0, 1.0], [2.0, np.inf]]))
