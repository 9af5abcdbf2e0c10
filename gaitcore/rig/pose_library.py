"""Example poses of a rig as a prior on how its chains fold: example-based IK.

Dragging a hoof fixes two of the six or seven side-view angles of its leg; how the leg folds
between the top joint and the hoof is left open, and damped least squares from the template
pose folds it wrongly (the same holds for the tail and the neck). A :class:`PoseLibrary`
holds example poses (the gait library shipped with Gait Studio, :func:`shipped_library`, and
the other keys already posed in the project); a drag then starts from the examples whose end
lies nearest the target, seen from the chain's parent (the trunk, for a leg), and the
least-squares solve moves the chain from there onto the target.

The shipped library (``resources/poses/horse_gaits.csv``) holds the synthetic walk, trot and
gallop of :mod:`gaitcore.bench.gaits`, both leads, one cycle each: never the canter, on which
``python -m benchmarks posing`` measures the drags.

References
----------
K. Grochow, S. L. Martin, A. Hertzmann, Z. Popovic, "Style-based inverse kinematics",
SIGGRAPH 2004 (IK constrained by a model of example poses).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import lru_cache
from importlib.resources import files

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.rig.skeleton import ROTATION_CHANNELS, Skeleton

NEIGHBOURS = 4
"""Examples blended into the start of a drag."""
BANDWIDTH_SHARE = 0.04
"""Width of the Gaussian weight of an example by the distance of its end from the target, as
a share of the chain's length (5 cm on a horse's fore leg)."""
SHIPPED = "horse_gaits"
"""The library that ships with the horse template."""


@dataclass(frozen=True, eq=False)
class PoseLibrary:
    """Example poses, laid out by channel name (any rig whose channels they name can use them).

    Attributes
    ----------
    channel_names : tuple of str
        ``"<joint>.<channel>"``, k of them.
    poses : ndarray of shape (n, k)
        Angles in degrees (translations are ignored); NaN where an example lacks a channel
        (a pose of another rig), and then it is no example for the chains using it.
    source : str
        What the examples are, in words (shown to the artist and in the benchmark's notes).

    Raises
    ------
    GaitInputError
        Poses that are not an (n, k) array of numbers (or NaN) matching the channel names.
    """

    channel_names: tuple[str, ...]
    poses: np.ndarray
    source: str

    def __post_init__(self) -> None:
        poses = np.asarray(self.poses, dtype=float)
        if poses.ndim != 2 or poses.shape[1] != len(self.channel_names):
            raise GaitInputError(f"a pose library needs one column per channel "
                                 f"({len(self.channel_names)}), got shape {poses.shape}")
        if np.isinf(poses).any():
            raise GaitInputError("a pose library holds only finite angles (or NaN where a "
                                 "pose lacks a channel)")
        poses.setflags(write=False)
        object.__setattr__(self, "channel_names", tuple(self.channel_names))
        object.__setattr__(self, "poses", poses)

    def __len__(self) -> int:
        return len(self.poses)

    def with_poses(self, skeleton: Skeleton, poses: np.ndarray, source: str) -> PoseLibrary:
        """This library and ``poses`` of ``skeleton`` (e.g. the project's other keys).

        Parameters
        ----------
        skeleton : Skeleton
        poses : ndarray of shape (m, skeleton.n_channels)
        source : str
            What the new poses are, appended to :attr:`source`.
        """
        added = np.asarray(poses, dtype=float).reshape(-1, skeleton.n_channels)
        if not len(added):
            return self
        names = self.channel_names + tuple(c for c in skeleton.channel_names
                                           if c not in self.channel_names)
        merged = np.full((len(self) + len(added), len(names)), np.nan)
        merged[:len(self), :len(self.channel_names)] = self.poses
        merged[len(self):, [names.index(c) for c in skeleton.channel_names]] = added
        return PoseLibrary(names, merged, f"{self.source}; {source}")

    @classmethod
    def of(cls, skeleton: Skeleton, poses: np.ndarray, source: str) -> PoseLibrary:
        """A library of poses of ``skeleton``, shape (n, skeleton.n_channels)."""
        return cls(skeleton.channel_names,
                   np.asarray(poses, dtype=float).reshape(-1, skeleton.n_channels), source)


def shipped_library() -> PoseLibrary:
    """The gait library that ships with Gait Studio (see the module docstring)."""
    return _read_shipped(SHIPPED)


@lru_cache(maxsize=2)
def _read_shipped(name: str) -> PoseLibrary:
    path = files("gaitcore.resources") / "poses" / f"{name}.csv"
    with path.open(encoding="utf-8") as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    values = np.array(rows[1:], dtype=float)
    return PoseLibrary(tuple(rows[0][1:]), values[:, 1:],
                       "the shipped gait library (synthetic walk, trot, gallop)")


def example_start(library: PoseLibrary, skeleton: Skeleton, base_pose: np.ndarray,
                  chain: tuple[int, ...], end: int, target_xyz: np.ndarray) -> np.ndarray:
    """``base_pose`` with the rotations of ``chain`` taken from the examples whose ``end``
    lies nearest ``target_xyz``, seen from the chain's parent.

    Parameters
    ----------
    library : PoseLibrary
    skeleton : Skeleton
    base_pose : ndarray of shape (k,)
    chain : tuple of int
        The joints that turn, top first (the top's parent stays where it is).
    end : int
        The end effector.
    target_xyz : ndarray of shape (3,)
        World position, metres.

    Returns
    -------
    ndarray of shape (k,)
        ``base_pose`` unchanged when the library lacks a rotation channel of the chain.

    Notes
    -----
    The start is the mean of the :data:`NEIGHBOURS` nearest examples weighted by a Gaussian
    of how much farther than the nearest their end lies from the target (width
    :data:`BANDWIDTH_SHARE` of the chain's length); the solve then reaches the target from
    there (Grochow et al. 2004 constrain IK by a learned model of poses; this is its
    nearest-examples form). The chain's own pose in ``base_pose`` is one of the examples, so
    a small drag keeps the fold the artist gave it.
    """
    found = _chain_examples(library, skeleton, chain, end)
    if found is None:
        return np.array(base_pose, dtype=float)
    slots, angles, ends, length = found
    world = skeleton.forward_kinematics(np.asarray(base_pose, float))
    parent = int(skeleton.parents[chain[0]])
    rot, origin = world[parent, :3, :3], world[parent, :3, 3]
    seen = rot.T @ (np.asarray(target_xyz, float) - origin)
    own_end = rot.T @ (world[end, :3, 3] - origin)  # the chain as it is: one more example
    angles = np.vstack([angles, np.asarray(base_pose, float)[slots]])
    distance = np.linalg.norm(np.vstack([ends, own_end]) - seen, axis=1)
    near = np.argsort(distance)[:NEIGHBOURS]
    width = BANDWIDTH_SHARE * length
    weight = np.exp(-0.5 * ((distance[near] - distance[near[0]]) / width) ** 2)
    pose = np.array(base_pose, dtype=float)
    limits = skeleton.limits_array()[slots]
    pose[slots] = np.clip(weight @ angles[near] / weight.sum(), limits[:, 0], limits[:, 1])
    return pose


@lru_cache(maxsize=64)
def _chain_examples(library: PoseLibrary, skeleton: Skeleton, chain: tuple[int, ...],
                    end: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float] | None:
    """Per library pose: the chain's rotation angles and its end in the top's parent frame;
    with the pose slots and the chain's rest length. None when a channel is missing."""
    slots, columns = [], []
    for j in chain:
        for c in ROTATION_CHANNELS:
            name = f"{skeleton.joints[j].name}.{c}"
            if name in skeleton.channel_names:
                if name not in library.channel_names:
                    return None
                slots.append(skeleton.channel_index(name))
                columns.append(library.channel_names.index(name))
    angles = library.poses[:, columns]
    angles = angles[~np.isnan(angles).any(axis=1)]  # the examples that have every channel
    if not slots or not len(angles):
        return None
    slots_a = np.array(slots)
    poses = np.zeros((len(angles), skeleton.n_channels))
    poses[:, slots_a] = angles
    world = skeleton.forward_kinematics(poses)
    parent = int(skeleton.parents[chain[0]])
    ends = np.einsum("nji,nj->ni", world[:, parent, :3, :3],
                     world[:, end, :3, 3] - world[:, parent, :3, 3])
    rest = skeleton.joint_positions(skeleton.rest_pose())
    path = [*chain, end]
    length = float(np.linalg.norm(np.diff(rest[path], axis=0), axis=1).sum())
    return slots_a, angles, ends, max(length, 1e-6)
