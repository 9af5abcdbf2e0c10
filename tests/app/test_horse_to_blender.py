"""From a folder of a ridden horse's frames to a BVH that Blender plays, in the real window.

A new user's whole path: open the folder (asked for its frame rate), box the horse, segment,
analyse, fit the rig, pose every key by dragging its hooves onto the footage, export. Blender
reads the BVH: the root advances on every frame by the stride the footage shows, the rig faces
the way the horse walks without a Flip, and a hoof stands on the ground on every frame.
Skipped where ``../shared/data/horse-walks`` or Blender's ``bpy`` is absent.
"""

from __future__ import annotations

import json
import subprocess

import cv2
import numpy as np
import pytest

from gaitcore.bench.real_gaits import HOOVES, Keypoints, per_stride
from gaitcore.project.footage_fit import (
    footage_from_world,
    silhouette_heights_px,
    skeleton_extent,
)
from tests.app.conftest import wait_ready
from tests.app.test_real_gait import usable_from_box
from tests.gaitcore.test_blender import PROBE, _blender_python

pytestmark = [pytest.mark.slow, pytest.mark.gl]

CLIP = "belle"
FPS = 15.0
TOES = {"RightFrontHoof": "R_fore_toe", "LeftFrontHoof": "L_fore_toe",
        "RightHindHoof": "R_hind_toe", "LeftHindHoof": "L_hind_toe"}
TRUSTED = 0.9
STRIDE_TOLERANCE = 0.15


def _frames_folder(video, folder) -> None:
    """The clip's frames as JPEG files (what a user gets from a camera's export)."""
    folder.mkdir()
    cap = cv2.VideoCapture(str(video))
    n = 0
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        cv2.imwrite(str(folder / f"{n:05d}.jpg"), frame, [cv2.IMWRITE_JPEG_QUALITY, 95])
        n += 1
    cap.release()


def _to_world(maps: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Source pixel -> the rig's side view (X, Y), the inverse of footage_from_world."""
    return np.linalg.solve(maps[:, :2], uv - maps[:, 2])


def _pose_by_hoof_drags(window, kp: Keypoints, size: tuple[int, int]) -> int:
    """Drag each hoof of each posed frame onto its keypoint, as an artist drags it onto the
    footage (hooves the network did not see are left as they are). Returns the drags made."""
    state, posing = window.state, window.posing
    made = 0
    for frame in state.analysis.posed_frames:
        state.set_frame(frame)
        skeleton = state.skeleton
        maps = footage_from_world(frame, skeleton_extent(skeleton), state.project.silhouettes,
                                  size, fit=state.project.footage_fit)
        posing.begin_drag()
        for name in HOOVES:
            index = kp.index(name)
            if kp.likelihood[frame, index] < TRUSTED:
                continue
            toe = skeleton.joint_index(TOES[name])
            pose = posing.pose_of(frame)
            z = skeleton.joint_positions(pose)[toe, 2]
            x, y = _to_world(maps, kp.xy[frame, index])
            posing.drag_end(toe, pose, np.array([x, y, z]))
            made += 1
    return made


def _export(qtbot, window, asker, path) -> None:
    asker.next_export_path = path
    job = window.exporter.export(path.suffix, path)
    assert job is not None, asker.errors
    with qtbot.waitSignal(job.finished, timeout=120_000):
        pass
    assert path.is_file(), asker.errors


def test_a_horse_walk_goes_from_a_folder_to_blender_walking_on_the_ground(
        qtbot, window, asker, shared_data, artifacts_dir, tmp_path):
    clip = shared_data / "horse-walks" / CLIP
    if not (clip / "source.avi").is_file():
        pytest.skip(f"the horse walks are not at {clip.parent}")
    blender = _blender_python()
    kp = Keypoints.read(clip / "joints.csv")
    folder = tmp_path / "frames"
    _frames_folder(clip / "source.avi", folder)
    first = cv2.imread(str(folder / "00000.jpg"))
    size = (first.shape[1], first.shape[0])
    asker.frame_rate_answer = FPS
    assert window.open_path(folder)
    wait_ready(qtbot, window)
    assert window.state.project.fps == FPS and any("frame rate" in a for a in asker.asked)
    analysis = usable_from_box(qtbot, window, kp.box(size))
    # Fit rig on the first key whose fit is not refused (a refusal says why, as an error).
    for key in analysis.key_frames:
        window.state.set_frame(key)
        fit = window.posing.fit_rig()
        with qtbot.waitSignal(fit.finished, timeout=60_000):
            pass
        wait_ready(qtbot, window)
        if window.state.project.proportions != type(window.state.project.proportions)():
            break
        assert "does not fit frame" in asker.errors[-1]
    else:
        pytest.fail(f"Fit rig refused every key: {asker.errors}")
    assert _pose_by_hoof_drags(window, kp, size) >= 2 * len(analysis.posed_frames)
    window.state.set_frame(analysis.key_frames[0])
    wait_ready(qtbot, window)
    window.snapshot().save(str(artifacts_dir / "app_horse_walk_posed.png"))
    out = tmp_path / "export"
    out.mkdir()
    _export(qtbot, window, asker, out / "a.bvh")
    _export(qtbot, window, asker, out / "a.glb")
    run = subprocess.run([blender, str(PROBE), str(out / "a.bvh"), str(out / "a.glb"), str(out)],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    (artifacts_dir / "blender_horse_walk.png").write_bytes((out / "blender.png").read_bytes())
    report = json.loads((out / "blender.json").read_text())["bvh"]
    assert report["fps"] == FPS
    motion = report["motion"]
    bones = motion["bones"]
    n = len(np.arange(*analysis.frame_range))
    heads = np.array(motion["heads"])[:n]
    tails = np.array(motion["tails"])[:n]
    root_x = heads[:, bones.index("root"), 0]
    assert np.diff(root_x).min() > 0  # the root advances on every frame
    assert (heads[:, bones.index("head"), 0] > root_x).all()  # facing the way it goes
    hooves = [bones.index(f"{s}_{leg}_hoof") for s in "LR" for leg in ("fore", "hind")]
    lowest = tails[:, hooves, 1].min(axis=1)  # a hoof bone ends at the toe
    assert lowest.min() > -0.005 and np.abs(lowest).max() <= 0.01, lowest
    # Per stride the root advances by the stride the footage shows: the withers' keypoint
    # over each stride, in metres at the scale the footage is shown behind the rig on that
    # frame. (Against the rig's own body length, the benchmark real_gaits measures it too.)
    start, stop = analysis.frame_range
    withers = kp.index("Withers")
    seen = kp.likelihood[start:stop, withers] > TRUSTED
    rows = np.arange(n)
    withers_px = np.interp(rows, rows[seen], kp.xy[start:stop, withers, 0][seen])
    heights = silhouette_heights_px(window.state.project.silhouettes)[start:stop]
    metres_per_px = (skeleton_extent(window.state.skeleton).height_m
                     * window.state.project.footage_fit.scale / heights)
    withers_m = np.r_[0.0, np.cumsum(np.diff(withers_px) * metres_per_px[1:])]
    stride = kp.stride_frames()
    footage = per_stride(withers_m, np.ones(n), stride)
    ours = per_stride(root_x, np.ones(n), stride)
    assert ours == pytest.approx(footage, rel=STRIDE_TOLERANCE), (ours, footage)
