"""Search over pairwise priorities (Ma et al. 2019) with Sabater's planner for each arm:
planners/roadmap/priority.py, on toy robots."""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.roadmap import RoadmapSettings, priority_search
from tests.planners.roadmap.toys import R_TOY, RNG, min_distance, toy_world

SETTINGS = RoadmapSettings(dt=0.5, dt_col=0.1, grid=(6, 6), n_random_edges=4, n_stop=None)
#: Vertices at 0, 5 and 10 on each joint, no random edges.
GRID_3X3 = RoadmapSettings(dt=0.5, dt_col=0.1, grid=(3, 3), n_random_edges=0, n_stop=None)
SWAP = [((1.0, 5.0), (9.0, 5.0)), ((9.0, 5.0), (1.0, 5.0))]


def conflict(i, a, j, b):
    t = np.arange(0.0, max(a.t_end, b.t_end) + 0.5, 0.1)
    return bool((np.hypot(*(a.at(t) - b.at(t)).T) < R_TOY).any())


def search(tasks, settings=SETTINGS, **kw):
    make = toy_world(tasks)
    return priority_search(len(tasks), lambda i, higher, arms: make(i, higher), conflict,
                           settings, RNG(0), **kw)


def test_priority_search_resolves_a_goal_conflict_with_no_order_given():
    res = search([((0.0, 5.0), (10.0, 5.0)), ((5.0, 8.0), (5.0, 5.0))])
    assert res.success and len(res.priorities) == 1 and res.n_arms == 2
    a, b = res.trajectories[0], res.trajectories[1]
    assert not conflict(0, a, 1, b)


def test_priority_search_makes_one_arm_yield_when_two_swap_places():
    """Two arms swapping places head-on: alone, each takes a cheapest path (on the line
    y = 5, the only grid vertex there is (5, 5)) and they collide; the search puts one above
    the other, which then goes round."""
    res = search(SWAP, GRID_3X3)
    assert res.success and res.nodes >= 2 and res.plans >= 3 and len(res.priorities) == 1
    (hi, lo), = res.priorities
    t = np.arange(0.0, 40.0, 0.1)
    off_line = lambda k: np.abs(res.trajectories[k].at(t)[:, 1] - 5.0).max()   # noqa: E731
    assert off_line(lo) >= R_TOY > off_line(hi)                # the lower arm goes round
    t = np.arange(0.0, 40.0, 0.01)
    assert min_distance(list(res.trajectories.values()), t) >= R_TOY - 0.1


def test_priority_search_reports_failure_within_its_node_budget():
    """The same swap with one search-tree node (the root, where they collide): no solution."""
    res = search(SWAP, GRID_3X3, max_nodes=1)
    assert not res.success and res.trajectories == {} and res.nodes == 1
