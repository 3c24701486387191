"""One robot's black boxes for the search (planners/roadmap/alpha_beta/world.py): the step
rule against moving robots, offline robots and the joint limits."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.kinematics import inverse
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
from rfp_twin.planners.roadmap.alpha_beta.world import AlphaBetaWorld
from tests.planners.conftest import hex7_folded


def test_collides_keeps_the_step_rule_margin():
    """The adapter's collides() flags capsules nearer than 2 buffer + MD (Eqs. 6-7)."""
    geom, step, md, fold, c = hex7_folded()
    paths = PathSet([np.array([0.0])] * geom.n_robots, [fold[i][None, :] for i in range(geom.n_robots)])
    world = AlphaBetaWorld(geom, paths, np.ones(geom.n_robots, bool), md, step)
    right = int(np.argmin(np.hypot(*(geom.base_xy - geom.base_xy[c] - [22.4, 0.0]).T)))
    arm = world.arm(c, fold[c], fold[c])
    # the centre robot, stretched (beta 0), turns away from its folded right neighbour:
    # the clearance goes from negative through MD to several mm
    alphas = np.linspace(0.0, 40.0, 4001)
    q = np.column_stack([alphas, np.zeros(alphas.size)])
    ang = np.tile(fold, (alphas.size, 1, 1))
    ang[:, c] = q
    clear = np.array([geom.pair_clearance(a)[np.all(np.sort(geom.pairs, 1) == sorted((c, right)), 1)][0]
                      for a in ang])
    hit = arm.collides(q, np.zeros(alphas.size))
    assert np.all(hit[clear <= md - 1e-6]) and not np.any(hit[clear > md + 1e-6])
    assert arm.forbidden(np.array([[361.0, 10.0], [10.0, -1.0]])).all()     # joint limits
    assert not arm.forbidden(np.array([[10.0, 170.0]])).any()


def intrusion():
    """7 robots at 2 mm, everyone folded; the centre robot's right neighbour reaches into
    its folded place (3 mm right of its base) at steps 40-60 and folds back.

    Returns (geom, md, centre, right, its intruding angles, fold (n, 2), paths)."""
    geom, step, md, fold, c = hex7_folded()
    spec = geom.spec
    right = int(np.argmin(np.hypot(*(geom.base_xy - geom.base_xy[c] - [22.4, 0.0]).T)))
    reach = inverse(geom.base_xy[[right]], geom.base_xy[[c]] + [[3.0, 0.0]],
                    spec.alpha_length_mm, spec.beta_length_mm)[0]
    steps = [np.array([0.0])] * geom.n_robots
    angles = [fold[i][None, :] for i in range(geom.n_robots)]
    steps[right] = np.array([0.0, 40.0, 60.0, 100.0])
    angles[right] = np.array([fold[right], reach, reach, fold[right]])
    return geom, md, c, right, reach, fold, PathSet(list(steps), list(angles))


def test_moving_obstacles_are_checked_at_their_step():
    """A neighbour that reaches into the centre robot's folded place at steps 40-60 is an
    obstacle then, not before or after; the world counts it as the one that blocked."""
    geom, md, c, right, _, fold, paths = intrusion()
    world = AlphaBetaWorld(geom, paths, np.ones(geom.n_robots, bool), md, 0.5)
    arm = world.arm(c, fold[c], fold[c])
    t = np.arange(0.0, 121.0)
    hit = arm.collides(np.tile(fold[c], (t.size, 1)), t)
    assert hit[40:61].all()
    assert not hit[:10].any() and not hit[110:].any()     # table end: it holds its fold
    assert world.blockers(c) == [right]
    assert world.blockers(c, exclude=[right]) == []
    assert not arm.forbidden(fold[c][None, :]).any()       # a mover, not a static obstacle


def test_offline_robots_are_static_obstacles():
    geom, md, c, right, reach, fold, paths = intrusion()
    paths.steps[right], paths.angles[right] = np.array([0.0]), reach[None, :]   # parked there
    movable = np.ones(geom.n_robots, bool)
    movable[right] = False
    arm = AlphaBetaWorld(geom, paths, movable, md, 0.5).arm(c, fold[c], fold[c])
    assert arm.forbidden(fold[c][None, :]).all()
    assert not arm.collides(fold[c][None, :], np.zeros(1)).any()


def test_the_compiled_sweep_finds_what_the_python_layer_loop_finds():
    """The world's arms carry a compiled sweep (the layer loop with the step-rule test
    inside numba). Same arm, same roadmap paths: the same trajectory and node count as
    the Python loop around ``collides``, with fewer checks (an action already beaten by a
    higher-priority one is not checked, a blocked one stops at its first blocked
    sub-check); and a node budget stops both alike."""
    from dataclasses import replace

    from rfp_twin.planners.roadmap.alpha_beta.settings import SearchResolveSettings
    from rfp_twin.planners.roadmap import plan_arm

    geom, step, md, fold, c = hex7_folded()
    right = int(np.argmin(np.hypot(*(geom.base_xy - geom.base_xy[c] - [22.4, 0.0]).T)))
    # the right neighbour swings its arm towards the centre and back over 120 steps: the
    # centre, clear where it is, must wait before it can stretch out
    times = [np.array([0.0])] * geom.n_robots
    confs = [fold[i][None, :] for i in range(geom.n_robots)]
    times[right] = np.array([0.0, 60.0, 120.0])
    confs[right] = np.array([fold[right], [140.0, 30.0], fold[right]])
    paths = PathSet(times, confs)
    world = AlphaBetaWorld(geom, paths, np.ones(geom.n_robots, bool), md, step)
    goal = np.array([0.0, 90.0])
    arm = world.arm(c, fold[c], goal)
    assert arm.sweep is not None
    base = SearchResolveSettings(search="sweep").roadmap_settings(step)
    for settings in (base, replace(base, max_nodes=300)):
        got = {}
        # each run with its own edge memo, so that both count their edge checks
        for name, a in (("compiled", replace(arm, edge_memo={})),
                        ("python", replace(arm, sweep=None, edge_memo={}))):
            traj, stats = plan_arm(a, settings, np.random.default_rng(3))
            got[name] = (None if traj is None else (traj.times.tolist(), traj.configs.tolist()),
                         stats.nodes, stats.paths_tried, stats.budget_exhausted, stats.checks)
        assert got["compiled"][:4] == got["python"][:4]
        assert 0 < got["compiled"][4] < got["python"][4]
        if settings is base:
            assert got["compiled"][0] is not None and got["compiled"][0][0][-1] > 120.0
    assert got["compiled"][3]                         # the small budget ran out


def test_arms_of_one_robot_share_their_edge_checks():
    """The world gives every arm of a robot the same edge memo (its forbidden zone does
    not change between plans): a second plan checks no edge again and finds the same
    trajectory as a plan with a memo of its own."""
    from dataclasses import replace

    from rfp_twin.planners.roadmap.alpha_beta.settings import SearchResolveSettings
    from rfp_twin.planners.roadmap import plan_arm

    geom, step, md, fold, c = hex7_folded()
    paths = PathSet([np.array([0.0])] * geom.n_robots, [fold[i][None, :] for i in range(geom.n_robots)])
    world = AlphaBetaWorld(geom, paths, np.ones(geom.n_robots, bool), md, step)
    settings = SearchResolveSettings(search="sweep").roadmap_settings(step)
    first = world.arm(c, fold[c], np.array([0.0, 90.0]))
    again = world.arm(c, fold[c], np.array([0.0, 90.0]), ignore=frozenset({c + 1}))
    assert again.edge_memo is first.edge_memo
    traj1, stats1 = plan_arm(first, settings, np.random.default_rng(3))
    n_memo = len(first.edge_memo)
    traj2, stats2 = plan_arm(again, settings, np.random.default_rng(3))
    own, stats3 = plan_arm(replace(again, edge_memo={}), settings, np.random.default_rng(3))
    assert traj1 is not None and n_memo > 0
    assert np.array_equal(traj2.configs, own.configs) and np.array_equal(traj2.times, own.times)
    assert stats2.checks < stats3.checks             # its edges were checked before
    assert world.arm(c + 1, fold[c + 1], fold[c + 1]).edge_memo is not first.edge_memo
