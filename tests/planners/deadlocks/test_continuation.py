"""Deadlock resolution by continuation (planners/deadlocks/continuation.py): the groups go on
alone with Markov moves of the real stepwise kernel, everyone else standing still."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from rfp_twin.models.kinematics import inverse
from rfp_twin.planners.deadlocks.continuation import ATTEMPTS, continue_groups
from rfp_twin.planners.stepwise import max_displacement
from rfp_twin.planners.stepwise.run import run_array
from tests.planners.conftest import make_geom

STEP = 0.5


def setup(max_steps: int = 3000):
    geom = make_geom(37, 2.0)
    spec = geom.spec
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()), STEP)
    fold = np.tile(np.asarray(spec.fold_deg, float), (geom.n_robots, 1))
    calls = []

    def run(start, dest, movable, greed, phobia, seed):
        calls.append((greed, phobia, seed, np.flatnonzero(movable).tolist()))
        return run_array(geom, start, dest, movable, step_deg=STEP, max_steps=max_steps, md=md,
                         greed=greed, phobia=phobia, seed=seed)
    return geom, fold, run, calls


def test_groups_that_arrive_get_paths_from_where_they_stood():
    geom, fold, run, calls = setup()
    c = int(np.argmin(np.hypot(*geom.base_xy.T)))
    far = int(np.argmax(np.hypot(*geom.base_xy.T)))
    final = fold.copy()
    final[c] = (200.0, 150.0)          # stretched out, clear of its folded neighbours
    final[far] = (100.0, 120.0)
    groups = [np.array([c]), np.array([far])]
    out = continue_groups(geom.n_robots, final, fold, groups, run, seed=11)
    assert out.solved == [0, 1] and out.attempts == 1
    # attempt 0 (and attempt 1, run beside it and unused) move only the groups
    assert (*ATTEMPTS[0], 11, sorted([c, far])) in calls
    assert all(moved == sorted([c, far]) for *_, moved in calls)
    assert sorted(out.paths) == sorted([c, far])
    for i in (c, far):
        steps, angles = out.paths[i]
        assert steps[0] == 0.0
        np.testing.assert_allclose(angles[0], final[i])
        np.testing.assert_allclose(angles[-1], fold[i], atol=1e-9)


def test_a_group_that_cannot_arrive_uses_every_attempt():
    """An offline neighbour reaches into the centre robot's folded place: it never gets there."""
    geom, fold, run, calls = setup(max_steps=200)
    spec = geom.spec
    c = int(np.argmin(np.hypot(*geom.base_xy.T)))
    right = int(np.argmin(np.hypot(*(geom.base_xy - geom.base_xy[c] - [22.4, 0.0]).T)))
    final = fold.copy()
    final[c] = (180.0, 0.0)            # stretched away from the right neighbour
    final[right] = inverse(geom.base_xy[[right]], geom.base_xy[[c]] + [[3.0, 0.0]],
                           spec.alpha_length_mm, spec.beta_length_mm)[0]
    dest = fold.copy()
    dest[right] = final[right]
    out = continue_groups(geom.n_robots, final, dest, [np.array([c])], run, seed=3, attempts=3)
    assert out.solved == [] and out.paths == {} and out.attempts == 3
    assert sorted(k[:3] for k in calls) == sorted((*ATTEMPTS[a], 3 + a) for a in range(3))
    assert continue_groups(geom.n_robots, final, dest, [np.array([c])], run, 3, attempts=0).attempts == 0


def _one_at_a_time(n, final, dest, groups, run, seed, attempts):
    """The continuation's rule without the second core: attempt after attempt, each on
    the groups not yet solved; returns (solved groups in order, paths' final angles)."""
    todo, solved, ends = list(range(len(groups))), [], {}
    for a in range(attempts):
        if not todo:
            break
        movable = np.zeros(n, dtype=bool)
        for g in todo:
            movable[groups[g]] = True
        r = run(final, dest, movable, *ATTEMPTS[a % len(ATTEMPTS)], seed + a)
        arrived = np.all(np.abs(r.final - dest) < 1e-6, axis=1)
        for g in list(todo):
            if arrived[groups[g]].all():
                solved.append(g)
                todo.remove(g)
                ends.update({int(i): r.final[i].copy() for i in groups[g]})
    return solved, ends


def test_two_attempts_at_once_give_the_one_at_a_time_result():
    """Groups solved by different attempts: the same groups, in the same order, with the
    same ends, as attempt after attempt. The runs are stand-ins whose robots arrive or
    not by a hash of (seed, robot, movable set), so which attempt solves what is known."""
    n = 12
    final = np.zeros((n, 2))
    dest = np.ones((n, 2))
    groups = [np.array([0, 1]), np.array([4]), np.array([6, 7, 8]), np.array([11])]

    def run(start, dest_, movable, greed, phobia, seed):
        key = hash((seed, tuple(np.flatnonzero(movable))))
        arrive = movable & (np.array([hash((key, i)) % 3 for i in range(n)]) > 0)
        return SimpleNamespace(final=np.where(arrive[:, None], dest_, start), n_steps=5,
                               ev_robot=np.zeros(0, np.int64), ev_step=np.zeros(0),
                               ev_angles=np.zeros((0, 2)))

    orders = set()
    for seed in range(40):
        out = continue_groups(n, final, dest, groups, run, seed, attempts=8)
        ref, ends = _one_at_a_time(n, final, dest, groups, run, seed, 8)
        assert out.solved == ref
        assert sorted(out.paths) == sorted(ends)
        orders.add(tuple(out.solved))
    assert len(orders) > 5        # groups solved in many different attempts and orders
