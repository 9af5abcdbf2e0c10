"""Demo helper: stand in for the artist by posing the key-images with the true poses,
compare the animation with the truth afterwards, and save it all as a Gait Studio project.

    python scripts/demo_pose_keys.py ANALYSIS.json POSES.csv KEYS.csv
    python scripts/demo_pose_keys.py --compare CURVES.csv POSES.csv SKELETON.json
    python scripts/demo_pose_keys.py --project CLIP_DIR KEYS.csv OUT.gaitproj
"""

from __future__ import annotations

import json
import sys

import numpy as np

from gaitcore.bench.evaluate import angle_error_deg
from gaitcore.io.pose_table import PoseTable, pose_matrix, read_pose_table, write_pose_table
from gaitcore.rig.skeleton import Skeleton

DEMO_FPS = 25.0


def pose_keys(analysis_path: str, poses_path: str, out_path: str) -> None:
    analysis = json.loads(open(analysis_path, encoding="utf-8").read())
    frames = analysis["key_frames"] + analysis.get("alternate_frames", [])
    truth = read_pose_table(poses_path)
    rows = [int(np.nonzero(truth.frames == f)[0][0]) for f in frames]
    write_pose_table(out_path, PoseTable(np.asarray(frames), truth.columns, truth.values[rows]))
    print(f"posed key-images {frames} with the true poses -> {out_path}")


def compare(curves_path: str, poses_path: str, skeleton_path: str) -> None:
    curves, truth = read_pose_table(curves_path), read_pose_table(poses_path)
    idx = Skeleton.from_json(skeleton_path).sagittal_angle_indices
    err = angle_error_deg(curves.values[:, idx], truth.values[:, idx])
    print(f"joint angles about the image normal: mean |error| {err.mean():.2f} deg, "
          f"std {err.std():.2f} deg over {len(idx)} angles x {len(truth.frames)} frames")


def save_project(clip: str, keys_path: str, out_path: str) -> None:
    """The clip, its silhouettes (made as the app makes them) and the posed keys, as a project
    the app opens with the animation ready."""
    from pathlib import Path

    from gaitcore.project.document import Project
    from gaitcore.project.steps import silhouettes_from_masks
    from gaitcore.project.storage import save_project as write_project

    clip_dir = Path(clip).absolute()
    skeleton = Skeleton.from_json(clip_dir / "skeleton.json")
    keys = read_pose_table(keys_path)
    poses = pose_matrix(skeleton, keys)
    project = Project(
        footage=clip_dir / "images", fps=DEMO_FPS, skeleton=skeleton,
        silhouettes=silhouettes_from_masks(clip_dir / "masks", None),
        key_poses={int(f): tuple(map(float, row)) for f, row in zip(keys.frames, poses)},
    )
    write_project(project, out_path)
    print(f"wrote the project {out_path} (keys {list(map(int, keys.frames))} posed)")


if __name__ == "__main__":
    if sys.argv[1] == "--compare":
        compare(*sys.argv[2:5])
    elif sys.argv[1] == "--project":
        save_project(*sys.argv[2:5])
    else:
        pose_keys(*sys.argv[1:4])
