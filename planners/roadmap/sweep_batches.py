"""The sweep search's loop over roadmap paths, in batches on two cores.

Sabater 2018's Algorithm 2 tries the roadmap paths cheapest first and takes the first
that gets a trajectory. With a compiled sweep (``Arm.sweep_paths``), a batch of paths is
swept in one kernel call that stops at the first success; two batches run at once, the
earlier one on this thread and the next one on a worker thread (the kernel releases the
GIL). The later batch counts only if every path of the earlier one failed, and only if
the node budget it was given (what was left before the earlier batch) would not have
ended it sooner once the earlier batch's nodes are counted; otherwise it is swept again
here with the budget the one-by-one loop would have given it. Blocker counts (``hits``)
of each batch are kept apart and added in path order. So the trajectory, the paths
tried, the nodes, the blocker counts and the budget are those of the one-by-one loop;
only the diagnostic count of configuration checks differs.

A robot that is boxed in fails every path of every departure (1,200 sweeps, most of
them ending within a few layers): those failing plans are where batches on two cores
save most (``benchmarks/bench_plan_stage.py`` reports their paths and seconds).

Units: joint angles as the arm's; time in the arm's units (planner steps here).
"""
from __future__ import annotations

import itertools
from typing import Iterator

import numpy as np

from rfp_twin.models.second_thread import second_thread
from rfp_twin.planners.roadmap.arm import ArmTrajectory, SearchStats
from rfp_twin.planners.roadmap.sweep import PathSweep, length_bound, path_positions

#: Outcomes of ``Arm.sweep_paths`` (those of the compiled layer loop).
FOUND, FAILED, BUDGET = 0, 1, 2

#: Paths in each batch, in turn (the last size repeats), each swept beside a batch of
#: the same size: the first path (the median success is the first or second path) and
#: its successor, then growing batches.
BATCH_SIZES = (1, 4, 8, 16, 32)


class _Batch:
    """Roadmap paths swept by one ``sweep_paths`` call (positions built by
    :func:`rfp_twin.planners.roadmap.sweep.path_positions`, as each path's
    :class:`PathSweep` would build them)."""

    def __init__(self, paths: list[np.ndarray], probe: PathSweep):
        self.paths = paths
        self.probe = probe
        pts = np.ascontiguousarray(np.vstack(paths), dtype=np.float64)
        p_ptr = np.zeros(len(paths) + 1, dtype=np.int64)
        p_ptr[1:] = np.cumsum([len(p) for p in paths])
        self.Qs, self.Ds, self.q_ptr = path_positions(
            pts, p_ptr, np.asarray(probe.arm.vmax, dtype=np.float64), float(probe.s.dt))
        k_static, k_max = probe.time_bounds()
        k_maxs = length_bound(k_static, k_max, np.diff(self.q_ptr))
        self.k_maxs = np.full(len(paths), -1, dtype=np.int64)     # -1: no bound
        if k_maxs is not None:
            self.k_maxs[:] = k_maxs
        self.k_static = -1 if k_static is None else k_static
        self.hits: np.ndarray | None = None
        self.stop = np.zeros(1, dtype=np.uint8)     # set: stop before the next path
        self.out = None

    def sweep(self, left: int) -> _Batch:
        """Sweep with node budget ``left`` (-1: none) into a blocker count of its own."""
        p = self.probe
        self.hits = np.zeros_like(p.arm.sweep.hits)
        self.out = p.arm.sweep_paths(self.Qs, self.Ds, self.q_ptr, p.frac, self.k_static,
                                     self.k_maxs, p.time(0), p.s.dt, p.goal_clear_after, left,
                                     self.hits, self.stop)
        return self


def _take(paths: Iterator[np.ndarray], n: int) -> list[np.ndarray]:
    return list(itertools.islice(paths, n))


def search_batched(probe: PathSweep, paths: Iterator[np.ndarray],
                   stats: SearchStats) -> ArmTrajectory | None:
    """The first of ``paths`` (the roadmap's, filtered and in order, at most
    ``settings.max_paths``) that gets a trajectory, or None; ``stats`` as the one-by-one
    loop leaves them. ``probe``: the sweep of the first path (its arm, with
    ``sweep_paths``, settings and goal time serve them all); its start must be clear."""
    sizes = iter(BATCH_SIZES)
    pending = [probe.path] + _take(paths, next(sizes) - 1)
    limit = probe.s.max_nodes
    while pending:
        here = _Batch(pending, probe)
        ahead_paths = _take(paths, len(pending))
        left = -1 if limit is None else max(0, limit - stats.nodes)
        ahead = next_batch = None
        if ahead_paths:
            # the next batch, optimistically with the budget left before this one
            next_batch = _Batch(ahead_paths, probe)
            ahead = second_thread().submit(next_batch.sweep, left)
        result, stop = _consume(here.sweep(left), stats)
        if stop:
            if ahead is not None:
                next_batch.stop[0] = 1      # unused: it stops before its next path
                ahead.result()
            return result
        if ahead is None:
            return None
        later = ahead.result()
        true_left = -1 if limit is None else max(0, limit - stats.nodes)
        if true_left >= 0 and (later.out[1] == BUDGET or int(later.out[4].sum()) >= true_left):
            later.sweep(true_left)           # the budget would have ended it sooner
        result, stop = _consume(later, stats)
        if stop:
            return result
        pending = _take(paths, next(sizes, len(pending)))
    return None


def _consume(batch: _Batch, stats: SearchStats) -> tuple[ArmTrajectory | None, bool]:
    """Count ``batch``'s sweeps in ``stats`` and its blockers in the arm's count; return
    (trajectory or None, whether the search ends here)."""
    n_done, outcome, k_end, came, nodes, checks = batch.out
    p = batch.probe
    stats.paths_tried += int(n_done)
    stats.nodes += int(nodes.sum())
    stats.checks += int(checks)
    p.arm.sweep.hits += batch.hits
    if outcome == FOUND:
        path = batch.paths[int(n_done) - 1]
        sweep = p if path is p.path else PathSweep(p.arm, path, p.s, stats, p.goal_clear_after)
        return sweep._trajectory(came, int(k_end)), True
    if outcome == BUDGET:
        stats.budget_exhausted = True
        return None, True
    return None, False
