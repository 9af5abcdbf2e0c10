"""Tests of frame sources (video files, GIFs, image folders) and of the mask-folder reader."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from gaitcore.errors import GaitInputError
from gaitcore.footage.image_folder import MaskWriter, iter_mask_folder, read_mask_folder
from gaitcore.footage.sources import open_frames
from gaitcore.silhouettes.annotations import Rect, Stroke

W, H = 64, 48


def frame_with_number(i: int) -> np.ndarray:
    """A frame whose mean level encodes its index (robust to lossy codecs)."""
    img = np.full((H, W, 3), 10 + 20 * i, np.uint8)
    cv2.rectangle(img, (4, 4), (20, 20), (0, 0, 255), -1)
    return img


def write_video(path: Path, n: int, fourcc: str = "MJPG", fps: float = 25.0) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, (W, H))
    assert writer.isOpened(), f"this OpenCV cannot write {fourcc}"
    for i in range(n):
        writer.write(frame_with_number(i))
    writer.release()
    return path


def level(img: np.ndarray) -> int:
    """Index back from a frame_with_number frame."""
    return int(round((float(np.median(img[30:, 30:])) - 10) / 20))


def write_folder(folder: Path, n: int, suffix: str = ".png") -> Path:
    folder.mkdir()
    for i in range(n):
        cv2.imwrite(str(folder / f"{i:05d}{suffix}"), frame_with_number(i))
    return folder


@pytest.mark.parametrize(("fourcc", "suffix"), [("MJPG", ".avi"), ("mp4v", ".mp4")])
def test_video_len_fps_size_and_random_access(tmp_path, fourcc, suffix):
    src = open_frames(write_video(tmp_path / f"clip{suffix}", 10, fourcc, fps=12.5))
    assert len(src) == 10 and src.size == (W, H) and src.shape == (H, W, 3)
    assert src.fps == pytest.approx(12.5)
    assert [level(src.frame(i)) for i in (7, 2, 3, 9, 0, -1)] == [7, 2, 3, 9, 0, 9]
    assert [level(f) for f in src] == list(range(10))


def test_frame_range_trims_and_indexes_from_start(tmp_path):
    src = open_frames(write_video(tmp_path / "clip.avi", 10), start=3, stop=8)
    assert len(src) == 5 and src.source_index(0) == 3
    assert [level(f) for f in src] == [3, 4, 5, 6, 7]
    assert level(src[4]) == 7
    with pytest.raises(IndexError):
        src.frame(5)
    assert [i for i, _ in src.iter_frames(1, 3)] == [1, 2]
    assert [level(f) for _, f in src.iter_frames(prefetch=2)] == [3, 4, 5, 6, 7]


def test_cache_is_bounded_and_frames_are_read_only(tmp_path):
    src = open_frames(write_video(tmp_path / "clip.avi", 10), cache_frames=3)
    for i in range(10):
        src.frame(i)
    assert len(src._cache) == 3
    assert src.frame(9) is src.frame(9)
    with pytest.raises(ValueError):
        src.frame(9)[0, 0, 0] = 1


def test_image_folder_sorted_by_name(tmp_path):
    folder = write_folder(tmp_path / "imgs", 6)
    (folder / ".DS_Store").write_bytes(b"junk")
    (folder / "sub").mkdir()
    src = open_frames(folder, start=1)
    assert len(src) == 5 and src.fps is None and src.size == (W, H)
    assert [level(f) for f in src] == [1, 2, 3, 4, 5]
    assert level(src.frame(0)) == 1


def test_folder_numbers_sort_by_value(tmp_path):
    folder = tmp_path / "imgs"
    folder.mkdir()
    for i in (10, 2, 1):
        cv2.imwrite(str(folder / f"frame{i}.png"), frame_with_number(i))
    assert [level(f) for f in open_frames(folder)] == [1, 2, 10]


def test_gif_is_read(tmp_path):
    path = tmp_path / "clip.gif"
    ok = cv2.imwritemulti(str(path), [frame_with_number(3 * i) for i in range(4)])
    if not ok:
        pytest.skip("this OpenCV build cannot write GIF")
    src = open_frames(path)
    # GIF has a 256-colour palette: levels come back within a step or so.
    got = [level(f) for f in src]
    assert len(src) == 4 and np.allclose(got, [0, 3, 6, 9], atol=1)


def test_missing_path(tmp_path):
    with pytest.raises(GaitInputError, match="does not exist"):
        open_frames(tmp_path / "nope.mp4")


def test_garbage_file(tmp_path):
    path = tmp_path / "clip.mp4"
    path.write_bytes(b"not a video at all" * 100)
    with pytest.raises(GaitInputError, match="cannot open video"):
        open_frames(path)


def test_truncated_file(tmp_path):
    full = write_video(tmp_path / "clip.mp4", 12, "mp4v").read_bytes()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(full[: len(full) // 2])  # the index (moov) is gone: nothing to read
    with pytest.raises(GaitInputError, match="truncated") as info:
        open_frames(cut)
    assert "\n" not in str(info.value)


def test_truncated_avi_opens_with_what_still_decodes(tmp_path):
    full = write_video(tmp_path / "clip.avi", 12).read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(full[: int(len(full) * 0.8)])
    src = open_frames(cut)
    assert 0 < len(src) < 12
    assert src.note == (f"cut.avi: its header says 12 frames but {len(src)} decode; "
                        f"all {len(src)} are used")
    assert [level(f) for f in src] == list(range(len(src)))


def _claim_frames(path: Path, claimed: int) -> Path:
    """Patch an AVI's frame counts (main header and stream header) to ``claimed``."""
    data = bytearray(path.read_bytes())
    avih, strh = data.find(b"avih"), data.find(b"strh")
    data[avih + 24 : avih + 28] = claimed.to_bytes(4, "little")  # dwTotalFrames
    data[strh + 40 : strh + 44] = claimed.to_bytes(4, "little")  # dwLength
    path.write_bytes(bytes(data))
    return path


def _write_30(path: Path) -> Path:
    """30 frames of levels 10 + 8 i (``level30`` reads them back)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (W, H))
    for i in range(30):
        writer.write(np.full((H, W, 3), 10 + 8 * i, np.uint8))
    writer.release()
    return path


def level30(img: np.ndarray) -> int:
    return int(round((float(np.median(img)) - 10) / 8))


@pytest.mark.parametrize("claimed", [40, 20])
def test_header_that_disagrees_with_the_stream_opens_every_decodable_frame(tmp_path, claimed):
    path = _claim_frames(_write_30(tmp_path / "clip.avi"), claimed)
    assert int(cv2.VideoCapture(str(path)).get(cv2.CAP_PROP_FRAME_COUNT)) == claimed
    src = open_frames(path, cache_frames=0)
    assert len(src) == 30 and f"says {claimed} frames but 30 decode" in src.note
    assert [level30(f) for f in src] == list(range(30))
    # Random access past the header's count and back, and streaming from the middle: a
    # seek that lands on another frame is caught by its timestamp.
    assert [level30(src.frame(i)) for i in (25, 5, 29, 21, 2, 28)] == [25, 5, 29, 21, 2, 28]
    assert [level30(f) for _, f in src.iter_frames(22, 26)] == [22, 23, 24, 25]
    assert [level30(f) for f in open_frames(path, start=24, stop=27)] == [24, 25, 26]


def test_a_faithful_header_gives_no_note(tmp_path):
    assert open_frames(write_video(tmp_path / "clip.avi", 6)).note is None


def test_stream_without_decodable_frames(tmp_path):
    path = write_video(tmp_path / "clip.avi", 5)
    data = bytearray(path.read_bytes())
    # Wipe the JPEG payloads (keep the AVI structure): the container opens, nothing decodes.
    pos = data.find(b"00dc")
    while pos >= 0:
        size = int.from_bytes(data[pos + 4 : pos + 8], "little")
        data[pos + 8 : pos + 8 + size] = bytes(size)
        pos = data.find(b"00dc", pos + 8 + size)
    path.write_bytes(bytes(data))
    with pytest.raises(GaitInputError, match="none of its frames decode .codec MJPG"):
        open_frames(path)


def test_video_with_zero_frames(tmp_path):
    path = tmp_path / "empty.avi"
    cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25, (W, H)).release()
    with pytest.raises(GaitInputError, match="no frames|cannot open"):
        open_frames(path)


def test_bad_frame_range(tmp_path):
    path = write_video(tmp_path / "clip.avi", 5)
    with pytest.raises(GaitInputError, match="frame range"):
        open_frames(path, start=4, stop=2)
    with pytest.raises(GaitInputError, match="frame range"):
        open_frames(path, stop=9)


def test_empty_folder(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(GaitInputError, match="empty"):
        open_frames(tmp_path / "empty")
    with pytest.raises(GaitInputError, match="empty"):
        read_mask_folder(tmp_path / "empty")


def test_folder_with_non_image_file(tmp_path):
    folder = write_folder(tmp_path / "imgs", 3)
    (folder / "notes.txt").write_text("hello")
    with pytest.raises(GaitInputError, match="not images.*notes.txt"):
        open_frames(folder)


@pytest.mark.parametrize("suffix", [".png", ".jpg", ".bmp"])
def test_folder_with_different_sizes(tmp_path, suffix):
    folder = write_folder(tmp_path / "imgs", 3, suffix)
    cv2.imwrite(str(folder / f"00001{suffix}"), np.zeros((H + 2, W, 3), np.uint8))
    with pytest.raises(GaitInputError, match="same size"):
        open_frames(folder)


def test_folder_with_damaged_image(tmp_path):
    folder = write_folder(tmp_path / "imgs", 3)
    (folder / "00001.png").write_bytes(b"\x89PNG broken")
    with pytest.raises(GaitInputError, match="cannot be read"):
        open_frames(folder)
    # A valid header with its data cut off passes the size check; reading it fails clearly.
    good = (folder / "00000.png").read_bytes()
    (folder / "00001.png").write_bytes(good[:40])
    src = open_frames(folder)
    with pytest.raises(GaitInputError, match="cannot be read"):
        src.frame(1)


def test_read_mask_folder(tmp_path):
    folder = tmp_path / "masks"
    folder.mkdir()
    for i in range(3):
        m = np.zeros((H, W), np.uint8)
        m[10:20, 5 + i : 15 + i] = 255
        cv2.imwrite(str(folder / f"{i:03d}.png"), m)
    masks = read_mask_folder(folder)
    assert masks.shape == (3, H, W) and masks.dtype == bool
    assert masks[2, 15, 7] and not masks[0, 15, 16] and masks.sum() == 300
    assert np.array_equal(np.stack(list(iter_mask_folder(folder))), masks)


def test_read_mask_folder_bad_inputs(tmp_path):
    with pytest.raises(GaitInputError, match="not a folder"):
        read_mask_folder(tmp_path / "nope")
    folder = tmp_path / "masks"
    folder.mkdir()
    cv2.imwrite(str(folder / "0.png"), np.zeros((H, W), np.uint8))
    cv2.imwrite(str(folder / "1.png"), np.zeros((H, W + 1), np.uint8))
    with pytest.raises(GaitInputError, match="same size"):
        read_mask_folder(folder)
    stream = iter_mask_folder(folder)
    assert next(stream).shape == (H, W)
    with pytest.raises(GaitInputError, match="same size"):
        next(stream)
    (folder / "1.png").unlink()
    (folder / "readme.md").write_text("x")
    with pytest.raises(GaitInputError, match="not images"):
        read_mask_folder(folder)


# -- model.py ---------------------------------------------------------------------------
def test_mask_writer_writes_every_mask_by_frame_number(tmp_path):
    rng = np.random.default_rng(3)
    masks = [(rng.random((H, W)) > 0.5).astype(np.uint8) * 255 for _ in range(20)]
    with MaskWriter(tmp_path / "out" / "masks", ahead=3) as write:
        for t, m in enumerate(masks):
            write(10 + t, m)
    names = sorted(p.name for p in (tmp_path / "out" / "masks").iterdir())
    assert names == [f"{10 + t:05d}.png" for t in range(20)]
    assert np.array_equal(read_mask_folder(tmp_path / "out" / "masks") * 255, np.array(masks))


def test_mask_writer_says_which_mask_it_could_not_write(tmp_path):
    (tmp_path / "masks" / "00002.png").mkdir(parents=True)  # a folder where a mask goes
    with pytest.raises(GaitInputError, match="cannot write the mask .*00002.png"):
        with MaskWriter(tmp_path / "masks") as write:
            for t in range(4):
                write(t, np.zeros((H, W), np.uint8))
    (tmp_path / "file").write_text("not a folder")
    with pytest.raises(GaitInputError, match="cannot make the masks folder"):
        MaskWriter(tmp_path / "file" / "masks")


def test_rect_validation_and_clipping():
    assert Rect(-5, 3, 20, 10).clipped_to(10, 10) == Rect(0, 3, 10, 7)
    assert Rect.from_corners(10, 8, 2, 1) == Rect(2, 1, 8, 7)
    assert Rect.parse("1, 2,3,4").as_tuple() == (1, 2, 3, 4)
    for bad in [(0, 0, 0, 5), (0, 0, 5, -1)]:
        with pytest.raises(GaitInputError, match="empty"):
            Rect(*bad)
    with pytest.raises(GaitInputError, match="outside"):
        Rect(20, 20, 5, 5).clipped_to(10, 10)
    with pytest.raises(GaitInputError, match="four integers"):
        Rect.parse("1,2,3")


def test_stroke_is_plain_read_only_data():
    s = Stroke([[0, 0], [3, 4]], 2, 5)
    assert s.points_xy.dtype == np.float64 and s.width_px == 2.0 and s.frame == 5
    assert s == Stroke(np.array([[0.0, 0.0], [3.0, 4.0]]), 2.0, 5)
    with pytest.raises(ValueError):
        s.points_xy[0, 0] = 1
    assert s.moved(s.points_xy + 1, frame=6).frame == 6
    for bad in [dict(points_xy=np.zeros((0, 2))), dict(points_xy=[[np.nan, 0]]),
                dict(width_px=0), dict(frame=-1)]:
        args = dict(points_xy=[[0, 0]], width_px=1.0, frame=0) | bad
        with pytest.raises(GaitInputError):
            Stroke(**args)
