"""Automatic key-image selection by the condition number criterion (paper Section 3.1).

Among the n frames of a clip, choose the m whose Gaussian kernel matrix H (built from their
PCA projections, as in the RBF pose map) has the smallest condition number of HᵀH. The paper
enumerates all C(n, m) subsets; an exact branch and bound gives the same answer far faster.
"""

from __future__ import annotations

import operator
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from gaitcore.analysis.kernel import DEFAULT_ALPHA, gaussian_kernel
from gaitcore.errors import GaitInputError
from gaitcore.progress import report

SINGULAR_RCOND = 1e-12
"""A set with λmin <= SINGULAR_RCOND λmax (eigenvalues of H) is numerically singular and its
condition number counts as +inf; :meth:`RBFPoseMap.fit` refuses such key sets too."""

_TIE_RTOL = 1e-9  # relative slack of every pruning test: rounding never drops a tie
_PROGRESS_INTERVAL_S = 0.05
_PROGRESS_TOTAL = 1_000_000
_N_STARTS = 8  # local-search starts, spread over the clip
_CHUNK = 100_000  # candidate sets tested per batch
_LEVELWISE_DEPTH = 5  # the last frames to add are grown level by level, not branched on
_MAX_LEVEL_ROWS = 4_000_000  # memory guard: a larger level is split into branches instead
MAX_CANDIDATES = 600
"""Above this many allowed frames (long clips), the candidates are thinned to one frame per
cell of a grid in PCA space (see :func:`_thin_pool`); the result is then optimal among
those candidates only and reported with ``exact=False``."""


@dataclass(frozen=True)
class KeySelection:
    """The outcome of a key-image search.

    Attributes
    ----------
    frames : tuple of int
        Sorted 0-based indices of the chosen frames.
    condition_number : float
        cond(HᵀH) = cond(H)² of the chosen set (+inf if it is numerically singular).
    exact : bool
        True when the search proved that no allowed set has a smaller condition number.
    nodes_visited : int
        Number of candidate key sets the exact search tested (effort, for benchmarks).
    """

    frames: tuple[int, ...]
    condition_number: float
    exact: bool
    nodes_visited: int


class _TimeUp(Exception):
    pass


def _cond_sq(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """cond(H)² from extreme eigenvalues, +inf where H is numerically singular."""
    out = np.full(np.shape(lo), np.inf)
    np.divide(hi, lo, out=out, where=lo > SINGULAR_RCOND * hi)
    return np.square(out, out=out)


def _set_conds(kernel: np.ndarray, sets: np.ndarray) -> np.ndarray:
    """cond(H)² of each row of ``sets`` (shape (b, k)) taken as a key set."""
    w = np.linalg.eigvalsh(kernel[sets[:, :, None], sets[:, None, :]])
    return _cond_sq(w[:, 0], w[:, -1])


def _validate(projections, m, alpha, pinned, forbidden) -> tuple[np.ndarray, list, list]:
    p = np.asarray(projections, dtype=float)
    if p.ndim != 2 or 0 in p.shape:
        raise GaitInputError(f"projections must be a 2-D array (frames, components), not {p.shape}")
    if not np.all(np.isfinite(p)):
        raise GaitInputError("projections contain NaN or infinity; recompute the PCA of the clip")
    if not (isinstance(m, (int, np.integer)) and m >= 1):
        raise GaitInputError(f"the number of key-images must be an integer >= 1, got {m!r}")
    if not (np.isfinite(alpha) and alpha > 0):
        raise GaitInputError(f"kernel width alpha must be positive and finite, got {alpha}")
    n = p.shape[0]
    if n < m:
        raise GaitInputError(f"cannot choose {m} key-images from a clip of {n} frames")
    try:
        pin, forb = (sorted({operator.index(f) for f in frames}) for frames in (pinned, forbidden))
    except TypeError:
        raise GaitInputError("pinned and forbidden frames must be integer frame indices") from None
    for name, frames in (("pinned", pin), ("forbidden", forb)):
        if frames and not 0 <= frames[0] <= frames[-1] < n:
            bad = frames[0] if frames[0] < 0 else frames[-1]
            raise GaitInputError(f"{name} frame {bad} is out of range: frames are 0..{n - 1}")
    if both := set(pin) & set(forb):
        raise GaitInputError(f"frame {min(both)} is both pinned and forbidden; choose one")
    if len(pin) > m:
        raise GaitInputError(f"{len(pin)} frames are pinned but only {m} key-images are wanted")
    if (n_distinct := len(np.unique(p, axis=0))) < m:
        raise GaitInputError(
            f"only {n_distinct} frames have distinct PCA coordinates, fewer than the {m} "
            "key-images wanted; ask for fewer keys"
        )
    if pin and len(np.unique(p[pin], axis=0)) < len(pin):
        raise GaitInputError("two pinned frames have identical PCA coordinates; unpin one")
    return p, pin, forb


def _candidate_pool(p: np.ndarray, pinned: list, forbidden: list) -> np.ndarray:
    """Frames the search may add: not pinned, not forbidden, first of identical frames."""
    group = np.unique(p, axis=0, return_inverse=True)[1].ravel().tolist()
    taken, barred, pool = {group[f] for f in pinned}, set(forbidden), []
    for f, g in enumerate(group):
        if g not in taken and f not in barred:
            taken.add(g)
            pool.append(f)
    return np.array(pool, dtype=np.intp)


def _local_search(kernel, m, pinned, pool, starts, deadline) -> tuple[list, float]:
    """Greedy completion then best-improvement swaps from each start; the best set found."""
    best, best_cond = None, np.inf
    for chosen in map(list, starts):
        while len(chosen) < m:
            cands = pool[~np.isin(pool, chosen)]
            sets = np.column_stack([np.tile(chosen, (cands.size, 1)), cands])
            chosen.append(int(cands[np.argmin(_set_conds(kernel, sets))]))
        cond = float(_set_conds(kernel, np.array([chosen]))[0])
        free = range(len(pinned), m)
        while (cands := pool[~np.isin(pool, chosen)]).size:
            sets = np.tile(chosen, (len(free) * cands.size, 1))
            for k, pos in enumerate(free):
                sets[k * cands.size : (k + 1) * cands.size, pos] = cands
            conds = _set_conds(kernel, sets)
            if not conds.min() < cond * (1.0 - _TIE_RTOL):
                break
            chosen, cond = sets[np.argmin(conds)].tolist(), float(conds.min())
        if best is None or cond < best_cond:
            best, best_cond = chosen, cond
        if deadline is not None and time.monotonic() >= deadline:
            break
    if best is None:
        raise ValueError("the local search was given no start")
    return best, best_cond


class _BranchAndBound:
    """Exact search for the best-conditioned m-set among supersets of the pinned frames.

    With many frames still to add it branches on one frame at a time (a branch may add only
    frames after it). Once at most ``_LEVELWISE_DEPTH`` remain, it grows the branch's sets
    level by level, as the "apriori" algorithm does: a set is kept only if it may beat the
    best set found, and a set one frame larger is formed only if all its subsets that hold
    the branch's fixed frames were kept. Interlacing makes both rules exact.
    """

    def __init__(self, kernel, m, pinned, pool, incumbent, progress, deadline):
        self.kernel, self.m, self.pinned, self.pool = kernel, m, pinned, pool
        self.best, self.best_cond = incumbent
        self.progress, self.deadline = progress, deadline
        self.nodes, self.done, self.next_report = 0, 0.0, 0.0
        self.pair_cond = _cond_sq(1.0 - kernel, 1.0 + kernel)  # 2×2 sets: λ = 1 ± k
        np.fill_diagonal(self.pair_cond, np.inf)
        self._refresh()

    def _refresh(self) -> None:
        self.threshold = self.best_cond * (1.0 + _TIE_RTOL)
        self.compatible = self.pair_cond < self.threshold

    def _tick(self) -> None:
        now = time.monotonic()
        if self.deadline is not None and now >= self.deadline:
            raise _TimeUp
        if self.progress is not None and now >= self.next_report:
            self.next_report = now + _PROGRESS_INTERVAL_S
            done = min(int(self.done * _PROGRESS_TOTAL), _PROGRESS_TOTAL)
            report(self.progress, done, _PROGRESS_TOTAL, "key-image search cancelled")

    def _keep(self, members: list, cands: np.ndarray, rows: np.ndarray, final: bool) -> np.ndarray:
        """Which sets members + cands[row] may beat the best set. On the final level, the
        best of them becomes the best set if it is better."""
        sets = np.empty((rows.shape[0], len(members) + rows.shape[1]), dtype=np.intp)
        sets[:, : len(members)] = members
        sets[:, len(members) :] = cands[rows]
        self.nodes += sets.shape[0]
        keep = np.empty(sets.shape[0], dtype=bool)
        for s in range(0, sets.shape[0], _CHUNK):
            self._tick()
            keep[s : s + _CHUNK] = _may_beat(self.kernel, sets[s : s + _CHUNK], self.threshold)
        if final and keep.any():
            hits = np.flatnonzero(keep)
            cond = _set_conds(self.kernel, sets[hits])
            if cond.min() < self.best_cond:
                self.best, self.best_cond = sets[hits[np.argmin(cond)]].tolist(), float(cond.min())
                self._refresh()
        return keep

    def run(self) -> None:
        members, cands = list(self.pinned), self.pool
        if members:
            final = len(members) + 1 == self.m
            cands = cands[self._keep(members, cands, np.arange(cands.size)[:, None], final)]
        if len(members) + 1 < self.m:
            self._node(members, cands, 1.0)

    def _node(self, members: list, cands: np.ndarray, weight: float) -> None:
        """Search the sets members + (r frames of cands); each members + [j] may beat."""
        r = self.m - len(members)
        if r <= _LEVELWISE_DEPTH and cands.size**r < 2**62:
            before = self.done
            if self._levelwise(members, cands, weight):
                return
            weight -= self.done - before
        share = weight / max(cands.size, 1)
        for i in range(cands.size - r + 1):
            rest = cands[i + 1 :]
            rest = rest[self.compatible[cands[i], rest]]
            child = members + [int(cands[i])]
            if rest.size >= r - 1:
                rest = rest[self._keep(child, rest, np.arange(rest.size)[:, None], r == 2)]
            if rest.size >= r - 1 and r > 2:
                self._node(child, rest, share)
            else:
                self.done += share
        self.done += share * max(min(r - 1, cands.size), 0)

    def _levelwise(self, members: list, cands: np.ndarray, weight: float) -> bool:
        """Grow members + X level by level, X a sorted tuple of positions in ``cands``.

        Returns False, for the caller to branch instead, if a level outgrows the memory guard.
        """
        q, r = cands.size, self.m - len(members)
        rows = np.arange(q, dtype=np.int32)[:, None]
        for size in range(2, r + 1):
            if rows.shape[0] < 2:
                break
            base = q ** np.arange(size - 2, -1, -1, dtype=np.int64)
            codes = rows @ base  # sorted, as rows are
            kept, n_kept = [], 0
            for new in _joins(rows):  # new = rows[a] + [last of rows[b]]: two subsets kept
                new = new[self.compatible[cands[new[:, -2]], cands[new[:, -1]]]]
                for drop in range(size - 2):  # the other subsets that hold all members
                    sub = np.delete(new, drop, axis=1) @ base
                    at = np.minimum(np.searchsorted(codes, sub), codes.size - 1)
                    new = new[codes[at] == sub]
                kept.append(new[self._keep(members, cands, new, final=size == r)])
                n_kept += kept[-1].shape[0]
                if n_kept > _MAX_LEVEL_ROWS and size < r:
                    return False
            rows = np.concatenate(kept)
            self.done += weight / (r - 1)
            weight -= weight / (r - 1)
        self.done += weight
        return True


def _joins(rows: np.ndarray) -> Iterator[np.ndarray]:
    """Unions of two rows that differ only in their last element, in chunks of ~_CHUNK.

    ``rows`` of shape (n, l), sorted lexically, give rows of shape (., l + 1), also sorted.
    """
    n = rows.shape[0]
    starts = np.r_[True, (rows[1:, :-1] != rows[:-1, :-1]).any(1)]
    group_end = np.r_[np.flatnonzero(starts)[1:], n][np.cumsum(starts) - 1]
    count = group_end - np.arange(n) - 1
    total = np.cumsum(count)
    cuts = np.searchsorted(total, np.arange(_CHUNK, total[-1], _CHUNK), side="right")
    edges = np.unique(np.r_[0, cuts, n])
    for lo, hi in zip(edges[:-1], edges[1:]):
        c = count[lo:hi]
        a = np.repeat(np.arange(lo, hi), c)
        b = a + 1 + np.arange(a.size) - np.repeat(np.cumsum(c) - c, c)
        yield np.column_stack([rows[a], rows[b, -1]])


def _may_beat(kernel: np.ndarray, sets: np.ndarray, threshold: float) -> np.ndarray:
    """False for the rows of ``sets`` (shape (b, k)) whose cond(H)² is surely >= threshold.

    The Rayleigh quotient hi after two power steps from the all-ones vector is a lower bound
    of λmax (the Perron vector of a positive matrix is nearly uniform). If H - (hi / s) I is
    not positive definite (s² = threshold), then λmin <= hi / s, so λmax / λmin >= s. The
    LDLᵀ test works on one length-b vector per matrix entry, fast for small k.
    """
    k, zero = sets.shape[1], np.zeros(sets.shape[0])
    cols = [np.ascontiguousarray(c) for c in sets.T]
    h = [[zero] * k for _ in range(k)]  # off-diagonal entries; the diagonal is 1
    for i in range(k):
        for j in range(i):
            h[i][j] = h[j][i] = kernel[cols[i], cols[j]]
    v = [sum(h[i], zero) + 1.0 for i in range(k)]
    for _ in range(2):
        w = [v[i] + sum((h[i][j] * v[j] for j in range(k)), zero) for i in range(k)]
        hi = sum(a * b for a, b in zip(v, w)) / sum(a * a for a in v)
        v = w
    scale = (1.0 - _TIE_RTOL) / np.sqrt(threshold) if np.isfinite(threshold) else SINGULAR_RCOND
    shift = hi * scale
    low = [[zero] * k for _ in range(k)]
    d: list[np.ndarray] = []
    ok = np.ones(sets.shape[0], dtype=bool)
    with np.errstate(all="ignore"):
        for j in range(k):
            ld = [low[j][p] * d[p] for p in range(j)]
            d.append((1.0 - shift) - sum((ld[p] * low[j][p] for p in range(j)), zero))
            ok &= d[j] > 0
            for i in range(j + 1, k):
                low[i][j] = (h[i][j] - sum((low[i][p] * ld[p] for p in range(j)), zero)) / d[j]
    return ok


def _select(kernel, m, pinned, pool, progress, deadline, seeds=()) -> KeySelection:
    if len(pinned) + pool.size < m:
        raise GaitInputError(
            f"only {len(pinned) + pool.size} frames are allowed (not forbidden, distinct "
            f"coordinates), fewer than the {m} key-images wanted; forbid fewer or ask for fewer"
        )
    if len(pinned) == m:
        cond = float(_set_conds(kernel, np.array([pinned]))[0])
        return KeySelection(tuple(pinned), cond, True, 1)
    spread = pool[np.unique(np.linspace(0, pool.size - 1, _N_STARTS).round().astype(int))]
    starts = [pinned + [int(f)] for f in spread]
    starts += [pinned + [f for f in seed if f not in pinned and f in pool] for seed in seeds]
    incumbent = _local_search(kernel, m, pinned, pool, starts, deadline)
    search = _BranchAndBound(kernel, m, pinned, pool, incumbent, progress, deadline)
    try:
        search.run()
        exact = True
    except _TimeUp:
        exact = False
    if exact and progress is not None:
        progress(_PROGRESS_TOTAL, _PROGRESS_TOTAL)
    return KeySelection(tuple(sorted(search.best)), search.best_cond, exact, search.nodes)


def _prepare(
    p, alpha, pin, forb, time_limit_s
) -> tuple[np.ndarray, list, np.ndarray, np.ndarray, bool, float | None]:
    """Kernel matrix over the pinned frames and the candidate pool, and the search's deadline.

    Returns the kernel, the pinned and pool positions in it, the global frame number of each
    of its rows, whether the pool was thinned, and the deadline.
    """
    if time_limit_s is not None and not time_limit_s >= 0:
        raise GaitInputError(f"time_limit_s must be a number of seconds >= 0, got {time_limit_s}")
    pool = _candidate_pool(p, pin, forb)
    thinned = pool.size > MAX_CANDIDATES
    if thinned:
        pool = _thin_pool(p, pool, MAX_CANDIDATES)
    rows = np.concatenate([np.asarray(pin, dtype=np.intp), pool])
    kernel = gaussian_kernel(p[rows], p[rows], alpha=alpha)
    np.fill_diagonal(kernel, 1.0)
    deadline = None if time_limit_s is None else time.monotonic() + time_limit_s
    local_pin = list(range(len(pin)))
    local_pool = np.arange(len(pin), rows.size, dtype=np.intp)
    return kernel, local_pin, local_pool, rows, thinned, deadline


def _thin_pool(p: np.ndarray, pool: np.ndarray, limit: int) -> np.ndarray:
    """At most ``limit`` frames of ``pool``: the first frame of each occupied cell of a grid
    in PCA space, with the finest cell size that keeps the count under the limit.

    A long clip of a periodic gait runs round the same loop many times, so its frames crowd
    the same places of PCA space; one frame per small cell keeps the loop's shape.
    """
    q = p[pool]
    span = float(np.ptp(q, axis=0).max()) or 1.0
    lo, hi = span * 1e-6, span
    best = pool[:1]
    for _ in range(40):
        cell = 0.5 * (lo + hi)
        _, first = np.unique(np.floor(q / cell), axis=0, return_index=True)
        if first.size > limit:
            lo = cell
        else:
            hi, best = cell, pool[np.sort(first)]
    return best


def _globalise(sel: KeySelection, rows: np.ndarray, thinned: bool) -> KeySelection:
    frames = tuple(sorted(int(rows[f]) for f in sel.frames))
    return KeySelection(frames, sel.condition_number, sel.exact and not thinned, sel.nodes_visited)


def select_key_images(
    projections: np.ndarray,
    m: int,
    *,
    alpha: float = DEFAULT_ALPHA,
    pinned: Iterable[int] = (),
    forbidden: Iterable[int] = (),
    progress: Callable[[int, int], bool] | None = None,
    time_limit_s: float | None = None,
) -> KeySelection:
    """Choose the m key-images whose kernel matrix is best conditioned.

    Parameters
    ----------
    projections : array_like of shape (n, c)
        PCA projections of the n frames (normalized, as :class:`ImagePCA` gives them).
    m : int
        Number of key-images, 1 <= m <= n.
    alpha : float, optional
        Gaussian kernel width, h(r) = exp(-alpha r²) (default ln 2, as the RBF pose map).
    pinned : iterable of int, optional
        Frames that must be among the keys (at most m).
    forbidden : iterable of int, optional
        Frames that must not be keys.
    progress : callable (done, total) -> bool, optional
        Called about every 50 ms with the explored share of the search, in millionths;
        returning False cancels the search.
    time_limit_s : float, optional
        Wall-clock budget; when it runs out the best set found so far is returned with
        ``exact=False``.

    Returns
    -------
    KeySelection
        The chosen frames, cond(HᵀH) of their (m, m) kernel matrix H, and whether the
        search proved it minimal over all allowed sets (up to ties within a relative 1e-9).
        Of identical frames only the first can be chosen.

    Raises
    ------
    GaitInputError
        If projections are not a finite, non-empty 2-D array, m < 1, there are fewer than m
        frames with distinct coordinates, pinned or forbidden frames are out of range or
        overlap, more than m are pinned, or too few allowed frames are left.
    Cancelled
        If ``progress`` returned False.

    Notes
    -----
    Paper Section 3.1 criterion, exact without the paper's enumeration of all C(n, m)
    subsets. H of a set is a principal submatrix of the n×n kernel matrix K (symmetric
    positive definite for distinct frames), so by Cauchy interlacing adding a frame never
    lowers λmax nor raises λmin: a set's condition number bounds that of all its supersets.
    The search, seeded by greedy + swap local search, drops every set (pairs first, by their
    2×2 condition ((1+k)/(1-k))²) that already reaches the best condition number found, and
    forms only sets whose subsets all survived. Numerically singular sets (λmin <= 1e-12
    λmax) count as +inf.
    """
    p, pin, forb = _validate(projections, m, alpha, pinned, forbidden)
    kernel, pin, pool, rows, thinned, deadline = _prepare(p, alpha, pin, forb, time_limit_s)
    return _globalise(_select(kernel, int(m), pin, pool, progress, deadline), rows, thinned)


def condition_curve(
    projections: np.ndarray,
    m_values: Iterable[int],
    *,
    alpha: float = DEFAULT_ALPHA,
    pinned: Iterable[int] = (),
    forbidden: Iterable[int] = (),
    time_limit_s: float | None = None,
) -> list[KeySelection]:
    """Best key set for each number of keys, to help choose how many to pose.

    Parameters
    ----------
    projections : array_like of shape (n, c)
    m_values : iterable of int
        Numbers of key-images to try.
    alpha, pinned, forbidden
        As in :func:`select_key_images`.
    time_limit_s : float, optional
        Budget for the whole curve; selections cut short by it have ``exact=False``.

    Returns
    -------
    list of KeySelection
        One per entry of ``m_values``, in the same order. The condition number never
        decreases with m (interlacing).

    Raises
    ------
    GaitInputError
        As :func:`select_key_images` for any of the m values, or if m_values is empty.

    Notes
    -----
    Paper Section 3.1 (the number of keys is "a compromise ... case by case"). Each search
    is seeded with the best set for the next smaller m.
    """
    ms, pinned, forbidden = list(m_values), tuple(pinned), tuple(forbidden)
    if not ms:
        raise GaitInputError("give at least one number of key-images for the condition curve")
    for m in ms:
        p, pin, forb = _validate(projections, m, alpha, pinned, forbidden)
    kernel, pin, pool, rows, thinned, deadline = _prepare(p, alpha, pin, forb, time_limit_s)
    results: dict[int, KeySelection] = {}
    for m in sorted({int(m) for m in ms}):
        seeds = [list(results[max(results)].frames)] if results else []
        results[m] = _select(kernel, m, pin, pool, None, deadline, seeds)
    return [_globalise(results[int(m)], rows, thinned) for m in ms]
