"""Depth-first state-time search along a roadmap path (Sabater 2018 Sect. 6.4, Algorithms
3-6): planners/roadmap/search.py, on toy robots through plan_arm."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.planners.roadmap import RoadmapSettings, plan_arm
from rfp_twin.planners.roadmap.search import neighbour_actions
from tests.planners.roadmap.toys import (RNG, actions, direct_only, fig10_world, line_arm, region,
                                         union, vertex_trap)


# --- actions and start-stop cycles (Algorithms 5-6) --------------------------------------
def test_neighbours_order_and_cycle_counting():
    # Neigh-DF: backward, stop, forward (popped last-in first: forward is tried first)
    assert [m for m, _ in neighbour_actions(0, 0, None)] == [-1, 0, 1]
    # starting from a stop is free; changing a motion counts one cycle (Fig. 8b)
    assert neighbour_actions(0, 0, 2) == [(-1, 0), (0, 0), (1, 0)]
    assert neighbour_actions(0, 1, 2) == [(-1, 1), (0, 1), (1, 0)]
    assert neighbour_actions(1, -1, 2) == [(-1, 1), (0, 2), (1, 2)]


def test_neigh_maxns_erratum_forward_neighbour_moves():
    """Sabater 2018 Algorithm 6 line 6 labels the forward neighbour of a stopped node with
    m = 0; fixed: it takes m = +1 (and keeps moving until the edge end)."""
    assert neighbour_actions(1, 0, 1) == [(0, 1), (1, 1)]
    assert neighbour_actions(1, 1, 1) == [(1, 1)]      # a moving arm keeps moving
    assert neighbour_actions(1, -1, 1) == [(-1, 1)]


def test_fig8b_forward_stop_forward_counts_one_cycle():
    """Fig. 8(b): forward, stop in front of an obstacle-time object, forward again."""
    wall = region(3.0, 4.0, 0.0, 4.0)            # q in [3, 4] blocked until t = 4
    tr, stats = plan_arm(line_arm(wall, t_static=5.0), direct_only(n_stop=None), RNG(0))
    assert actions(tr) == "FFSSFFFFFFFF"           # F F, stop 2 dt, then on to the goal
    assert tr.n_start_stop == 1 and tr.n_go == 10 and tr.n_stop_steps == 2
    assert tr.at([tr.t_end])[0, 0] == 10.0
    assert stats.paths_tried == 1 and stats.nodes > 0 and stats.checks > 0


@pytest.mark.parametrize("n_stop", [None, 2, 1, 0])
def test_fig10_every_result_is_collision_free_and_within_its_cycle_cap(n_stop):
    hit = fig10_world()
    tr, _ = plan_arm(line_arm(hit, t_static=12.0), direct_only(n_stop=n_stop), RNG(0))
    assert tr is not None
    t = np.arange(0.0, tr.t_end + 1e-9, 1.0)
    assert not hit(tr.at(t), t).any()
    assert n_stop is None or tr.n_start_stop <= n_stop


def test_fig10_the_cycle_cap_changes_the_motion():
    """Fig. 10: unlimited nStop hugs the obstacles (many start-stop cycles); nStop = 2
    gives forward, backward, stop, forward; nStop = 0 waits, then one straight move."""
    hit = fig10_world()
    arm = line_arm(hit, t_static=12.0)
    plans = {n: plan_arm(arm, direct_only(n_stop=n), RNG(0))[0] for n in (None, 2, 1, 0)}
    assert actions(plans[None]) == "FFFFBBSSFFSFFFFFF" and plans[None].n_start_stop == 3
    assert actions(plans[2]) == "FFFFBBSSSFFFFFFFF" and plans[2].n_start_stop == 2
    assert actions(plans[1]) == "FFSSSSSSSFFFFFFFF" and plans[1].n_start_stop == 1
    assert actions(plans[0]) == "S" * 7 + "F" * 10 and plans[0].n_start_stop == 0
    # depth first, forward first: all reach the goal as early as the wall allows
    assert {p.t_end for p in plans.values()} == {17.0}


def test_no_trajectory_when_the_cap_forbids_the_only_escape():
    """As Fig. 10, but the start is hit at t = 2: with nStop = 0 the arm can only wait
    at the start, so it fails; one start-stop cycle (wait further on) is enough."""
    hit = union(fig10_world(), region(0.0, 0.0, 2.0, 2.0))
    arm = line_arm(hit, t_static=12.0)
    assert plan_arm(arm, direct_only(n_stop=0), RNG(0))[0] is None
    one, _ = plan_arm(arm, direct_only(n_stop=1), RNG(0))
    assert one is not None and one.n_start_stop == 1


def test_a_start_hit_at_t_start_has_no_trajectory_and_the_node_budget_is_kept():
    assert plan_arm(line_arm(region(0.0, 0.0, 0.0, 0.0)), direct_only(n_stop=None), RNG(0))[0] is None
    tr, stats = plan_arm(line_arm(fig10_world(), t_static=12.0),
                         direct_only(n_stop=None, max_nodes=5), RNG(0))
    assert tr is None and stats.budget_exhausted and stats.nodes == 5


def test_collisions_between_nodes_are_checked_every_dt_col():
    """A thin obstacle the arm would jump over with dt = 2 (it moves 2 per action)."""
    thin = region(2.9, 3.1, 0.0, 4.0)
    arm = line_arm(thin, t_static=5.0)
    coarse, _ = plan_arm(arm, direct_only(dt=2.0, n_stop=None), RNG(0))
    fine, _ = plan_arm(arm, direct_only(dt=2.0, dt_col=0.5, n_stop=None), RNG(0))
    t = np.arange(0.0, 20.0, 0.5)
    assert thin(coarse.at(t), t).any()          # dt_col = dt misses it ...
    assert not thin(fine.at(t), t).any()        # ... dt_col = dt / 4 does not


def test_edge_speed_divides_the_edge_into_whole_steps():
    """Sect. 6.4.1: the edge speed is the largest <= vmax giving whole dt steps."""
    arm = line_arm(lambda q, t: np.zeros(len(q), bool), goal=7.0)
    tr, _ = plan_arm(arm, direct_only(dt=2.0, n_stop=None), RNG(0))
    assert tr.t_end == 8.0                      # 7 units at speed <= 1 in whole 2-unit steps
    assert np.allclose(tr.configs[-1], [7.0])


def test_paper_mode_commits_to_each_edge_and_resume_mode_backs_up():
    """Algorithm 2 keeps an edge's first trajectory; ``resume_edges`` may change it (the
    first edge's depth-first search reaches the trapped vertex at t = 5)."""
    arm, hit = vertex_trap()
    s = dict(dt=1.0, grid=(1, 1), n_random_edges=0, n_stop=None)
    assert plan_arm(arm, RoadmapSettings(**s, resume_edges=False), RNG(0))[0] is None
    tr, _ = plan_arm(arm, RoadmapSettings(**s, resume_edges=True), RNG(0))
    assert tr is not None and len(tr.path) == 3
    t = np.arange(0.0, tr.t_end + 1e-9, 1.0)
    assert not hit(tr.at(t), t).any()
    assert np.interp(5.0, tr.configs[:, 0], tr.times) > 12.0   # reaches the vertex after the hit
