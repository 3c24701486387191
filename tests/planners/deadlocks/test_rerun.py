"""Deadlock resolution by greedy-first Markov re-runs (planners/deadlocks/rerun.py) and the kernel's
mixed runs it relies on; plans are declared clear only by the independent 2D checker."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import SpecError
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.plan import REACHED, build_paths
import rfp_twin.planners.deadlocks.rerun as rerun_module
from rfp_twin.planners.deadlocks.groups import arrival_steps, clusters, grow_region
from rfp_twin.planners.deadlocks.rerun import (EXTRA_ATTEMPTS, LADDER, MARGIN_HOPS, PATIENCE,
                                               STEP_CAP, WHOLE_ATTEMPTS, rerun_deadlocks)
from rfp_twin.planners.plan import PlannerSettings
from rfp_twin.planners.stepwise import StepRun, array_max_displacement, run_array
from rfp_twin.validation.checker2d import check_trajectory
from tests.planners.conftest import make_geom, plan_random


@pytest.fixture(scope="module")
def deadlock_547():
    """547 grid, 2.5 mm, 0.25 deg, seed 5: the greedy run leaves two groups (6 robots)."""
    geom = ArrayGeometry(load_spec("sdss-v"), Layout.sdss_v_grid(), 2.5)
    targets, first = plan_random(geom, 5, resolve=False, step_deg=0.25)
    _, plan = plan_random(geom, 5, resolver="search", step_deg=0.25)
    return geom, targets, first, plan


def test_the_rerun_keeps_every_target_without_the_search(deadlock_547):
    geom, targets, first, plan = deadlock_547
    m = plan.metrics
    assert first.metrics["n_deadlocked"] >= 2 and m["convergence"] < 1.0
    assert m["n_rerun_groups"] >= 2 and m["n_rerun_robots"] == first.metrics["n_deadlocked"]
    assert 1 <= m["rerun_attempts"] <= 2 * len(LADDER) and m["rerun_s"] > 0.0
    assert m["n_search_groups"] == 0 and m["search_s"] == 0.0 and m["n_replaced"] == 0
    assert plan.complete and np.all(plan.status == REACHED)
    np.testing.assert_allclose(plan.end(), targets, atol=1e-9)
    np.testing.assert_allclose(plan.start(), np.tile(geom.spec.fold_deg, (geom.n_robots, 1)))
    # the re-run's steps are bounded by the cap, measured from the deadlocked run's length
    assert plan.n_steps <= np.ceil(STEP_CAP * first.n_steps)
    assert m["tau_sr_s"] >= m["tau_pg_s"] + m["rerun_s"] - 1e-9
    report = check_trajectory(Trajectory.from_plan(plan), geom.spec, geom.layout, geom.buffer_mm)
    assert report.ok, report.table()


def test_grow_region_follows_the_neighbour_pairs():
    pairs = np.array([[0, 1], [1, 2], [2, 3], [3, 4]])     # a chain 0-1-2-3-4
    seed = np.zeros(5, bool)
    seed[2] = True
    assert grow_region(pairs, seed, 0).tolist() == seed.tolist()
    assert np.flatnonzero(grow_region(pairs, seed, 1)).tolist() == [1, 2, 3]
    assert grow_region(pairs, seed, 9).all()
    assert not seed[[0, 1, 3, 4]].any()        # the input is not modified


N_CHAIN = 24
PAIRS = np.array([[i, i + 1] for i in range(N_CHAIN - 1)])     # a chain of robots
GOAL = np.zeros((N_CHAIN, 2))
MOVABLE = np.ones(N_CHAIN, bool)


def _fake(n_steps: int, stuck: list[int], robots=None) -> StepRun:
    """A run of ``robots`` (default: the whole chain) whose goal is (0, 0): the ``stuck``
    ones (chain indices) end at (1, 1); one breakpoint per robot, at its last step."""
    robots = np.arange(N_CHAIN) if robots is None else robots
    final = np.zeros((robots.size, 2))
    final[np.isin(robots, stuck)] = 1.0
    return StepRun(final, n_steps, np.arange(robots.size),
                   np.full(robots.size, n_steps - 1, np.int64), np.full((robots.size, 2), 5.0),
                   0.0)


def _paths(run: StepRun):
    return build_paths(N_CHAIN, run.ev_robot, run.ev_step, run.ev_angles,
                       np.full((N_CHAIN, 2), 9.0), run.final, run.n_steps)


def _ladder_of(results: list, whole: list | None = None):
    """A local run function that hands out ``(n_steps, stuck chain indices)`` in turn (or
    "blocked") as runs of the patch it is given, and records its calls. With ``whole``,
    whole-array runs take theirs from that list instead, entry k for attempt k (known
    by its seed: they run in threads of their own, two attempts at a time, beside the
    patches), and are recorded apart, in ``calls.whole`` by attempt."""
    calls = _Calls()
    lock = threading.Lock()

    def run(robots, script, movable, greed, phobia, greedy_first, seed, max_steps):
        call = dict(robots=robots.copy(), script=script, movable=movable.copy(),
                    greed=greed.copy(), phobia=phobia.copy(), region=greedy_first.copy(),
                    seed=seed, max_steps=max_steps)
        if whole is not None and robots.size == N_CHAIN:
            k = (seed - WHOLE_SEED - 1) // 7
            with lock:
                calls.whole[k] = call
            got = whole[min(k, len(whole) - 1)]     # an attempt started ahead, unused
        else:
            calls.append(call)
            got = results[len(calls) - 1]
        if got == "blocked":
            out = _fake(10, [], robots)
            out.replay_blocked = True
            return out
        return _fake(got[0], got[1], robots)
    return run, calls


class _Calls(list):
    """The patch runs' calls; ``whole``: the whole-array runs' calls by attempt."""

    def __init__(self):
        super().__init__()
        self.whole: dict = {}


#: The whole-array ladder's base seed for ``_rerun(..., seed=0)``: 0 + 7919 (rerun.py).
WHOLE_SEED = 7919


def _rerun(first, run, whole: bool = False, **kw):
    """rerun_deadlocks on the chain; patches only unless ``whole`` (the chain is small
    enough for the whole-array ladder after them)."""
    limit = rerun_module.WHOLE_ARRAY_ROBOTS
    rerun_module.WHOLE_ARRAY_ROBOTS = N_CHAIN if whole else 0
    try:
        return rerun_deadlocks(first, GOAL, MOVABLE, PAIRS, _paths(first), run, **kw)
    finally:
        rerun_module.WHOLE_ARRAY_ROBOTS = limit


def test_groups_their_patches_leave_get_whole_array_runs_on_small_arrays():
    first = _fake(100, [12, 13])
    # patches: no progress until the ladder stops; whole-array runs: the second completes
    patches = [(125, [12, 13])] * PATIENCE
    whole = [(125, [12, 13]), (125, [12]), (99, [])]
    run, calls = _ladder_of(patches, whole=whole)
    rr = _rerun(first, run, whole=True, seed=0, attempts=8)
    assert rr.complete and rr.attempts == len(patches) + len(whole) and not rr.partial
    # the whole-array attempts used are 0, 1, 2 (the one after may have started ahead)
    assert len(calls) == len(patches) and set(range(len(whole))) <= set(calls.whole)
    assert all(c["robots"].size < N_CHAIN for c in calls)
    last = calls.whole[len(whole) - 1]
    assert last["robots"].tolist() == list(range(N_CHAIN)) and last["movable"].all()
    assert np.diff(last["script"][0]).sum() == 0           # nobody replays
    assert rr.solved.tolist() == np.isin(np.arange(N_CHAIN), [12, 13]).tolist()
    # none completes: the whole-array attempt with fewer stuck robots goes on, partial
    run, _ = _ladder_of(patches, whole=[(125, [12, 13])] + [(125, [12])] * 8)
    rr = _rerun(first, run, whole=True, seed=0, attempts=8)
    assert rr.partial and not rr.complete and rr.solved.tolist() == (np.arange(N_CHAIN) == 13).tolist()
    assert rr.run.final[12].tolist() == [1.0, 1.0]


def test_the_whole_array_ladder_makes_at_most_its_own_number_of_attempts():
    first = _fake(100, [12, 13])
    # the whole-array attempts leave both robots or one of them stuck in turn: none
    # completes and no PATIENCE stale ones come in a row before the fifth (the sixth
    # would end it), so the cap stops it; the patches stop at their own patience
    patches = [(125, [12, 13])] * PATIENCE
    run, calls = _ladder_of(patches, whole=[(125, [12, 13]), (125, [12])] * 8)
    rr = _rerun(first, run, whole=True, seed=0, attempts=8)
    assert rr.partial and rr.attempts == PATIENCE + WHOLE_ATTEMPTS
    assert sorted(calls.whole) == list(range(WHOLE_ATTEMPTS))    # none started beyond


def test_the_whole_array_ladder_runs_beside_the_patches_and_stops_when_they_suffice():
    first = _fake(100, [12, 13])
    gate = threading.Event()
    started = threading.Event()
    whole_calls, patch_calls = [], []

    def run(robots, script, movable, greed, phobia, greedy_first, seed, max_steps):
        if robots.size == N_CHAIN:          # the whole-array ladder, in its own thread
            whole_calls.append(threading.current_thread().name)
            started.set()
            gate.wait(10.0)
            return _fake(125, [12], robots)
        patch_calls.append(threading.current_thread().name)
        # the patch ends only once the ladder runs beside it (a fast patch could
        # otherwise finish before the ladder's thread made its first call)
        assert started.wait(10.0)
        return _fake(90, [], robots)        # the first patch attempt completes the group

    rr = _rerun(first, run, whole=True, seed=0, attempts=8)
    assert rr.complete and not rr.partial and rr.attempts == 1 and rr.run.n_steps <= 100
    assert patch_calls == [threading.current_thread().name]
    gate.set()
    for t in threading.enumerate():
        if t.name.startswith(("rerun-ahead", "rerun-attempt")):
            t.join(10.0)
    # its first attempt was running when the patches were done; it made no other
    # (unstopped, it makes 5: PATIENCE), and none beside it: the caller never waited
    assert len(whole_calls) == 1
    assert all(n.startswith("rerun-attempt") for n in whole_calls)


def test_a_patch_is_the_region_its_margin_and_a_replaying_ring():
    first = _fake(100, [12])
    run, calls = _ladder_of([(110, []), (100, []), (90, [])])
    rr = _rerun(first, run, seed=7)
    assert rr.attempts == 2 and len(calls) == 2 and rr.complete and rr.n_groups == 1
    hops, g, p = LADDER[0]
    c = calls[0]
    region = list(range(12 - hops, 13 + hops))
    reach = hops + MARGIN_HOPS
    assert c["robots"].tolist() == list(range(12 - reach - 1, 13 + reach + 1))
    inner = np.isin(c["robots"], range(12 - reach, 13 + reach))
    assert c["robots"][c["region"]].tolist() == region
    assert np.all(c["greed"][c["region"]] == g) and np.all(c["greed"][~c["region"]] == 1.0)
    assert np.all(c["phobia"][c["region"]] == p) and np.all(c["phobia"][~c["region"]] == 0.0)
    # only the interior plans; the two ring robots replay the first run's paths
    assert c["movable"].tolist() == inner.tolist()
    ptr, steps, angles = c["script"]
    rows = np.diff(ptr)
    assert np.all(rows[inner] == 0) and np.all(rows[~inner] == 3)      # start, step 1, end
    np.testing.assert_array_equal(steps[:3], [0.0, 99.0, 100.0])
    assert c["max_steps"] == int(np.ceil(STEP_CAP * 100))
    assert len({c["seed"] for c in calls}) == 2                   # a new seed per attempt
    # the accepted patch's interior is swapped in: its breakpoints, the rest the first run's
    assert rr.solved.tolist() == (np.arange(N_CHAIN) == 12).tolist()
    assert np.array_equal(np.sort(rr.run.ev_robot), np.arange(N_CHAIN))
    assert rr.run.n_steps == 100 and np.all(rr.run.final == 0.0)


def test_without_an_early_accept_the_shortest_complete_attempt_wins():
    first = _fake(100, [12])
    run, _ = _ladder_of([(125, [11]), (120, []), (125, [11]), (110, []), (105, [])])
    rr = _rerun(first, run, seed=0, attempts=8)
    # EXTRA_ATTEMPTS more after the first complete one (the second attempt), then stop
    assert rr.attempts == 2 + EXTRA_ATTEMPTS == 4
    assert rr.complete and rr.run.n_steps == 110


def test_when_nothing_completes_the_first_run_stands_and_stuck_robots_join_the_region():
    first = _fake(100, [12, 13])
    run, calls = _ladder_of([(125, [9, 12, 13]), (125, [13]), (125, [11, 13])])
    rr = _rerun(first, run, seed=0, attempts=3)
    assert not rr.complete and rr.n_solved == 0 and rr.attempts == 3
    assert rr.run is first and not rr.solved.any()
    # robot 9, stuck only in the first attempt, is in the region of the next ones
    assert 9 not in calls[0]["robots"][calls[0]["region"]]
    assert 9 in calls[1]["robots"][calls[1]["region"]]


def test_attempts_that_make_no_progress_or_are_blocked_stop_the_ladder():
    first = _fake(100, [12, 13])
    runs = [(125, [12]), "blocked", (125, [12, 13]), (125, [12]), (125, [12]), (125, [])]
    run, calls = _ladder_of(runs)
    rr = _rerun(first, run, seed=0, attempts=8)
    assert rr.attempts == 1 + PATIENCE == len(calls) and rr.n_solved == 0
    assert rr.blocked == 1 and rr.run is first
    # a blocked attempt widens the margin before the ring by one hop
    hops = LADDER[2][0]
    lo, hi = 12 - hops - MARGIN_HOPS - 1, 13 + hops + MARGIN_HOPS + 1
    assert calls[2]["robots"].tolist() == list(range(lo - 1, hi + 2))


def test_clusters_far_apart_get_their_own_ladders_and_patches():
    first = _fake(100, [2, 21])
    # the cluster of robot 2 is solved at once; the one of 21 never
    run, calls = _ladder_of([(98, []), (125, [21]), (125, [21]), (125, [21])])
    rr = _rerun(first, run, seed=0, attempts=3)
    assert rr.n_groups == 2 and rr.n_solved == 1 and not rr.complete
    assert rr.solved.tolist() == (np.arange(N_CHAIN) == 2).tolist()
    assert 2 in calls[0]["robots"] and 21 not in calls[0]["robots"]
    assert all(21 in c["robots"] and 2 not in c["robots"] for c in calls[1:])
    # the unsolved cluster keeps its first-run motion, so the run keeps its length
    assert rr.run.n_steps == first.n_steps and rr.run.final[21].tolist() == [1.0, 1.0]
    assert rr.run.final[2].tolist() == [0.0, 0.0]
    assert clusters(PAIRS, np.isin(np.arange(N_CHAIN), [2, 21]), 4)[0].tolist() == [2]
    assert len(clusters(PAIRS, np.isin(np.arange(N_CHAIN), [2, 21]), 9)) == 1


def test_reruns_must_not_be_negative():
    with pytest.raises(SpecError, match="'reruns'"):
        PlannerSettings(reruns=-1)


def test_a_free_greedy_first_robot_moves_as_a_greedy_one():
    """Nothing ever blocks a lone robot, so a greedy-first Markov robot with any greed and
    phobia takes the obvious move at every step: the greedy path, step for step."""
    geom = make_geom(1, 2.0)
    start = np.array([[30.0, 40.0]])
    dest = np.array([[250.0, 170.0]])
    kw = dict(step_deg=0.5, max_steps=2000, md=array_max_displacement(geom, 0.5), seed=3)
    greedy = run_array(geom, start, dest, np.ones(1, bool), greed=1.0, phobia=0.0, **kw)
    first = run_array(geom, start, dest, np.ones(1, bool), greed=0.2, phobia=0.9,
                      greedy_first=np.ones(1, bool), **kw)
    markov = run_array(geom, start, dest, np.ones(1, bool), greed=0.2, phobia=0.9, **kw)
    assert first.n_steps == greedy.n_steps
    np.testing.assert_array_equal(first.final, greedy.final)
    np.testing.assert_allclose(_states(first, start), _states(greedy, start), atol=1e-12)
    assert markov.n_steps > greedy.n_steps       # a plain Markov robot wanders


def _states(run: StepRun, start: np.ndarray) -> np.ndarray:
    """(n_steps + 1, 2) deg: robot 0's angles at every step, from the run's breakpoints."""
    ptr, steps, angles = build_paths(1, run.ev_robot, run.ev_step, run.ev_angles, start,
                                     run.final, run.n_steps)
    t = np.arange(run.n_steps + 1)
    st, an = steps[ptr[0]:ptr[1]], angles[ptr[0]:ptr[1]]
    return np.column_stack([np.interp(t, st, an[:, 0]), np.interp(t, st, an[:, 1])])


def test_robots_outside_a_markov_region_keep_the_greedy_rules():
    """A mixed run with every robot greedy (greed 1, phobia 0 as arrays) is the greedy run."""
    geom = make_geom(37, 2.0)
    targets, _ = plan_random(geom, 2, resolve=False, step_deg=0.5)
    fold = np.tile(np.asarray(geom.spec.fold_deg, float), (geom.n_robots, 1))
    kw = dict(step_deg=0.5, max_steps=2000, md=array_max_displacement(geom, 0.5), seed=1)
    mov = np.ones(geom.n_robots, bool)
    a = run_array(geom, targets, fold, mov, greed=1.0, phobia=0.0, **kw)
    b = run_array(geom, targets, fold, mov, greed=np.ones(geom.n_robots),
                  phobia=np.zeros(geom.n_robots), greedy_first=mov.copy(), **kw)
    assert a.n_steps == b.n_steps
    np.testing.assert_array_equal(a.ev_robot, b.ev_robot)
    np.testing.assert_array_equal(a.ev_angles, b.ev_angles)


def test_the_cap_counts_from_the_last_arrival_not_from_the_stuck_robots_moves():
    # robots 0, 1 arrive at steps 40 and 60; robot 2 (stuck) moves until step 90
    run = StepRun(np.zeros((3, 2)), 95, np.array([0, 1, 2, 2]), np.array([39, 59, 10, 89]),
                  np.zeros((4, 2)), 0.0)
    assert arrival_steps(run, np.array([False, False, True])) == 60
    assert arrival_steps(run, np.array([True, True, True])) == 95      # nobody arrived


def test_whole_array_attempts_overlap_only_once_the_caller_waits():
    """Before ``idle`` is set the patches use the other core: whole-array attempts run one
    at a time; after it, attempt k + 1 runs beside attempt k (same results either way)."""
    from rfp_twin.planners.deadlocks.rerun import attempt_ladder

    live = [0]
    peak = []
    lock = threading.Lock()

    def run(robots, script, movable, greed, phobia, greedy_first, seed, max_steps):
        with lock:
            live[0] += 1
            peak.append(live[0])
        threading.Event().wait(0.05)
        with lock:
            live[0] -= 1
        return _fake(50, [3], robots)                   # robot 3 stays stuck: no completion

    first = _fake(50, [3])
    own = np.zeros(N_CHAIN, bool)
    own[3] = True
    for idle_set, most in ((False, 1), (True, 2)):
        peak.clear()
        idle = threading.Event()
        if idle_set:
            idle.set()
        best, made, blocked, closest = attempt_ladder(own, None, MOVABLE, PAIRS, _paths(first), {}, run,
                                               GOAL, 50, 55, 0, len(LADDER), idle=idle)
        assert best is None and closest is None and made == PATIENCE
        assert max(peak) == most
