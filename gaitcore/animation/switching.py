"""Resolving the left/right ambiguity of walks with switching models (paper Section 3.2).

From the side, the two half-cycles of a walk give nearly the same silhouettes with the left
and right legs swapped, so one RBF map over m keys can only animate half a cycle. Each key
gets an *alternate*: a frame of the other half-cycle with the same silhouette, posed by the
artist (usually the mirror of the key's pose). The 2m poses, ordered by phase over the whole
gait cycle, are grouped into q overlapping sets of m; each frame is animated by one set.

The switching rule designed here
--------------------------------
For a walk the (PC1, PC2) trajectory goes round its loop twice per gait cycle, so the angle
of the trajectory around the loop's centre, unwrapped over time, counts half-cycles. We
compute that *loop angle* theta(t) on the band-pass filtered trajectory (clean and nearly
monotone) and make it non-decreasing (a running maximum), so that noise can never send the
state backwards and make it flicker. The gait phase of a frame is
psi(t) = (theta(t) - theta(k_1)) mod 4 pi, which places the 2m poses on one gait cycle. Set s
holds the poses s*step+1 .. s*step+m (cyclically, step = 2m/q; for m = 4, q = 4 this is the
paper's sigma, eq. 19) and is active from the phase of the last pose of set s-1 to the phase
of its own last pose. The state therefore changes exactly when the clip reaches the last
key silhouette of the current set (the paper's rule, eq. 17), and because both the old and
the new set contain that key, and an RBF map is exact at its keys, the animation is
continuous across the switch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.analysis.alternates import TWO_PI
from gaitcore.analysis.kernel import DEFAULT_ALPHA
from gaitcore.animation.rbf import RBFPoseMap
from gaitcore.errors import GaitInputError


def default_n_sets(m: int) -> int:
    """q for m keys: sets advance by m // 2 poses (at least 1), so consecutive sets share
    about half their poses; 4 for m = 2, 4, 6, 8 (the paper's choice for m = 4)."""
    return 2 * m // max(1, m // 2)


def switching_sets(n_poses: int, n_sets: int | None = None) -> np.ndarray:
    """The overlapping pose sets sigma of the switching models.

    Parameters
    ----------
    n_poses : int
        2m, the number of poses ordered by phase.
    n_sets : int, optional
        q, the number of sets; must divide 2m. Default :func:`default_n_sets`.

    Returns
    -------
    ndarray of shape (q, m), int
        0-based pose indices; for 2m = 8, q = 4 this is the paper's eq. (19) less one.
    """
    if n_poses < 2 or n_poses % 2:
        raise GaitInputError(f"switching models need an even number of poses, got {n_poses}")
    m = n_poses // 2
    if n_sets is None:
        n_sets = default_n_sets(m)
    if n_sets < 2 or n_poses % n_sets:
        raise GaitInputError(f"{n_sets} switching sets cannot split {n_poses} poses evenly")
    step = n_poses // n_sets
    return (np.arange(n_sets)[:, None] * step + np.arange(m)[None, :]) % n_poses


@dataclass(frozen=True, eq=False)
class SwitchingModel:
    """q RBF pose maps over overlapping sets of the 2m key and alternate poses.

    Attributes
    ----------
    pose_frames : tuple of int
        The 2m posed frames ordered by gait phase.
    pose_phase : ndarray of shape (2m,)
        Their phase psi in [0, 4 pi).
    sets : ndarray of shape (q, m)
        Indices into ``pose_frames`` of each set.
    maps : tuple of RBFPoseMap
        One fitted map per set.
    theta0 : float
        Loop angle of the first key, the origin of the phase.
    """

    pose_frames: tuple[int, ...]
    pose_phase: np.ndarray
    sets: np.ndarray
    maps: tuple[RBFPoseMap, ...]
    theta0: float

    @classmethod
    def fit(
        cls,
        projections: np.ndarray,
        theta: np.ndarray,
        key_frames: tuple[int, ...] | list[int],
        alternate_frames: tuple[int, ...] | list[int],
        poses: dict[int, np.ndarray],
        *,
        n_sets: int | None = None,
        alpha: float = DEFAULT_ALPHA,
        clamp: tuple[float, float] | None = None,
    ) -> SwitchingModel:
        """Order the key and alternate poses by phase and fit one RBF map per set.

        Parameters
        ----------
        projections : ndarray of shape (n, c)
            Coordinates used for the RBF interpolation.
        theta : ndarray of shape (n,)
            Loop angle of every frame (:func:`gaitcore.analysis.alternates.loop_angle`).
        key_frames, alternate_frames : sequence of int, length m each
        poses : dict of int to ndarray of shape (k,)
            Pose vector of every key and alternate frame.
        n_sets : int, optional
            q (4 in the paper for m = 4); default :func:`default_n_sets`.

        Raises
        ------
        GaitInputError
            Missing poses, a frame used twice, or a set whose keys coincide in PCA space.

        Notes
        -----
        Paper Section 3.2, eqs. (16)-(19).
        """
        frames = list(key_frames) + list(alternate_frames)
        if len(key_frames) != len(alternate_frames):
            raise GaitInputError("every key-image needs exactly one alternate frame")
        if len(set(frames)) != len(frames):
            raise GaitInputError(
                "a frame is used both as a key and as an alternate: pick distinct alternates"
            )
        missing = [f for f in frames if f not in poses]
        if missing:
            raise GaitInputError(f"no pose for frame(s) {missing}: pose every key and alternate")
        theta0 = float(theta[key_frames[0]])
        phase = np.mod(np.asarray([theta[f] for f in frames]) - theta0, 2 * TWO_PI)
        order = np.argsort(phase, kind="stable")
        pose_frames = tuple(int(frames[i]) for i in order)
        sets = switching_sets(len(frames), n_sets)
        p = np.asarray(projections, dtype=float)
        maps = []
        for s in sets:
            fr = [pose_frames[i] for i in s]
            try:
                maps.append(
                    RBFPoseMap.fit(p[fr], np.stack([poses[f] for f in fr]), alpha=alpha,
                                   clamp=clamp)
                )
            except GaitInputError as exc:
                raise GaitInputError(f"switching set of frames {fr}: {exc}") from exc
        return cls(pose_frames, phase[order], sets, tuple(maps), theta0)

    def states(self, theta: np.ndarray) -> np.ndarray:
        """Active set of every frame, s_t (paper eq. 17).

        Parameters
        ----------
        theta : ndarray of shape (n,)
            Loop angle of the frames.

        Returns
        -------
        ndarray of shape (n,), int
        """
        psi = np.mod(np.asarray(theta, dtype=float) - self.theta0, 2 * TWO_PI)
        ends = self.pose_phase[self.sets[:, -1]]
        # Set s is active on [end of set s-1, end of set s), cyclically over the gait cycle.
        order = np.argsort(ends)
        idx = np.searchsorted(ends[order], psi, side="right")
        return order[idx % len(order)]

    def predict(self, projections: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """Pose of every frame from the map of its active set (paper eq. 16).

        Returns
        -------
        ndarray of shape (n, k)
        """
        p = np.asarray(projections, dtype=float)
        state = self.states(theta)
        out = np.empty((p.shape[0], self.maps[0].key_poses.shape[1]))
        for s, rbf in enumerate(self.maps):
            sel = state == s
            if sel.any():
                out[sel] = rbf.predict(p[sel])
        return out
