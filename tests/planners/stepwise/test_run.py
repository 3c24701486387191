"""The stepwise kernel on an array (planners/stepwise/run.py): breakpoints that rebuild
the paths, buffers that grow without changing the result."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.planners.plan import build_paths
from rfp_twin.planners.deadlocks.groups import grow_region
from rfp_twin.planners.stepwise import ANGLE_EPS, max_displacement
from rfp_twin.planners.stepwise.run import run_array, sub_csr
from rfp_twin.planners.plan.targets import random_targets
from tests.planners.conftest import make_geom


@pytest.fixture(scope="module")
def problem():
    geom = make_geom(37, 2.0)
    spec = geom.spec
    step = 0.5
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()), step)
    targets = random_targets(geom, np.random.default_rng(4), margin_mm=md)
    fold = np.tile(np.asarray(spec.fold_deg, float), (geom.n_robots, 1))
    return geom, targets, fold, dict(step_deg=step, max_steps=2000, md=md)


@pytest.mark.parametrize("greed,phobia", [(1.0, 0.0), (0.9, 0.3)])
def test_small_buffers_grow_and_give_the_same_run(problem, greed, phobia):
    geom, targets, fold, kw = problem
    movable = np.ones(geom.n_robots, bool)
    big = run_array(geom, targets, fold, movable, greed=greed, phobia=phobia, seed=5, **kw)
    small = run_array(geom, targets, fold, movable, greed=greed, phobia=phobia, seed=5, cap=1, **kw)
    assert big.ev_robot.size > 1
    assert small.n_steps == big.n_steps
    # every kernel call counts in the run's time: the small buffers needed more calls
    assert big.retries == 0 and small.retries >= 1
    assert small.seconds > 0.0
    for name in ("final", "ev_robot", "ev_step", "ev_angles"):
        np.testing.assert_array_equal(getattr(small, name), getattr(big, name))


def test_breakpoints_rebuild_paths_that_move_one_step_at_a_time(problem):
    geom, targets, fold, kw = problem
    movable = np.ones(geom.n_robots, bool)
    run = run_array(geom, targets, fold, movable, greed=1.0, phobia=0.0, seed=0, **kw)
    np.testing.assert_allclose(run.final, fold, atol=ANGLE_EPS)       # this one converges
    for i in range(geom.n_robots):                                    # each robot's in step order
        assert np.all(np.diff(run.ev_step[run.ev_robot == i]) >= 0)
    ptr, steps, angles = build_paths(geom.n_robots, run.ev_robot, run.ev_step, run.ev_angles,
                                     targets, run.final, run.n_steps)
    for i in range(geom.n_robots):
        st, an = steps[ptr[i]:ptr[i + 1]], angles[ptr[i]:ptr[i + 1]]
        np.testing.assert_allclose(an[0], targets[i])
        np.testing.assert_allclose(an[-1], fold[i], atol=ANGLE_EPS)
        rate = np.abs(np.diff(an, axis=0)) / np.maximum(np.diff(st), 1.0)[:, None]
        assert rate.max() <= kw["step_deg"] + 1e-9


def test_robots_that_cannot_move_stay(problem):
    geom, targets, fold, kw = problem
    movable = np.ones(geom.n_robots, bool)
    movable[::3] = False
    run = run_array(geom, targets, fold, movable, greed=0.9, phobia=0.3, seed=1, **kw)
    np.testing.assert_array_equal(run.final[~movable], targets[~movable])
    assert not np.isin(run.ev_robot, np.flatnonzero(~movable)).any()    # no breakpoints


@pytest.mark.parametrize("greed,phobia", [(1.0, 0.0), (0.9, 0.3)])
def test_paths_are_the_kernel_states_at_every_step(problem, greed, phobia):
    """Linear interpolation of the breakpoints is the kernel's own state at each step: a
    run stopped after k steps (the kernel is deterministic for a seed) stands where the
    full run's paths put it at step k, also for a robot that reached its destination and
    waits there (its arrival is a breakpoint, not spread over the wait)."""
    geom, targets, fold, kw = problem
    movable = np.ones(geom.n_robots, bool)
    full = run_array(geom, targets, fold, movable, greed=greed, phobia=phobia, seed=2, **kw)
    ptr, steps, angles = build_paths(geom.n_robots, full.ev_robot, full.ev_step, full.ev_angles,
                                     targets, full.final, full.n_steps)
    arrived = 0
    for k in np.linspace(1, full.n_steps - 1, 9).astype(int):
        part = run_array(geom, targets, fold, movable, greed=greed, phobia=phobia, seed=2,
                         **{**kw, "max_steps": int(k)})
        at_k = np.array([[np.interp(k, steps[ptr[i]:ptr[i + 1]], angles[ptr[i]:ptr[i + 1], ax])
                          for ax in (0, 1)] for i in range(geom.n_robots)])
        np.testing.assert_allclose(at_k, part.final, atol=1e-9)
        arrived += int(np.sum(np.all(np.abs(part.final - fold) < ANGLE_EPS, axis=1)))
    assert arrived > 0          # some robots wait at their destination before the end


def _csr_rows(paths, robots, keep):
    """CSR ``paths`` of ``robots`` where ``keep``, empty rows elsewhere (a replay script)."""
    ptr, steps, angles = paths
    counts = np.where(keep, ptr[robots + 1] - ptr[robots], 0)
    out = np.concatenate([[0], np.cumsum(counts)])
    take = np.concatenate([np.arange(ptr[r], ptr[r + 1]) for r in robots[keep]])
    return out, steps[take], angles[take]


def _at_steps(paths, i, t):
    ptr, steps, angles = paths
    st, an = steps[ptr[i]:ptr[i + 1]], angles[ptr[i]:ptr[i + 1]]
    return np.column_stack([np.interp(t, st, an[:, 0]), np.interp(t, st, an[:, 1])])


def test_a_patch_inside_a_replaying_ring_repeats_the_whole_run():
    """Greedy is deterministic: a run of the centre robot and its neighbours, with the
    robots around them replaying the whole run's paths, moves its interior exactly as the
    whole run did, in a fraction of the robots."""
    geom = make_geom(91, 2.5)
    spec = geom.spec
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()), 0.5)
    targets = random_targets(geom, np.random.default_rng(8), margin_mm=md)
    fold = np.tile(np.asarray(spec.fold_deg, float), (geom.n_robots, 1))
    kw = dict(step_deg=0.5, max_steps=2000, md=md, greed=1.0, phobia=0.0, seed=1)
    movable = np.ones(geom.n_robots, bool)
    whole = run_array(geom, targets, fold, movable, **kw)
    same = run_array(geom, targets, fold, movable, robots=np.arange(geom.n_robots), **kw)
    np.testing.assert_array_equal(same.ev_angles, whole.ev_angles)
    paths = build_paths(geom.n_robots, whole.ev_robot, whole.ev_step, whole.ev_angles, targets,
                        whole.final, whole.n_steps)
    centre = np.zeros(geom.n_robots, bool)
    centre[np.argmin(np.hypot(*geom.base_xy.T))] = True
    inner_all = grow_region(geom.pairs, centre, 1)             # the centre and its neighbours
    robots = np.flatnonzero(grow_region(geom.pairs, inner_all, 1))
    inner = inner_all[robots]
    assert 7 <= inner.sum() < (~inner).sum() < geom.n_robots // 2
    local = run_array(geom, targets[robots], fold[robots], inner.copy(), robots=robots,
                      script=_csr_rows(paths, robots, ~inner), **kw)
    assert not local.replay_blocked and local.n_steps <= whole.n_steps
    mine = build_paths(robots.size, local.ev_robot, local.ev_step, local.ev_angles,
                       targets[robots], local.final, local.n_steps)
    t = np.arange(whole.n_steps + 1)
    moved = 0
    for k in np.flatnonzero(inner):
        np.testing.assert_allclose(_at_steps(mine, k, t), _at_steps(paths, robots[k], t), atol=1e-9)
        moved += np.ptp(_at_steps(mine, k, t)) > 1.0
    assert moved >= 5
    assert not np.any(local.ev_robot[~inner[local.ev_robot]] >= 0)   # the ring records nothing


def test_a_replayed_move_into_a_robot_that_stands_there_stops_the_run():
    """Robot 1 replays a half turn of its stretched arm through the direction of robot 0,
    which stands with its arm stretched towards robot 1: the run stops at the step whose
    replayed move fails the step rule. The half turn on the far side goes through."""
    geom = make_geom(7, 2.0)
    spec = geom.spec
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()), 1.0)
    robots = np.array([0, 1])
    towards_1 = float(np.degrees(np.arctan2(*(geom.base_xy[1] - geom.base_xy[0])[::-1]))) % 360.0

    def run(stand, through):
        """Robot 0 at ``stand``; robot 1's alpha turns 180 deg through ``through``."""
        a0 = (through - 90.0) % 360.0
        script = (np.array([0, 0, 2]), np.array([0.0, 180.0]), np.array([[a0, 0.0], [a0 + 180.0, 0.0]]))
        start = np.array([stand, [a0, 0.0]])
        return run_array(geom, start, start, np.array([False, False]), step_deg=1.0,
                         max_steps=400, md=md, greed=1.0, phobia=0.0, seed=0, robots=robots,
                         script=script)

    hit = run([towards_1, 0.0], (towards_1 + 180.0) % 360.0)
    assert hit.replay_blocked and 45 < hit.n_steps < 135
    free = run(list(spec.fold_deg), towards_1)
    assert not free.replay_blocked and free.n_steps == 180


def test_replays_run_to_their_end_past_the_step_limit():
    """The step limit bounds the planning, not the replays: a swing recorded over 180
    steps is replayed (and checked) to its end with max_steps 50, and one that runs into
    a standing arm after step 50 is still caught."""
    geom = make_geom(7, 2.0)
    spec = geom.spec
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()), 1.0)
    towards_1 = float(np.degrees(np.arctan2(*(geom.base_xy[1] - geom.base_xy[0])[::-1]))) % 360.0
    a0 = (towards_1 + 10.0) % 360.0            # pointing away; robot 0 is met after step 100
    script = (np.array([0, 0, 2]), np.array([0.0, 180.0]), np.array([[a0, 0.0], [a0 + 180.0, 0.0]]))
    start = np.array([[towards_1, 0.0], [a0, 0.0]])
    run = run_array(geom, start, start, np.array([False, False]), step_deg=1.0, max_steps=50,
                    md=md, greed=1.0, phobia=0.0, seed=0, robots=np.array([0, 1]), script=script)
    assert run.replay_blocked and 100 < run.n_steps < 180


def test_sub_csr_keeps_the_rows_asked_for_and_renumbers_robot_lists():
    # robots 0..3: 0 -> {1, 2}, 1 -> {0, 3}, 2 -> {0}, 3 -> {1}
    ptr = np.array([0, 2, 4, 5, 6])
    idx = np.array([1, 2, 0, 3, 0, 1])
    p, i, take = sub_csr(ptr, idx, np.array([0, 1, 3]))
    assert p.tolist() == [0, 1, 3, 4] and i.tolist() == [1, 0, 2, 1]
    assert idx[take].tolist() == [1, 0, 3, 1]            # the entries kept, old numbering
    # robot -> obstacle lists: every entry of the rows, unchanged
    p, i, take = sub_csr(ptr, idx, np.array([1, 2]), renumber=False)
    assert p.tolist() == [0, 2, 3] and i.tolist() == [0, 3, 0] and take.tolist() == [2, 3, 4]


def test_a_beta_first_robot_alone_turns_alpha_only_once_beta_is_home():
    """Nothing blocks a robot alone: marked ``beta_first`` it moves beta only until beta
    is at its destination, then alpha; unmarked, both from the first step."""
    geom = make_geom(1, 2.0)
    start, dest = np.array([[300.0, 40.0]]), np.array([[10.0, 170.0]])
    kw = dict(step_deg=0.5, max_steps=2000, md=0.1, greed=1.0, phobia=0.0, seed=0)
    for marked in (True, False):
        run = run_array(geom, start, dest, np.ones(1, bool), beta_first=np.array([marked]), **kw)
        ptr, steps, angles = build_paths(1, run.ev_robot, run.ev_step, run.ev_angles, start,
                                         run.final, run.n_steps)
        k = np.arange(run.n_steps + 1)
        a, b = np.interp(k, steps, angles[:, 0]), np.interp(k, steps, angles[:, 1])
        np.testing.assert_allclose([a[-1], b[-1]], dest[0], atol=ANGLE_EPS)
        beta_home = int(np.argmax(np.abs(b - dest[0, 1]) < ANGLE_EPS))
        alpha_starts = int(np.flatnonzero(np.abs(np.diff(a)) > ANGLE_EPS)[0])
        assert beta_home == 260                                  # 130 deg at 0.5 deg a step
        assert alpha_starts == (beta_home if marked else 0)
        assert run.n_steps == (260 + 580 if marked else 580)     # 290 deg of alpha


def test_beta_first_robots_on_a_grid_arrive_and_keep_the_step_rule(problem):
    """Half of the 37-robot grid marked ``beta_first``: a different run, every robot at
    its destination, and every neighbour pair clear of the buffers at every step."""
    geom, targets, fold, kw = problem
    movable = np.ones(geom.n_robots, bool)
    marked = np.zeros(geom.n_robots, bool)
    marked[::2] = True
    run = run_array(geom, targets, fold, movable, greed=1.0, phobia=0.0, seed=0,
                    beta_first=marked, **kw)
    plain = run_array(geom, targets, fold, movable, greed=1.0, phobia=0.0, seed=0, **kw)
    np.testing.assert_allclose(run.final, fold, atol=ANGLE_EPS)
    assert not np.array_equal(run.ev_angles, plain.ev_angles)
    ptr, steps, angles = build_paths(geom.n_robots, run.ev_robot, run.ev_step, run.ev_angles,
                                     targets, run.final, run.n_steps)
    kk = np.arange(run.n_steps + 1)
    at = np.stack([np.column_stack([np.interp(kk, steps[ptr[i]:ptr[i + 1]],
                                              angles[ptr[i]:ptr[i + 1], c]) for c in range(2)])
                   for i in range(geom.n_robots)], axis=1)
    assert min(geom.pair_clearance(at[s]).min() for s in range(kk.size)) > 0.0


def test_beta_first_robots_are_the_ones_whose_travel_fits_the_longest_alpha():
    from rfp_twin.planners.plan.runs import beta_first_robots

    start = np.array([[350.0, 30.0], [100.0, 40.0], [20.0, 170.0], [300.0, 100.0]])
    dest = np.tile([10.0, 170.0], (4, 1))
    movable = np.array([True, True, True, False])
    # travel (deg): 480, 220, 10, (offline); longest alpha travel 340 of the movable
    np.testing.assert_array_equal(beta_first_robots(start, dest, movable, 0.85),
                                  [False, True, True, False])
    assert beta_first_robots(start, dest, movable, 0.0) is None
