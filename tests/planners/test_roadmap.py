"""Sabater 2018 roadmap / state-time planner on toy robots, through its two black boxes.

The toy robots here are points: on a line (1 joint) or in the plane (2 joints), with
obstacles given directly as regions of state-time. Nothing here knows alpha/beta arms.
"""
from __future__ import annotations

import numpy as np
import pytest

from models.errors import SpecError
from planners.roadmap import (Arm, ArmTrajectory, RoadmapSettings, build_roadmap,
                              corner_vertices, edge_time, neighbour_actions, plan_arm,
                              prioritized_plan, priority_search)

RNG = np.random.default_rng


def never(q):
    return np.zeros(len(q), dtype=bool)


def line_arm(collides, start=0.0, goal=10.0, t_static=30.0, **kw) -> Arm:
    """A point on a line, speed 1 per time unit: one action moves it by one unit. Its
    roadmap grid is the goal alone, so with ``direct_only`` it has one path, one edge."""
    return Arm(start=np.array([start]), goal=np.array([goal]), vmax=np.array([1.0]),
               forbidden=never, collides=collides, lower=np.array([goal]), upper=np.array([goal]),
               t_static=t_static, **kw)


def direct_only(**kw) -> RoadmapSettings:
    """One straight edge (see ``line_arm``)."""
    base = dict(dt=1.0, grid=(1,), n_random_edges=0, max_paths=1)
    base.update(kw)
    return RoadmapSettings(**base)


def actions(tr: ArmTrajectory, dt: float = 1.0) -> str:
    """The motion of each dt as a string: F forward, S stop, B backward (1-D)."""
    t = np.arange(tr.times[0], tr.t_end + 1e-9, dt)
    d = np.diff(tr.at(t)[:, 0])
    return "".join("F" if x > 1e-9 else "B" if x < -1e-9 else "S" for x in d)


def region(q_lo, q_hi, t_lo, t_hi):
    """Obstacle-time region: the points q_lo <= q <= q_hi collide for t_lo <= t <= t_hi."""
    def hit(q, t):
        return (q[:, 0] >= q_lo) & (q[:, 0] <= q_hi) & (t >= t_lo) & (t <= t_hi)
    return hit


def union(*fs):
    return lambda q, t: np.any([f(q, t) for f in fs], axis=0)


# --- Sect. 6.4: actions and start-stop cycles (Algorithms 5-6) ---------------------------
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


def fig10_world():
    """A wall ahead until t = 12 (q >= 5) and a blocker sweeping q in [3, 4] at t 6-8:
    an arm waiting in front of the wall must back off and come again (Fig. 10)."""
    return union(region(5.0, 10.0, 0.0, 11.5), region(3.0, 4.0, 6.0, 8.0))


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
    """Algorithm 2 keeps an edge's first trajectory; ``resume_edges`` may change it.

    One path, (0, 0) -> (5, 5) -> (10, 0) (the direct line is forbidden). Past x = 5.5
    everything is blocked until t = 15 and the vertex itself is hit at t 7-12: arriving
    at the vertex at t = 5, as the first edge's depth-first search does, is fatal."""
    def hit(q, t):
        at_vertex = (np.hypot(q[:, 0] - 5.0, q[:, 1] - 5.0) < 0.5) & (t >= 7) & (t <= 12)
        return at_vertex | ((q[:, 0] > 5.5) & (t < 15))

    arm = Arm(start=np.zeros(2), goal=np.array([10.0, 0.0]), vmax=np.ones(2),
              forbidden=lambda q: (q[:, 1] < 1.0) & (q[:, 0] > 3.0) & (q[:, 0] < 7.0),
              collides=hit, lower=np.array([10.0, 0.0]), upper=np.array([10.0, 0.0]),
              t_static=15.0, extra_vertices=np.array([[5.0, 5.0]]))
    s = dict(dt=1.0, grid=(1, 1), n_random_edges=0, n_stop=None)
    assert plan_arm(arm, RoadmapSettings(**s, resume_edges=False), RNG(0))[0] is None
    tr, _ = plan_arm(arm, RoadmapSettings(**s, resume_edges=True), RNG(0))
    assert tr is not None and len(tr.path) == 3
    t = np.arange(0.0, tr.t_end + 1e-9, 1.0)
    assert not hit(tr.at(t), t).any()
    assert np.interp(5.0, tr.configs[:, 0], tr.times) > 12.0   # reaches the vertex after the hit


# --- Sect. 6.1: roadmap ----------------------------------------------------------------
def plane_arm(start, goal, collides=None, forbidden=never, **kw) -> Arm:
    return Arm(start=np.asarray(start, float), goal=np.asarray(goal, float),
               vmax=np.array([1.0, 1.0]), forbidden=forbidden,
               collides=collides or (lambda q, t: np.zeros(len(q), bool)),
               lower=np.array([0.0, 0.0]), upper=np.array([10.0, 10.0]), **kw)


def test_roadmap_vertices_edges_and_paths_cheapest_first():
    disk = lambda q: np.hypot(q[:, 0] - 5.0, q[:, 1] - 5.0) < 2.0   # noqa: E731 (the ZoA)
    arm = plane_arm([1.0, 1.0], [9.0, 9.0], forbidden=disk, t_static=0.0)
    rm = build_roadmap(arm, RoadmapSettings(grid=(6, 6), n_random_edges=5), RNG(1))
    assert not disk(rm.vertices).any()
    assert len(rm.vertices) == 36 - 4            # the 6 x 6 grid minus the ZoA
    used = rm.edges.ravel()
    assert len(used) == len(set(used.tolist()))  # a vertex is in one random edge at most
    assert np.all(np.diff(rm.est_times) >= 0)
    assert rm.est_times[0] == edge_time(arm.start, arm.goal, arm.vmax) == 8.0
    counts = sorted({len(p) for p in rm.paths})
    assert counts == [2, 3, 4]                   # direct, one vertex, a random edge


def test_plan_goes_around_the_forbidden_zone():
    disk = lambda q: np.hypot(q[:, 0] - 5.0, q[:, 1] - 5.0) < 2.0   # noqa: E731
    arm = plane_arm([1.0, 1.0], [9.0, 9.0], forbidden=disk, t_static=0.0)
    tr, stats = plan_arm(arm, RoadmapSettings(grid=(6, 6), n_random_edges=5, dt=0.5,
                                              dt_col=0.1, n_stop=None), RNG(1))
    t = np.arange(0.0, tr.t_end + 1e-9, 0.05)
    assert not disk(tr.at(t)).any()
    assert len(tr.path) > 2 and stats.paths_tried >= 1


def test_corner_vertices():
    c = corner_vertices(np.array([0.0, 0.0]), np.array([4.0, 10.0]), np.array([1.0, 1.0]))
    rows = {tuple(r) for r in c}
    assert {(4.0, 0.0), (0.0, 10.0)} <= rows     # one joint first, then the other
    assert {(4.0, 4.0), (0.0, 6.0)} <= rows      # both at full speed until one is done


def test_forbidden_start_is_named():
    arm = plane_arm([5.0, 5.0], [9.0, 9.0], forbidden=lambda q: q[:, 0] < 6, t_static=0.0)
    with pytest.raises(SpecError, match="'start'"):
        plan_arm(arm, RoadmapSettings(grid=(3, 3)), RNG(0))


@pytest.mark.parametrize("kw,field", [({"dt": 0.0}, "dt"), ({"dt": 1.0, "dt_col": 0.3}, "dt_col"),
                                      ({"n_stop": -1}, "n_stop"), ({"grid": (0, 2)}, "grid")])
def test_settings_are_checked(kw, field):
    with pytest.raises(SpecError, match=f"'{field}'.*allowed"):
        RoadmapSettings(**kw)


def test_same_seed_same_plan():
    hit = region(4.0, 6.0, 0.0, 6.0)
    arm = Arm(start=np.array([0.0, 5.0]), goal=np.array([10.0, 5.0]), vmax=np.ones(2),
              forbidden=never, collides=lambda q, t: hit(q, t) & (np.abs(q[:, 1] - 5) < 1),
              lower=np.zeros(2), upper=np.full(2, 10.0), t_static=7.0)
    s = RoadmapSettings(grid=(5, 5), n_random_edges=4, n_stop=None)
    a, _ = plan_arm(arm, s, RNG(3))
    b, _ = plan_arm(arm, s, RNG(3))
    np.testing.assert_array_equal(a.times, b.times)
    np.testing.assert_array_equal(a.configs, b.configs)


def test_lead_in_is_kept_as_long_as_possible():
    """An arm may follow a given motion and leave it (here: it must leave before t = 4)."""
    lead = (np.array([0.0, 6.0]), np.array([[0.0], [3.0]]))     # 0 -> 3 at speed 1/2
    hit = region(2.0, 2.0, 4.0, 4.0)
    arm = line_arm(hit, t_static=5.0, lead_in=lead)
    tr, _ = plan_arm(arm, direct_only(n_stop=None, max_departures=8), RNG(0))
    t = np.arange(0.0, tr.t_end + 1e-9, 1.0)
    assert not hit(tr.at(t), t).any()
    np.testing.assert_allclose(tr.at([2.0]), [[1.0]])           # still on the lead-in at t = 2


# --- Algorithm 1: prioritized planning, goal conflicts -------------------------------
R_TOY = 1.0   # two toy robots collide when their points are closer than this


def toy_world(tasks):
    """Point robots in the plane; arm i's collides() sees the arms planned before it."""
    def make_arm(i, planned):
        start, goal = tasks[i]

        def collides(q, t):
            hit = np.zeros(len(q), dtype=bool)
            for tr in planned.values():
                hit |= np.hypot(*(q - tr.at(t)).T) < R_TOY
            return hit
        ends = [tr.t_end for tr in planned.values()]
        return plane_arm(start, goal, collides, t_static=max(ends, default=0.0))
    return make_arm


def min_distance(trs, t):
    return min(np.hypot(*(a.at(t) - b.at(t)).T).min()
               for k, a in enumerate(trs) for b in trs[k + 1:])


def test_early_parked_arm_stays_clear_until_the_arm_before_it_has_passed():
    """A (first) crosses the plane; B's goal lies on A's route. B, planned second, must
    not park there before A has gone by; C, planned third, avoids B parked."""
    tasks = [((0.0, 5.0), (10.0, 5.0)),        # A: a long trip along y = 5
             ((5.0, 8.0), (5.0, 5.0)),         # B: short trip onto A's route
             ((5.0, 2.0), (5.0, 7.0))]         # C: its straight path crosses B's goal
    s = RoadmapSettings(dt=0.5, dt_col=0.1, grid=(6, 6), n_random_edges=4, n_stop=None)
    res = prioritized_plan(3, toy_world(tasks), s, RNG(0), order=[0, 1, 2])
    assert res.success and res.order == [0, 1, 2]
    a, b, c = (res.trajectories[k] for k in range(3))
    t_pass = np.interp(5.0 + R_TOY, a.at(np.arange(0, 20, 0.01))[:, 0], np.arange(0, 20, 0.01))
    assert b.t_end >= t_pass - 1e-9             # B parks only after A has gone by
    t = np.arange(0.0, max(a.t_end, b.t_end, c.t_end) + 1.0, 0.01)
    assert min_distance([a, b, c], t) >= R_TOY - 0.1   # checked every dt_col (speed 1)
    assert len(c.path) > 2                      # C goes round B parked on its line


def test_prioritized_plan_tries_another_order_after_a_failure():
    """B's goal is A's start and A's goal is B's start region; B first cannot work
    (A would be walled in), A first can."""
    tasks = [((1.0, 5.0), (9.0, 5.0)), ((9.0, 5.0), (1.0, 8.0))]
    s = RoadmapSettings(dt=0.5, dt_col=0.1, grid=(5, 5), n_random_edges=4, n_stop=None)
    res = prioritized_plan(2, toy_world(tasks), s, RNG(0), order=[1, 0], max_orders=3)
    assert res.success
    t = np.arange(0.0, 40.0, 0.01)
    assert min_distance(list(res.trajectories.values()), t) >= R_TOY - 0.1


def test_priority_search_resolves_a_goal_conflict_with_no_order_given():
    tasks = [((0.0, 5.0), (10.0, 5.0)), ((5.0, 8.0), (5.0, 5.0))]
    make = toy_world(tasks)

    def make_arm(i, higher, arms):
        return make(i, higher)

    def conflict(i, a, j, b):
        t = np.arange(0.0, max(a.t_end, b.t_end) + 0.5, 0.1)
        return bool((np.hypot(*(a.at(t) - b.at(t)).T) < R_TOY).any())

    s = RoadmapSettings(dt=0.5, dt_col=0.1, grid=(6, 6), n_random_edges=4, n_stop=None)
    res = priority_search(2, make_arm, conflict, s, RNG(0))
    assert res.success and len(res.priorities) == 1
    a, b = res.trajectories[0], res.trajectories[1]
    assert not conflict(0, a, 1, b)


# --- beyond the paper: the time-layered search ("sweep") --------------------------------
def test_sweep_finds_the_earliest_arrival_on_the_same_graph():
    hit = fig10_world()
    arm = line_arm(hit, t_static=12.0)
    dfs, _ = plan_arm(arm, direct_only(n_stop=None), RNG(0))
    sweep, stats = plan_arm(arm, direct_only(n_stop=None, search="sweep"), RNG(0))
    t = np.arange(0.0, sweep.t_end + 1e-9, 1.0)
    assert not hit(sweep.at(t), t).any()
    assert sweep.t_end == dfs.t_end == 17.0            # the wall sets the arrival time
    wall = region(3.0, 4.0, 0.0, 4.0)
    tr, _ = plan_arm(line_arm(wall, t_static=5.0), direct_only(n_stop=None, search="sweep"), RNG(0))
    assert tr.t_end == 12.0 and actions(tr).count("F") == 10


def test_sweep_crosses_vertices_and_checks_between_nodes():
    def hit(q, t):
        at_vertex = (np.hypot(q[:, 0] - 5.0, q[:, 1] - 5.0) < 0.5) & (t >= 7) & (t <= 12)
        return at_vertex | ((q[:, 0] > 5.5) & (t < 15))

    arm = Arm(start=np.zeros(2), goal=np.array([10.0, 0.0]), vmax=np.ones(2),
              forbidden=lambda q: (q[:, 1] < 1.0) & (q[:, 0] > 3.0) & (q[:, 0] < 7.0),
              collides=hit, lower=np.array([10.0, 0.0]), upper=np.array([10.0, 0.0]),
              t_static=15.0, extra_vertices=np.array([[5.0, 5.0]]))
    tr, _ = plan_arm(arm, RoadmapSettings(dt=1.0, dt_col=0.25, grid=(1, 1), n_random_edges=0,
                                          n_stop=None, search="sweep"), RNG(0))
    t = np.arange(0.0, tr.t_end + 1e-9, 0.25)
    assert not hit(tr.at(t), t).any() and len(tr.path) == 3


def test_sweep_needs_unlimited_start_stops():
    with pytest.raises(SpecError, match="'n_stop'"):
        RoadmapSettings(search="sweep", n_stop=1)
    with pytest.raises(SpecError, match="'search'"):
        RoadmapSettings(search="astar")
