"""Deadlock resolution by re-running the plan, locally, with greedy-first Markov robots around the groups.

When the stepwise planner leaves groups of robots deadlocked, the cheapest thing that can
untangle them is the planner itself, run again around each group with the robots in and
near it made *greedy-first Markov* robots
(``greedy_first`` of :func:`rfp_twin.planners.stepwise.kernel.run_stepwise`): each takes
its obvious move (one step towards its destination on each axis) whenever that move
passes the step rule, exactly as a greedy robot does, and draws a Markov move (Sayres
2021 Sect. 4.2: random candidate order, energy with probability ``phobia``, acceptance
with probability ``greed``) only when the obvious move is blocked, or steps aside when it
is at its destination and a neighbour encroaches (Eq. 10). So the region moves as the
plan did wherever it was free to, and jiggles only where it was locked: the fold is
rarely longer than the first run's, while a full Markov region (random moves at every
step) made it 25-70 % longer (medians).

**Local runs.** A re-run covers only a *patch*: the region, :data:`MARGIN_HOPS` more hops
of greedy robots that may react to it, and a *ring* (every other neighbour of those)
that replays the first run's motion step for step, each replayed move checked by the
step rule against the patch (:func:`rfp_twin.planners.stepwise.run_array` with
``robots`` and ``script``). The robots beyond the ring never see a change: the ring does
exactly what they saw it do, and the patch's robots have no other neighbours. So the
first run with the patch's motion swapped in satisfies the step rule at every step (a
ring move that the patch leaves no room for fails the attempt). A patch costs its own
size, not the array's (2-3 s a whole-array run at 12,871 robots, 0.03-0.09 s a patch of
150-450 robots), and each group gets its own ladder: one stubborn group does not fail
the others. Groups are taken in turn, each ring replaying the motion as the groups
before left it; the robots of patches solved before, and the other groups' stuck robots,
replay too (a patch never re-plans them).

Attempts climb a ladder (:data:`LADDER`): the region is the group's stuck robots
grown by some hops through the Eq. 4 neighbour graph (plus the robots stuck in earlier
attempts), each attempt with its own kernel seed. The first attempt in which every
robot of the patch reaches its destination *without lengthening the first run's fold*
is taken at once; otherwise the shortest complete attempt, once :data:`EXTRA_ATTEMPTS`
more have been made after the first complete one (or the ladder is spent, or
:data:`PATIENCE` attempts in a row made no progress). A group no attempt completes
keeps its first-run motion for the next resolver (the state-time search). The
pipeline's independent 2D check looks at the result as at any plan.

The re-runs come before the state-time search because they untangle most groups in a
fraction of its time and without lengthening the fold, where the search's plans often
do (benchmarks/HISTORY.md, "Code comments", under the former path planners/rerun.py).
:class:`RerunResolver` is the strategy of the chain (greedy plans, before the search).

Units: planner steps; wall time in s.
"""
from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Callable

import numpy as np

from rfp_twin.planners.deadlocks.groups import arrival_steps, clusters, grow_region, stuck_mask
from rfp_twin.planners.deadlocks.resolver import Round
from rfp_twin.planners.plan import build_paths
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.planners.stepwise import ANGLE_EPS, StepRun, run_array

#: The attempts, in order: (hops the region grows from the stuck robots, greed, phobia)
#: of the region's greedy-first Markov robots.
LADDER = ((2, 0.8, 0.3), (2, 0.8, 0.3), (3, 0.9, 0.2), (1, 0.8, 0.3), (3, 0.8, 0.3),
          (2, 0.5, 0.5), (0, 0.8, 0.3), (3, 0.5, 0.5))

#: Attempts made after the first complete one, looking for a shorter fold.
EXTRA_ATTEMPTS = 2

#: While no attempt is complete, the ladder stops after this many attempts in a row that
#: leave no fewer robots stuck than the best so far, or are blocked (a group none of them
#: untangles is left to the search, ~1 s a group; an attempt is a patch, ~0.05 s).
PATIENCE = 4

#: An attempt stops after this many times the first run's fold (:func:`arrival_steps`):
#: by then it has failed (a complete attempt that late would lengthen the fold by as
#: much), and an attempt handed to the search with robots still stuck ends there. Its
#: robots around the stuck ones go on stepping aside until then, so the cap is also how
#: much such a plan can lengthen the fold: a larger cap lengthens the folds of the hard
#: cases, a smaller one loses attempts that would have completed.
STEP_CAP = 1.10

#: Hops of greedy robots between a region and the ring that replays the first run: room
#: for the region's changes to settle before the ring, which cannot give way. Each
#: attempt blocked by the ring widens it by one hop, up to :data:`MAX_MARGIN_HOPS`.
MARGIN_HOPS = 2
MAX_MARGIN_HOPS = 4

#: On arrays of at most this many robots (a whole run: 0.05-0.4 s), groups that their
#: patches left stuck get the ladder again as whole-array runs around every group,
#: taken only when one completes: on the 500-robot layout at 3.0-3.5 mm,
#: neighbouring groups squeeze each other's patches and often need to move together.
#: This ladder depends only on the first run, so it starts with the patches, in a thread
#: of its own (the kernel releases the GIL: on a second core it costs no wall time while
#: the patches run), and is stopped after its current attempt if the patches solve every
#: group: the same result as running it after them.
WHOLE_ARRAY_ROBOTS = 2000

#: Attempts at most of that whole-array ladder (the patches get ``attempts``). On crowded
#: arrays its runs rarely complete: it is there for the attempt that leaves fewest robots
#: stuck for the search, which the first five rungs of :data:`LADDER` nearly always
#: give; the later ones cost 0.15-0.25 s each and almost never change the plan.
WHOLE_ATTEMPTS = 5

#: One local kernel run: (robots (k,) int64 increasing, script (ptr, steps, angles) CSR
#: paths of the ring robots in ``robots`` order (empty rows: the others), movable (k,),
#: greed (k,), phobia (k,), greedy_first (k,) bool, seed, max_steps) -> StepRun over
#: ``robots`` (``replay_blocked`` when a ring move found no room).
RunFn = Callable[[np.ndarray, tuple, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int],
                 StepRun]


@dataclass
class Rerun:
    """What :func:`rerun_deadlocks` found.

    Attributes
    ----------
    run : StepRun, the first run with the motion of every solved group's patch swapped
        in (the first run itself when none was solved); the robots of unsolved groups
        keep their first-run motion, and the run its length
    solved : (n,) bool, the stuck robots of the groups solved
    n_groups, n_solved : int, groups tried and solved
    attempts : int, kernel runs made
    blocked : int, attempts stopped by a ring move that found no room
    seconds : float, wall time of all of it
    partial : bool, ``run`` is a whole-array attempt whose stuck robots went on wandering
        until the step cap (a search had better plan them from step 0)
    """

    run: StepRun
    solved: np.ndarray
    n_groups: int
    n_solved: int
    attempts: int
    blocked: int
    seconds: float
    partial: bool = False

    @property
    def complete(self) -> bool:
        """Every group solved."""
        return self.n_solved == self.n_groups


@dataclass(frozen=True)
class RerunRecord:
    """What the re-runs did in one round: deadlocked ``groups`` / ``robots`` they
    resolved, kernel runs made (``attempts``) and their wall time (``seconds``)."""

    groups: int
    robots: int
    attempts: int
    seconds: float


class RerunResolver:
    """Local re-runs of the round's greedy run around its deadlocked groups
    (:func:`rerun_deadlocks`, at most ``settings.reruns`` attempts a group), each group's
    patch inside a ring of robots replaying the run."""

    def __init__(self, settings: PlannerSettings) -> None:
        self.settings = settings

    def applies(self, rnd: Round) -> bool:
        return True

    def resolve(self, rnd: Round) -> RerunRecord:
        s, geom, start, goal = self.settings, rnd.geom, rnd.start, rnd.goal

        def run(robots, script, mov, greed, phobia, greedy_first, seed, max_steps):
            return run_array(geom, start[robots], goal[robots], mov, step_deg=s.step_deg,
                             max_steps=min(max_steps, s.steps_limit), md=rnd.md, greed=greed,
                             phobia=phobia, seed=seed, greedy_first=greedy_first,
                             robots=robots, script=script)

        rr = rerun_deadlocks(rnd.run, goal, rnd.movable, geom.pairs, rnd.run_paths(), run,
                             rnd.seed + 104729, s.reruns)
        groups = rnd.groups
        rnd.run, rnd.partial = rr.run, rr.partial
        rnd.settle()
        resolved = [g for g in groups if not rnd.stuck[g].any()]
        return RerunRecord(len(resolved), int(sum(len(g) for g in resolved)), rr.attempts,
                           rr.seconds)


def ring_script(paths: tuple, robots: np.ndarray, ring: np.ndarray,
                override: dict | None = None) -> tuple:
    """CSR paths (ptr, steps, angles) of ``robots`` ((k,) int64) where ``ring`` ((k,) bool)
    is True, empty rows elsewhere, from the whole array's CSR ``paths``; a robot in
    ``override`` ({robot: (steps (m,), angles (m, 2))}) gets that path instead."""
    ptr, steps, angles = paths
    override = override or {}
    rows_s, rows_a = [], []
    counts = np.zeros(robots.size, dtype=np.int64)
    for k in np.flatnonzero(ring):
        r = int(robots[k])
        st, an = override[r] if r in override else (steps[ptr[r]:ptr[r + 1]],
                                                     angles[ptr[r]:ptr[r + 1]])
        rows_s.append(st)
        rows_a.append(an)
        counts[k] = st.size
    out = np.zeros(robots.size + 1, dtype=np.int64)
    np.cumsum(counts, out=out[1:])
    if not rows_s:
        return out, np.zeros(0), np.zeros((0, 2))
    return out, np.concatenate(rows_s), np.concatenate(rows_a)


def rerun_deadlocks(first: StepRun, goal: np.ndarray, movable: np.ndarray, pairs: np.ndarray,
                    paths: tuple, run: RunFn, seed: int, attempts: int = len(LADDER)) -> Rerun:
    """Re-run each group of the robots that the greedy run ``first`` left stuck in its own
    patch, with greedy-first Markov regions, and swap the solved patches in.

    Groups are taken one after the other; each patch's ring replays the motion as it is
    after the groups before (the first run with their patches swapped in), so patches may
    overlap. Robots of the other groups still stuck are kept out of a patch's interior.

    first : the plan's greedy run; goal : (n, 2) deg, its destinations; movable : (n,)
    bool; pairs : (p, 2) neighbour pairs; paths : (ptr, steps, angles), ``first`` as CSR
    paths (:func:`rfp_twin.planners.plan.build_paths`); run : one local kernel run
    (:data:`RunFn`); seed : base of the attempts' kernel seeds; attempts : at most that
    many runs a group (the ladder is cycled with new seeds beyond its length).
    """
    clock = time.perf_counter()
    stuck = stuck_mask(first, goal, movable)
    fold = arrival_steps(first, stuck)
    max_steps = max(1, int(np.ceil(STEP_CAP * fold)))
    ptr, _, angles = paths
    start = angles[ptr[:-1]]
    solved = np.zeros(stuck.size, dtype=bool)
    override: dict = {}              # robot -> its path (steps, angles) from a solved patch
    events: dict = {}                # robot -> its breakpoints (steps, angles) from it
    final = first.final.copy()
    made = blocked = n_solved = 0
    length = fold
    groups = clusters(pairs, stuck, 0)
    # the whole-array ladder below needs nothing from the patches: it runs on the second
    # core meanwhile (the kernel releases the GIL) and is used only if a group is left
    ahead = None
    if stuck.size <= WHOLE_ARRAY_ROBOTS and groups:
        ahead = _Ahead(attempt_ladder, stuck, None, movable, pairs, paths, {}, run, goal, fold,
                       max_steps, int(seed) + 7919, min(attempts, WHOLE_ATTEMPTS))
    for c, members in enumerate(groups):
        own = np.zeros(stuck.size, dtype=bool)
        own[members] = True
        # other groups' stuck robots, and the robots of the patches solved before, replay
        allowed = ~(stuck & ~solved & ~own)
        allowed[list(override)] = False
        best, tries, stops, _ = attempt_ladder(own, allowed, movable, pairs, paths, override, run,
                                        goal, fold, max_steps, int(seed) + 1000003 * c, attempts)
        made += tries
        blocked += stops
        if best is None:
            continue
        robots, inner, attempt, arrived = best
        n_solved += 1
        solved |= own
        length = max(length, arrived)
        sub_ptr, sub_steps, sub_angles = build_paths(
            robots.size, attempt.ev_robot, attempt.ev_step, attempt.ev_angles, start[robots],
            attempt.final, attempt.n_steps)
        # each patch robot's breakpoints, in the kernel's (step) order
        by_robot = np.argsort(attempt.ev_robot, kind="stable")
        ev_ptr = np.searchsorted(attempt.ev_robot[by_robot], np.arange(robots.size + 1))
        for k in np.flatnonzero(inner):
            r = int(robots[k])
            override[r] = (sub_steps[sub_ptr[k]:sub_ptr[k + 1]], sub_angles[sub_ptr[k]:sub_ptr[k + 1]])
            mine = by_robot[ev_ptr[k]:ev_ptr[k + 1]]
            events[r] = (attempt.ev_step[mine], attempt.ev_angles[mine])
            final[r] = attempt.final[k]
    if ahead is not None and n_solved == len(groups):
        ahead.cancel()
    elif ahead is not None:
        # groups next to each other may need to give way together: whole-array runs
        best, tries, stops, closest = ahead.result()
        made += tries
        blocked += stops
        if best is not None:
            return Rerun(best[2], stuck.copy(), len(groups), len(groups), made, blocked,
                         time.perf_counter() - clock)
        left = stuck_mask(closest, goal, movable) if closest is not None else stuck
        if left.sum() < (stuck & ~solved).sum():
            # fewer stuck than the patches left: its stuck robots wandered until the cap
            return Rerun(closest, stuck & ~left, len(groups),
                         len([g for g in groups if not left[g].any()]), made, blocked,
                         time.perf_counter() - clock, partial=True)
    merged = first
    if events:
        old = ~np.isin(first.ev_robot, np.fromiter(events, dtype=np.int64))
        rows = list(events)
        merged = StepRun(
            final, int(length if n_solved == len(groups) else max(length, first.n_steps)),
            np.concatenate([first.ev_robot[old]]
                           + [np.full(events[r][0].size, r, dtype=np.int64) for r in rows]),
            np.concatenate([first.ev_step[old]] + [events[r][0] for r in rows]),
            np.concatenate([first.ev_angles[old]] + [events[r][1] for r in rows]),
            first.seconds, first.retries)
    return Rerun(merged, solved, len(groups), n_solved, made, blocked,
                 time.perf_counter() - clock)


class _Ahead:
    """``fn(*args, stop=event, idle=event)`` started at once in a thread of its own;
    :meth:`result` sets ``idle`` (the caller now only waits) and waits for it,
    :meth:`cancel` asks it to stop after the attempt it is in."""

    def __init__(self, fn, *args):
        self._stop = threading.Event()
        self._idle = threading.Event()
        self._pool = ThreadPoolExecutor(1, thread_name_prefix="rerun-ahead")
        self._future = self._pool.submit(fn, *args, stop=self._stop, idle=self._idle)

    def result(self):
        self._idle.set()
        try:
            return self._future.result()
        finally:
            self._pool.shutdown(wait=False)

    def cancel(self) -> None:
        self._stop.set()
        self._pool.shutdown(wait=False)


def attempt_ladder(own, allowed, movable, pairs, paths, override, run, goal, fold, max_steps, seed,
            attempts, stop: threading.Event | None = None, idle: threading.Event | None = None):
    """The attempts on one group (robots ``own`` (n,) bool; patches within ``allowed``,
    or whole-array runs when it is None), until ``stop`` is set if given. Returns (best
    (robots, interior mask, StepRun, steps until its interior arrived) or None, attempts
    made, attempts blocked by the ring, the incomplete attempt that left fewest robots
    stuck (fewer than the group) or None).

    Whole-array attempts run two at a time once ``idle`` is set (always without it): while
    attempt k runs, attempt k + 1 starts as if k left no new robot stuck (its region is
    then the same; so in ~70 % of the attempts), and is run again when k did; the same
    attempts and results as one at a time. ``idle`` says the caller's thread only waits
    (its patches are done): before that the patches use the other core."""
    seen = own.copy()                # robots stuck in the first run or any attempt
    everyone = np.arange(own.size)
    fewest = int(own.sum())
    stale = made = blocked = 0
    margin = MARGIN_HOPS
    best = closest = None
    first_complete = -1

    def call(k: int):
        """(robots, interior mask, region, the run's arguments) of attempt k."""
        hops, g, p = LADDER[k % len(LADDER)]
        if allowed is None:          # the whole array
            region = grow_region(pairs, seen, hops) & movable
            robots, inner = everyone, np.ones(own.size, dtype=bool)
        else:
            region = grow_region(pairs, seen, hops) & movable & allowed
            interior = grow_region(pairs, region, margin) & allowed
            robots = np.flatnonzero(grow_region(pairs, interior, 1))
            inner = interior[robots]
        return robots, inner, region, (
            robots, ring_script(paths, robots, ~inner, override), movable[robots] & inner,
            np.where(region[robots], g, 1.0), np.where(region[robots], p, 0.0),
            region[robots].copy(), int(seed) + 7 * k + 1, max_steps)

    pool = ThreadPoolExecutor(2, thread_name_prefix="rerun-attempt") if allowed is None else None
    ahead: dict = {}                 # k -> (region, future) started before attempt k - 1 ended
    try:
        for k in range(attempts):
            if stop is not None and stop.is_set():
                break
            robots, inner, region, args = call(k)
            if pool is None:
                attempt = run(*args)
            else:
                started = ahead.pop(k, None)
                same = started is not None and np.array_equal(started[0], region)
                running = started[1] if same else pool.submit(run, *args)
                if k + 1 < attempts and (idle is None or idle.is_set()):
                    _, _, next_region, next_args = call(k + 1)
                    ahead[k + 1] = (next_region, pool.submit(run, *next_args))
                attempt = running.result()
            made += 1
            if attempt.replay_blocked:
                blocked += 1
                margin = min(margin + 1, MAX_MARGIN_HOPS)   # more room before the ring
                left = None
            else:
                at_goal = np.all(np.abs(attempt.final - goal[robots]) < ANGLE_EPS, axis=1)
                left = movable[robots] & inner & ~at_goal
            if left is not None and not left.any():
                # its length: the interior's last arrival (the ring may replay on after it)
                arrived = arrival_steps(attempt, ~inner)
                if best is None or arrived < best[3]:
                    best = (robots, inner, attempt, arrived)
                if first_complete < 0:
                    first_complete = k
                if arrived <= fold:
                    break            # complete, and the fold is no longer than the plan's
            elif left is not None and int(left.sum()) < fewest:
                fewest = int(left.sum())
                closest = attempt
                stale = 0
            else:
                stale += 1
            if left is not None:
                seen[robots[left]] = True
            if 0 <= first_complete <= k - EXTRA_ATTEMPTS:
                break
            if first_complete < 0 and stale >= PATIENCE:
                break
    finally:
        if pool is not None:
            for _, future in ahead.values():
                future.cancel()      # one already running ends on its own
            pool.shutdown(wait=False)
    return best, made, blocked, closest
