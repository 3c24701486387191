"""The sweep search's path loop in batches on two cores (planners/roadmap/sweep_batches.py):
the same outcome, paths tried, nodes, budget and blocker counts as one path at a time."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import rfp_twin.planners.roadmap.sweep_batches as batches
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
from rfp_twin.planners.roadmap.alpha_beta.settings import SearchResolveSettings
from rfp_twin.planners.roadmap.alpha_beta.world import AlphaBetaWorld
from rfp_twin.planners.roadmap import plan_arm
from rfp_twin.planners.roadmap.arm import compress_breakpoints
from tests.planners.conftest import hex7_folded


def _world(stays: bool):
    """7-robot hex: the right neighbour of the centre swings its arm over (and stays
    there if ``stays``, else goes back after 120 steps)."""
    geom, step, md, fold, c = hex7_folded()
    right = int(np.argmin(np.hypot(*(geom.base_xy - geom.base_xy[c] - [22.4, 0.0]).T)))
    times = [np.array([0.0])] * geom.n_robots
    confs = [fold[i][None, :] for i in range(geom.n_robots)]
    times[right] = np.array([0.0, 60.0, 120.0])
    confs[right] = np.array([fold[right], [140.0, 30.0], [140.0, 30.0] if stays else fold[right]])
    world = AlphaBetaWorld(geom, PathSet(times, confs), np.ones(geom.n_robots, bool), md, step)
    return world, fold, c, step


def _both(arm, settings):
    """(batched, one at a time): (trajectory or None, paths tried, nodes, budget ended,
    blocker counts) of each, from the same arm."""
    out = []
    for a in (replace(arm, edge_memo={}), replace(arm, sweep_paths=None, edge_memo={})):
        a.sweep.hits[:] = 0
        tr, st = plan_arm(a, settings, np.random.default_rng(3))
        out.append((None if tr is None else (tr.times.tolist(), tr.configs.tolist()),
                    st.paths_tried, st.nodes, st.budget_exhausted, a.sweep.hits.tolist()))
    return out


@pytest.mark.parametrize("goal", [(0.0, 90.0), (180.0, 90.0), (150.0, 100.0)])
def test_a_boxed_in_arm_fails_every_path_as_one_at_a_time_does(goal):
    world, fold, c, step = _world(stays=True)
    arm = world.arm(c, fold[c], np.array(goal))
    settings = SearchResolveSettings(search="sweep").roadmap_settings(step)
    batched, single = _both(arm, settings)
    assert batched == single
    assert batched[0] is None and batched[1] == settings.max_paths       # every path failed
    assert sum(batched[4]) > 0


def test_a_node_budget_ends_both_loops_at_the_same_path():
    """The budget runs out inside a batch swept beside an earlier one: that batch was
    given the budget left before the earlier one, and is swept again with the right one."""
    world, fold, c, step = _world(stays=True)
    arm = world.arm(c, fold[c], np.array([0.0, 90.0]))
    base = SearchResolveSettings(search="sweep").roadmap_settings(step)
    sizes = np.cumsum(batches.BATCH_SIZES[:1] + tuple(2 * s for s in batches.BATCH_SIZES[1:]))
    for max_nodes in (1500, 3000, 4500):
        batched, single = _both(arm, replace(base, max_nodes=max_nodes))
        assert batched == single and batched[3]
        assert batched[1] > sizes[1]           # past the first pair of batches side by side


def test_the_first_success_is_the_same_path_and_trajectory():
    world, fold, c, step = _world(stays=False)
    arm = world.arm(c, fold[c], np.array([0.0, 90.0]))
    batched, single = _both(arm, SearchResolveSettings(search="sweep").roadmap_settings(step))
    assert batched == single and batched[0] is not None and batched[0][0][-1] > 120.0


def _compress_reference(times, configs, tol=1e-9):
    """The one-breakpoint-at-a-time rule that ``compress_breakpoints`` compiles."""
    keep = [0]
    for k in range(1, len(times)):
        if times[k] == times[keep[-1]] and np.allclose(configs[k], configs[keep[-1]], atol=tol):
            continue
        keep.append(k)
    times, configs = times[keep], configs[keep]
    if len(times) <= 2:
        return times, configs
    out = [0]
    for k in range(1, len(times) - 1):
        a, b = out[-1], k + 1
        span = times[b] - times[a]
        if span <= 0:
            out.append(k)
            continue
        pred = configs[a] + (times[k] - times[a]) / span * (configs[b] - configs[a])
        if not np.allclose(pred, configs[k], atol=tol):
            out.append(k)
    out.append(len(times) - 1)
    return times[out], configs[out]


def test_compress_keeps_the_breakpoints_the_reference_rule_keeps():
    rng = np.random.default_rng(0)
    for _ in range(200):
        n = int(rng.integers(1, 40))
        times = np.cumsum(rng.choice([0.0, 1.0, 2.0], size=n))
        # runs of constant speed, stops and repeated points
        configs = np.cumsum(rng.choice([-1.0, 0.0, 0.0, 1.0], size=(n, 2)) * 0.25, axis=0)
        got, want = compress_breakpoints(times, configs), _compress_reference(times, configs)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert compress_breakpoints(np.array([0.0, 1.0, 2.0]), np.array([[0.0], [1.0], [2.0]]))[0].tolist() == [0.0, 2.0]


def test_edges_checked_together_get_the_answers_of_one_at_a_time():
    """The world's arm checks many straight edges in one call (``edges_forbidden``): the
    same answer per edge as sampling it (``edge_samples``) and asking ``forbidden``,
    with a parked neighbour as a static obstacle and edges past the joint limits."""
    from rfp_twin.planners.roadmap.graph import EdgeFeasibility, edge_samples
    from tests.planners.roadmap.alpha_beta.test_world import intrusion

    geom, md, c, right, reach, fold, paths = intrusion()
    paths.steps[right], paths.angles[right] = np.array([0.0]), reach[None, :]   # parked there
    movable = np.ones(geom.n_robots, bool)
    movable[right] = False
    arm = AlphaBetaWorld(geom, paths, movable, md, 0.5).arm(c, fold[c], fold[c])
    rng = np.random.default_rng(1)
    q0 = rng.uniform([-20.0, -20.0], [380.0, 200.0], size=(300, 2))
    q1 = rng.uniform([-20.0, -20.0], [380.0, 200.0], size=(300, 2))
    q1[:20] = q0[:20]                                     # zero-length edges
    step = np.array([0.5, 0.5])
    want = np.array([bool(np.any(arm.forbidden(edge_samples(a, b, step)))) for a, b in zip(q0, q1)])
    got, counts = arm.edges_forbidden(q0, q1, step)
    assert got.tolist() == want.tolist() and 0 < want.sum() < want.size
    assert counts.tolist() == [len(edge_samples(a, b, step)) for a, b in zip(q0, q1)]
    feasible = EdgeFeasibility(replace(arm, edge_memo={}), step)
    feasible.prefetch([np.stack([a, b]) for a, b in zip(q0, q1)])
    assert [feasible.ok(a, b) for a, b in zip(q0, q1)] == (~want).tolist()


def test_a_forked_child_searches_with_a_worker_of_its_own():
    """A process forked after a search (e.g. a process pool) must not wait on the
    parent's worker thread, which it does not have."""
    import multiprocessing

    world, fold, c, step = _world(stays=True)
    arm = world.arm(c, fold[c], np.array([0.0, 90.0]))
    settings = SearchResolveSettings(search="sweep").roadmap_settings(step)
    before = _both(arm, settings)[0]              # the parent's worker exists now
    _FORKED[:] = [arm, settings]                  # the child has them by the fork
    ctx = multiprocessing.get_context("fork")
    out = ctx.Queue()
    child = ctx.Process(target=_child_search, args=(out,), daemon=True)
    child.start()
    got = out.get(timeout=60)
    child.join(30)
    assert child.exitcode == 0 and got == before[:4] and got[1] == settings.max_paths


_FORKED: list = []


def _child_search(out):
    arm, settings = _FORKED
    a = replace(arm, edge_memo={})
    a.sweep.hits[:] = 0
    tr, st = plan_arm(a, settings, np.random.default_rng(3))
    out.put((None if tr is None else (tr.times.tolist(), tr.configs.tolist()),
             st.paths_tried, st.nodes, st.budget_exhausted))
