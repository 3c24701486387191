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
them ending within a few layers); the second core halves the time of those sweeps.

Units: joint angles as the arm's; time in the arm's units (planner steps here).
"""
from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Iterator

import numpy as np

from rfp_twin.planners.roadmap.arm import Arm, ArmTrajectory, RoadmapSettings, SearchStats
from rfp_twin.planners.roadmap.sweep import _PathSweep

#: Outcomes of ``Arm.sweep_paths`` (those of the compiled layer loop).
FOUND, FAILED, BUDGET = 0, 1, 2

#: Paths in each batch, in turn (the last size repeats), each swept beside a batch of
#: the same size: the first path (the median success is the first or second path) and
#: its successor, then growing batches.
BATCH_SIZES = (1, 4, 8, 16, 32)

_WORKER: ThreadPoolExecutor | None = None
_WORKER_LOCK = threading.Lock()


def _worker() -> ThreadPoolExecutor:
    global _WORKER
    with _WORKER_LOCK:
        if _WORKER is None:
            _WORKER = ThreadPoolExecutor(1, thread_name_prefix="sweep-batch")
        return _WORKER


class _Batch:
    """Paths (their prepared sweeps) swept by one ``sweep_paths`` call."""

    def __init__(self, sweeps: list[_PathSweep], k_static: int):
        self.sweeps = sweeps
        q_ptr = np.zeros(len(sweeps) + 1, dtype=np.int64)
        q_ptr[1:] = np.cumsum([len(sw.Q) for sw in sweeps])
        self.q_ptr = q_ptr
        self.Qs = np.ascontiguousarray(np.vstack([sw.Q for sw in sweeps]), dtype=np.float64)
        self.Ds = np.ascontiguousarray(np.vstack([sw.D for sw in sweeps]), dtype=np.float64)
        k_max = [sw.bounds()[1] for sw in sweeps]
        self.k_maxs = np.array([-1 if k is None else k for k in k_max], dtype=np.int64)
        self.k_static = k_static
        self.hits: np.ndarray | None = None
        self.stop = np.zeros(1, dtype=np.uint8)     # set: stop before the next path
        self.out = None

    def sweep(self, arm: Arm, settings: RoadmapSettings, left: int) -> _Batch:
        """Sweep with node budget ``left`` (-1: none) into a blocker count of its own."""
        first = self.sweeps[0]
        self.hits = np.zeros_like(arm.sweep.hits)
        self.out = arm.sweep_paths(self.Qs, self.Ds, self.q_ptr, first.frac, self.k_static,
                                   self.k_maxs, first.time(0), settings.dt,
                                   first.goal_clear_after, left, self.hits, self.stop)
        return self


def _prepared(arm: Arm, paths: Iterator[np.ndarray], settings: RoadmapSettings,
              stats: SearchStats, clear_after: float, n: int) -> list[_PathSweep]:
    out = []
    for path in paths:
        out.append(_PathSweep(arm, path, settings, stats, clear_after))
        if len(out) == n:
            break
    return out


def search_batched(arm: Arm, paths: Iterator[np.ndarray], settings: RoadmapSettings,
                   stats: SearchStats, clear_after: float) -> ArmTrajectory | None:
    """The first of ``paths`` (the roadmap's, filtered and in order, at most
    ``settings.max_paths``) that gets a trajectory, or None; ``stats`` as the one-by-one
    loop leaves them. ``arm.sweep_paths`` must be set and the start clear."""
    sizes = iter(BATCH_SIZES)
    size = next(sizes)
    pending = _prepared(arm, paths, settings, stats, clear_after, size)
    if not pending:
        return None
    k_static = pending[0].bounds()[0]
    k_static = -1 if k_static is None else k_static
    limit = settings.max_nodes
    while pending:
        here = _Batch(pending, k_static)
        ahead_sweeps = _prepared(arm, paths, settings, stats, clear_after, len(pending))
        left = -1 if limit is None else max(0, limit - stats.nodes)
        ahead = next_batch = None
        if ahead_sweeps:
            # the next batch, optimistically with the budget left before this one
            next_batch = _Batch(ahead_sweeps, k_static)
            ahead = _worker().submit(next_batch.sweep, arm, settings, left)
        result, stop = _consume(here.sweep(arm, settings, left), arm, stats)
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
            later.sweep(arm, settings, true_left)   # the budget would have ended it sooner
        result, stop = _consume(later, arm, stats)
        if stop:
            return result
        size = next(sizes, size)
        pending = _prepared(arm, paths, settings, stats, clear_after, size)
    return None


def _consume(batch: _Batch, arm: Arm, stats: SearchStats) -> tuple[ArmTrajectory | None, bool]:
    """Count ``batch``'s sweeps in ``stats`` and its blockers in the arm's count; return
    (trajectory or None, whether the search ends here)."""
    n_done, outcome, k_end, came, nodes, checks = batch.out
    stats.paths_tried += int(n_done)
    stats.nodes += int(nodes.sum())
    stats.checks += int(checks)
    arm.sweep.hits += batch.hits
    if outcome == FOUND:
        return batch.sweeps[int(n_done) - 1]._trajectory(came, int(k_end)), True
    if outcome == BUDGET:
        stats.budget_exhausted = True
        return None, True
    return None, False
