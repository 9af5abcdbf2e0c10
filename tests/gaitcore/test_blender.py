"""Our exports read by Blender itself (bpy, Blender 4.5 LTS as a Python module).

bpy runs in its own interpreter (``blender_probe.py`` in a subprocess): it pins NumPy below 2,
which the project's environment cannot take, and it must not share a process with Qt and
pyrender. The interpreter is, in order: ``$GAITSTUDIO_BLENDER_PYTHON``, ``.venv-blender``
(``make test`` makes it where bpy has a wheel: Python 3.11 on Linux x86-64), or this one.
The test skips, saying why, only when none of them can import bpy.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from gaitcore.cli import main
from gaitcore.io.bvh.reader import read_bvh
from gaitcore.rig.rotations import euler_zxy_matrix
from gaitcore.rig.skeleton import Skeleton

ROOT = Path(__file__).resolve().parents[2]
PROBE = Path(__file__).with_name("blender_probe.py")
ARTIFACTS = ROOT / "tests" / "_artifacts"
N_FRAMES = 60
FPS = 24.0

pytestmark = [pytest.mark.slow, pytest.mark.gl]


@lru_cache(maxsize=1)
def _blender_python() -> str:
    candidates = [os.environ.get("GAITSTUDIO_BLENDER_PYTHON"),
                  str(ROOT / ".venv-blender" / "bin" / "python"), sys.executable]
    why = []
    for exe in filter(None, candidates):
        if not Path(exe).exists():
            why.append(f"{exe}: not found")
            continue
        probe = subprocess.run([exe, "-c", "import bpy; print(bpy.app.version_string)"],
                               capture_output=True, text=True, timeout=300)
        if probe.returncode == 0:
            return exe
        why.append(f"{exe}: {(probe.stderr.strip().splitlines() or ['no bpy'])[-1]}")
    pytest.skip("bpy (Blender 4.5 as a Python module) cannot be imported; `make test` installs "
                "it in .venv-blender where a wheel exists (Python 3.11, Linux x86-64). Tried "
                + "; ".join(why))


@pytest.fixture(scope="module")
def clip(tmp_path_factory) -> dict:
    """A synthetic canter through the whole pipeline, exported with the defaults and as a loop."""
    _blender_python()  # skip before the work when there is no Blender
    root = tmp_path_factory.mktemp("blender")
    assert main(["synth", "--gait", "canter", "--frames", str(N_FRAMES), "--out",
                 str(root / "syn"), "--width", "160", "--height", "120"]) == 0
    assert main(["analyze", str(root / "syn" / "masks"), "--out", str(root / "an")]) == 0
    keys = json.loads((root / "an" / "analysis.json").read_text())["key_frames"]
    with (root / "syn" / "poses.csv").open() as fh:
        rows = list(csv.reader(fh))
    with (root / "keys.csv").open("w", newline="") as fh:
        csv.writer(fh).writerows([rows[0]] + [rows[f + 1] for f in keys])
    common = ["--key-poses", str(root / "keys.csv"),
              "--skeleton", str(root / "syn" / "skeleton.json")]
    for name, extra in (("clip", []), ("loop", ["--loop"])):
        out = root / name
        out.mkdir()
        assert main(["animate", str(root / "an" / "analysis.json"), *common, "--out",
                     str(out / "curves.csv"), "--bvh", str(out / "a.bvh"), "--glb",
                     str(out / "a.glb"), *extra]) == 0
    return {"root": root, "skeleton": Skeleton.from_json(root / "syn" / "skeleton.json")}


def _probe(clip: dict, name: str) -> dict:
    folder = clip["root"] / name
    if not (folder / "blender.json").exists():
        exe = _blender_python()
        run = subprocess.run([exe, str(PROBE), str(folder / "a.bvh"), str(folder / "a.glb"),
                              str(folder)], capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, run.stderr[-2000:]
    return json.loads((folder / "blender.json").read_text())


def _ours(clip: dict, name: str) -> tuple[Skeleton, np.ndarray]:
    """Our skeleton and the world transforms of the exported poses, (n, J, 4, 4)."""
    skeleton = clip["skeleton"]
    table = read_bvh(clip["root"] / name / "a.bvh")[1]
    values = table.values[:, [table.columns.index(c) for c in skeleton.channel_names]]
    return skeleton, skeleton.forward_kinematics(values)


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle of the rotation between matrices a and b, (..., 3, 3) -> (...), degrees."""
    cos = (np.trace(np.swapaxes(a, -1, -2) @ b, axis1=-2, axis2=-1) - 1) / 2
    sin = np.linalg.norm(a - b, axis=(-2, -1)) / np.sqrt(2)  # exact enough for small angles
    return np.degrees(np.where(cos > 0.99, np.arcsin(np.clip(sin, 0, 1)),
                               np.arccos(np.clip(cos, -1, 1))))


def test_bvh_in_blender_matches_our_curves(clip):
    report = _probe(clip, "clip")["bvh"]
    skeleton, world = _ours(clip, "clip")
    assert report["fps"] == 24 and report["fps_base"] == 1.0  # not 23.999997
    assert report["action_range"] == [1, N_FRAMES]
    end_sites = 6  # head_end, tail_end and four toes; the ears are a joint without channels
    assert report["n_bones"] == skeleton.n_joints - end_sites
    motion = report["motion"]
    index = [skeleton.joint_index(b) for b in motion["bones"]]
    theirs = np.array(motion["rotations"])[:N_FRAMES]
    assert _angle_deg(theirs, world[:, index][..., :3, :3]).max() < 1e-3
    heads = np.array(motion["heads"])[:N_FRAMES]
    np.testing.assert_allclose(heads, world[:, index][..., :3, 3], atol=1e-4)


def test_feet_stay_on_the_ground_and_the_root_goes_forward_in_blender(clip):
    motion = _probe(clip, "clip")["bvh"]["motion"]
    bones = motion["bones"]
    hooves = [bones.index(f"{s}_{leg}_hoof") for s in "LR" for leg in ("fore", "hind")]
    tails = np.array(motion["tails"])[:N_FRAMES]  # a hoof bone ends at the toe
    heads = np.array(motion["heads"])[:N_FRAMES]
    lowest = min(tails[:, hooves, 1].min(), heads[:, hooves, 1].min())
    assert lowest > -0.005
    root_x = heads[:, bones.index("root"), 0]
    assert np.diff(root_x).min() > -0.01


def test_glb_in_blender_matches_our_curves(clip):
    report = _probe(clip, "clip")["glb"]
    skeleton, world = _ours(clip, "clip")
    assert report["n_bones"] == skeleton.n_joints and report["n_skinned"] == 1
    assert report["action_range"] == [0, N_FRAMES - 1]
    motion = report["motion"]
    index = [skeleton.joint_index(b) for b in motion["bones"]]
    heads = np.array(motion["heads"])
    np.testing.assert_allclose(heads, world[:, index][..., :3, 3], atol=1e-4)
    assert _angle_deg(np.array(motion["rotations"]), world[:, index][..., :3, :3]).max() < 1e-3


def test_our_bvh_reexported_by_blender_round_trips(clip):
    _probe(clip, "clip")
    ours, table, _ = read_bvh(clip["root"] / "clip" / "a.bvh")
    back, again, fps = read_bvh(clip["root"] / "clip" / "reexported.bvh")
    assert fps == FPS and len(again.frames) == len(table.frames)
    z_up = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # Blender writes its own axes
    worst = 0.0
    for joint in (j for j in ours.joints if "rz" in j.channels):
        names = [f"{joint.name}.{c}" for c in ("rz", "rx", "ry")]
        a = euler_zxy_matrix(table.values[:, [table.columns.index(n) for n in names]])
        b = (z_up.T @ euler_zxy_matrix(again.values[:, [again.columns.index(n) for n in names]])
             @ z_up)
        worst = max(worst, _angle_deg(a, b).max())
    assert worst < 1e-4


def test_a_loop_plays_round_in_blender_without_a_hitch(clip):
    report = _probe(clip, "loop")
    bvh = report["bvh"]
    first, last = bvh["action_range"]
    rotations = np.array(bvh["motion"]["rotations"])  # frames first .. last + 2
    heads = np.array(bvh["motion"]["heads"])
    assert _angle_deg(rotations[last - first], rotations[0]).max() < 1e-3  # closing = first
    # the Cycles modifiers (Make Cyclic) carry on from the closing frame
    assert _angle_deg(rotations[last - first + 1], rotations[1]).max() < 1e-3
    np.testing.assert_allclose(heads[last - first + 2], heads[2], atol=1e-4)
    assert report["glb"]["action_range"] == [0, last - first]


def test_render_one_frame_for_a_person_to_look_at(clip):
    _probe(clip, "clip")
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    png = (clip["root"] / "clip" / "blender.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    (ARTIFACTS / "blender_canter.png").write_bytes(png)
