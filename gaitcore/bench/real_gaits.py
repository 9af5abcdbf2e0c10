"""Real gaits with keypoints: does the analysis find the stride, and does the animation follow
the animal? The protocol of ``python -m benchmarks real_gaits`` and of the real-footage tests.

A clip folder holds ``source.avi`` and ``joints.csv`` (``frame,joint,x,y,likelihood``: a
trained network's keypoints in the video's pixels, not hand labels). The protocol:

- *Box*: the keypoints' box on the first frame (those of likelihood > ``KEY_LIKELIHOOD``),
  padded by a tenth of its size on the sides and below, and by ``RIDER_PAD`` of its height
  above (a rider counts as part of the subject), clipped to the frame.
- *Stride*: the hooves' horizontal positions relative to the trunk (origin halfway between
  withers and hip), autocorrelated: the first peak after the first zero crossing.
- *Poses*: the 16 keypoints relative to the trunk, in units of the clip's median keypoint
  height (the vertical extent of a frame's keypoints), as one vector per frame.
- *Keys*: the analysis chooses them among the frames whose keypoints all have likelihood >
  ``KEY_LIKELIHOOD``; they and their alternates are posed with their keypoints; ``animate``
  predicts the other frames of the analysed range.
- *Error*: the mean distance between predicted and true keypoints of likelihood >
  ``TRUSTED_LIKELIHOOD`` over the frames not posed, in % of that height; beside it the
  nearest posed frame's pose (nearest in the coordinates the analysis uses), the posed
  frames' mean pose, and the oracle: the same protocol with the PCA taken on the true
  keypoints instead of the silhouettes.
- *Stride in body lengths*: the withers' displacement over one stride from each frame, in the
  withers-to-hip length over that stride (the horse turns a little from the camera as it
  goes: both shorten together), averaged (:func:`per_stride`); a rig's root against it, in
  the rig's length from shoulder blade to hip joint (:func:`rig_body_length`).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gaitcore.analysis.analyze import Analysis, AnalysisSettings, analyze_features
from gaitcore.animation.animate import AnalysisRecord, animate_record
from gaitcore.errors import GaitInputError
from gaitcore.rig.skeleton import Skeleton

HORSE_JOINTS = ("Nostril", "Poll", "Withers", "RightKnee", "RightFrontFetlock", "RightFrontHoof",
                "LeftKnee", "LeftFrontFetlock", "LeftFrontHoof", "Hip", "RightHock",
                "RightHindFetlock", "RightHindHoof", "LeftHock", "LeftHindFetlock",
                "LeftHindHoof")
HOOVES = ("RightFrontHoof", "LeftFrontHoof", "RightHindHoof", "LeftHindHoof")
KEY_LIKELIHOOD = 0.6
TRUSTED_LIKELIHOOD = 0.9
RIDER_PAD = 0.8


@dataclass(frozen=True, eq=False)
class Keypoints:
    """A clip's keypoints.

    Attributes
    ----------
    xy : ndarray of shape (n, j, 2)
        Pixels of the video (NaN where missing).
    likelihood : ndarray of shape (n, j)
    """

    xy: np.ndarray
    likelihood: np.ndarray

    @classmethod
    def read(cls, path: Path, joints: tuple[str, ...] = HORSE_JOINTS) -> Keypoints:
        """Read ``joints.csv``.

        Raises
        ------
        GaitInputError
            A missing file, column or joint.
        """
        try:
            with open(path, newline="", encoding="utf-8") as f:
                rows = list(csv.DictReader(f))
            n = max(int(r["frame"]) for r in rows) + 1
            xy = np.full((n, len(joints), 2), np.nan)
            lik = np.zeros((n, len(joints)))
            for r in rows:
                if r["joint"] in joints:
                    t, j = int(r["frame"]), joints.index(r["joint"])
                    xy[t, j] = float(r["x"]), float(r["y"])
                    lik[t, j] = float(r["likelihood"])
        except (OSError, KeyError, ValueError) as exc:
            raise GaitInputError(f"cannot read the keypoints {path}: {exc}") from None
        return cls(xy, lik)

    @property
    def n_frames(self) -> int:
        return int(self.xy.shape[0])

    def index(self, name: str) -> int:
        return HORSE_JOINTS.index(name)

    def trunk(self) -> np.ndarray:
        """Halfway between withers and hip, shape (n, 2)."""
        return 0.5 * (self.xy[:, self.index("Withers")] + self.xy[:, self.index("Hip")])

    def height_px(self) -> float:
        """The clip's median keypoint height (vertical extent of a frame's keypoints)."""
        ys = self.xy[..., 1]
        return float(np.nanmedian(np.nanmax(ys, axis=1) - np.nanmin(ys, axis=1)))

    def poses(self) -> np.ndarray:
        """Keypoints relative to the trunk in units of :meth:`height_px`, (n, j, 2)."""
        return (self.xy - self.trunk()[:, None, :]) / self.height_px()

    def box(self, frame_wh: tuple[int, int]) -> tuple[int, int, int, int]:
        """The padded box of the first frame (see the module notes), x, y, w, h."""
        ok = self.likelihood[0] > KEY_LIKELIHOOD
        (x0, y0), (x1, y1) = self.xy[0, ok].min(axis=0), self.xy[0, ok].max(axis=0)
        w, h = x1 - x0, y1 - y0
        left, right = max(0.0, x0 - 0.1 * w), min(frame_wh[0] - 1.0, x1 + 0.1 * w)
        top, bottom = max(0.0, y0 - RIDER_PAD * h), min(frame_wh[1] - 1.0, y1 + 0.1 * h)
        return int(left), int(top), int(right - left), int(bottom - top)

    def stride_frames(self) -> float:
        """The stride from the hooves' positions relative to the trunk (see the module)."""
        trunk_x = self.trunk()[:, 0]
        t = np.arange(self.n_frames)
        signals = []
        for name in HOOVES:
            j = self.index(name)
            x = self.xy[:, j, 0] - trunk_x
            ok = (self.likelihood[:, j] > KEY_LIKELIHOOD) & np.isfinite(x)
            if ok.sum() >= 2:
                x = np.interp(t, t[ok], x[ok])
                signals.append(x - x.mean())
        s = np.array(signals)
        n = s.shape[1]
        ac = np.array([np.sum(s[:, : n - lag] * s[:, lag:]) / (n - lag)
                       for lag in range(n // 2 + 1)])
        ac /= ac[0]
        zero = int(np.argmax(ac < 0))
        lag = zero + int(np.argmax(ac[zero:]))
        if 0 < lag < ac.size - 1:
            a, b, c = ac[lag - 1 : lag + 2]
            if a - 2 * b + c < 0:
                return float(lag + 0.5 * (a - c) / (a - 2 * b + c))
        return float(lag)


@dataclass(frozen=True)
class PoseErrors:
    """Keypoint errors of one animation, % of the clip's keypoint height."""

    animation: float
    nearest_key: float
    mean_pose: float


def per_stride(x: np.ndarray, body: np.ndarray, stride: float) -> float:
    """Mean displacement of ``x`` over one stride from each frame, in the mean of ``body``
    (NaN where unknown) over that stride."""
    rows = np.arange(len(x))
    moved = [abs(np.interp(a + stride, rows, x) - x[a])
             / np.nanmean(body[a : int(np.ceil(a + stride)) + 1])
             for a in range(len(x) - int(np.ceil(stride)))]
    return float(np.mean(moved)) if moved else float("nan")


def withers_stride(kp: Keypoints, frame_range: tuple[int, int]) -> float:
    """The withers' displacement per stride in withers-to-hip lengths over ``frame_range``."""
    start, stop = frame_range
    withers, hip = kp.index("Withers"), kp.index("Hip")
    seen = ((kp.likelihood[start:stop, withers] > TRUSTED_LIKELIHOOD)
            & (kp.likelihood[start:stop, hip] > TRUSTED_LIKELIHOOD))
    w_xy, h_xy = kp.xy[start:stop, withers], kp.xy[start:stop, hip]
    body = np.where(seen, np.linalg.norm(w_xy - h_xy, axis=1), np.nan)
    rows = np.arange(stop - start)
    x = np.interp(rows, rows[seen], w_xy[seen, 0])
    return per_stride(x, body, kp.stride_frames())


def rig_body_length(skeleton: Skeleton) -> float:
    """Side-view distance from the right shoulder blade (the withers) to the root (the hip
    joint) of a horse rig at rest, metres."""
    rest = skeleton.joint_positions(skeleton.rest_pose())
    return float(np.linalg.norm(rest[skeleton.joint_index("R_scapula"), :2]
                                - rest[skeleton.joint_index("root"), :2]))


def ineligible_keys(kp: Keypoints) -> tuple[int, ...]:
    """Frames that may not be keys: some keypoint under ``KEY_LIKELIHOOD``."""
    return tuple(int(t) for t in np.flatnonzero(~(kp.likelihood > KEY_LIKELIHOOD).all(axis=1)))


def pose_errors(analysis: Analysis, kp: Keypoints) -> PoseErrors:
    """Animate ``analysis`` from its posed frames' keypoints and measure it (module notes)."""
    poses = kp.poses()
    flat = np.nan_to_num(poses.reshape(kp.n_frames, -1))
    posed = analysis.posed_frames
    record = AnalysisRecord.from_analysis(analysis)
    predicted = animate_record(record, {f: flat[f] for f in posed},
                               alternates=analysis.alternate_frames)
    rows = np.arange(analysis.n_frames)
    frames = rows + analysis.first_frame
    posed_rows = np.array(analysis.rows(list(posed)))
    coords = record.projections
    d2 = ((coords[:, None, :] - coords[posed_rows][None]) ** 2).sum(axis=-1)
    nearest = flat[np.array(posed)[np.argmin(d2, axis=1)]]
    mean = np.broadcast_to(flat[list(posed)].mean(axis=0), predicted.shape)
    others = ~np.isin(frames, posed)
    trusted = kp.likelihood[frames[others]] > TRUSTED_LIKELIHOOD

    def error(pred: np.ndarray) -> float:
        diff = pred[others].reshape(-1, len(HORSE_JOINTS), 2) - poses[frames[others]]
        return float(100.0 * np.linalg.norm(diff, axis=2)[trusted].mean())

    return PoseErrors(error(predicted), error(nearest), error(mean))


def oracle(kp: Keypoints, settings: AnalysisSettings, frame_range: tuple[int, int]
           ) -> Analysis:
    """The same analysis on the true keypoints of ``frame_range`` (start, stop)."""
    start, stop = frame_range
    flat = np.nan_to_num(kp.poses().reshape(kp.n_frames, -1))[start:stop]
    forbidden = tuple(f for f in ineligible_keys(kp) if start <= f < stop)
    return analyze_features(flat, AnalysisSettings(pcs=settings.pcs, keys=settings.keys,
                                                   switching=settings.switching,
                                                   forbidden=forbidden),
                            first_frame=start)
