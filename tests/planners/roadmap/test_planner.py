"""One arm, Sabater 2018 Algorithm 2 (roadmap paths cheapest first, goal conflicts, lead-in):
planners/roadmap/planner.py, on toy robots."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.planners.roadmap import Arm, RoadmapSettings, goal_clear_after, plan_arm
from tests.planners.roadmap.toys import (R_TOY, RNG, direct_only, line_arm, min_distance, never,
                                         plane_arm, region, toy_world)


def test_plan_goes_around_the_forbidden_zone():
    disk = lambda q: np.hypot(q[:, 0] - 5.0, q[:, 1] - 5.0) < 2.0   # noqa: E731
    arm = plane_arm([1.0, 1.0], [9.0, 9.0], forbidden=disk, t_static=0.0)
    tr, stats = plan_arm(arm, RoadmapSettings(grid=(6, 6), n_random_edges=5, dt=0.5,
                                              dt_col=0.1, n_stop=None), RNG(1))
    t = np.arange(0.0, tr.t_end + 1e-9, 0.05)
    assert not disk(tr.at(t)).any()
    assert len(tr.path) > 2 and stats.paths_tried >= 1


def test_forbidden_start_and_missing_time_bound_are_named():
    arm = plane_arm([5.0, 5.0], [9.0, 9.0], forbidden=lambda q: q[:, 0] < 6, t_static=0.0)
    with pytest.raises(SpecError, match="'start'"):
        plan_arm(arm, RoadmapSettings(grid=(3, 3)), RNG(0))
    with pytest.raises(SpecError, match="'t_max'"):
        plan_arm(plane_arm([1.0, 1.0], [9.0, 9.0]), RoadmapSettings(grid=(3, 3)), RNG(0))


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


def test_goal_must_stay_clear_until_hold_until():
    """The goal is hit at t = 3 (by an arm passing it): an arm that must hold its goal
    until t = 6 may park there only after the hit."""
    hit = region(10.0, 10.0, 3.0, 3.0)
    arm = line_arm(hit, start=8.0, t_static=4.0, hold_until=6.0)
    assert goal_clear_after(arm, direct_only()) > 3.0
    assert goal_clear_after(replace(arm, hold_until=0.0), direct_only()) == -np.inf
    tr, _ = plan_arm(arm, direct_only(n_stop=None), RNG(0))
    assert tr.t_end > 3.0
    t = np.arange(0.0, 6.0 + 1e-9, 1.0)
    assert not hit(tr.at(t), t).any()


def plan_in_order(tasks, settings, rng):
    """Sabater 2018 Algorithm 1 on toy robots: each arm against the ones planned before
    it, parking only once they have all arrived (``Arm.hold_until``)."""
    make = toy_world(tasks)
    planned = {}
    for i in range(len(tasks)):
        ends = [tr.t_end for tr in planned.values()]
        tr, _ = plan_arm(replace(make(i, dict(planned)), hold_until=max(ends, default=0.0)),
                         settings, rng)
        assert tr is not None, f"arm {i}"
        planned[i] = tr
    return [planned[i] for i in range(len(tasks))]


def test_early_parked_arm_stays_clear_until_the_arm_before_it_has_passed():
    """A (first) crosses the plane; B's goal lies on A's route. B, planned second, must
    not park there before A has gone by; C, planned third, avoids B parked."""
    tasks = [((0.0, 5.0), (10.0, 5.0)),        # A: a long trip along y = 5
             ((5.0, 8.0), (5.0, 5.0)),         # B: short trip onto A's route
             ((5.0, 2.0), (5.0, 7.0))]         # C: its straight path crosses B's goal
    s = RoadmapSettings(dt=0.5, dt_col=0.1, grid=(6, 6), n_random_edges=4, n_stop=None)
    a, b, c = plan_in_order(tasks, s, RNG(0))
    t_pass = np.interp(5.0 + R_TOY, a.at(np.arange(0, 20, 0.01))[:, 0], np.arange(0, 20, 0.01))
    assert b.t_end >= t_pass - 1e-9             # B parks only after A has gone by
    t = np.arange(0.0, max(a.t_end, b.t_end, c.t_end) + 1.0, 0.01)
    assert min_distance([a, b, c], t) >= R_TOY - 0.1   # checked every dt_col (speed 1)
    assert len(c.path) > 2                      # C goes round B parked on its line


def test_leaving_the_lead_in_at_once_can_be_left_out():
    """``depart_at_start=False`` drops only the t_start departure; the others stay."""
    from rfp_twin.planners.roadmap.planner import departure_times
    from rfp_twin.planners.roadmap.arm import SearchStats

    lead = (np.array([0.0, 30.0]), np.array([[0.0], [3.0]]))
    arm = line_arm(lambda q, t: np.zeros(len(q), bool), t_static=5.0, lead_in=lead)
    every = departure_times(arm, direct_only(n_stop=None), SearchStats())
    later = departure_times(arm, direct_only(n_stop=None, depart_at_start=False), SearchStats())
    assert len(every) == 4 and every[-1] == arm.t_start and every[0] == 30.0
    assert later == every[:-1]
    # a lead-in blocked after its first step leaves t_start as the only departure: kept
    blocked = line_arm(lambda q, t: np.asarray(t) >= 1.0, t_static=5.0, lead_in=lead)
    assert departure_times(blocked, direct_only(n_stop=None, depart_at_start=False),
                       SearchStats()) == [arm.t_start]


def test_candidate_paths_lose_their_zero_length_edges_and_keep_their_order():
    """``candidate_paths`` drops a vertex that repeats the one before it in its path (a
    vertex on the start or goal), a block of paths at a time: the same paths as cleaning
    each path alone, in roadmap order, cut at ``max_path_time`` and ``max_paths``."""
    from dataclasses import replace as with_
    from rfp_twin.planners.roadmap.graph import Roadmap
    from rfp_twin.planners.roadmap.planner import candidate_paths

    rng = np.random.default_rng(3)
    paths = []
    for k in range(150):
        p = rng.uniform(0.0, 100.0, size=(int(rng.integers(2, 6)), 2))
        if k % 3 == 0:
            p[1] = p[0]                                   # on the start
        if k % 5 == 0:
            p[-2] = p[-1] * (1 + 1e-7)                    # on the goal, within tolerance
        if k % 11 == 0:
            p[:] = p[0]                                   # all one point
        if k % 7 == 0 and paths:
            p[0] = paths[-1][-1]                          # starts where the one before ends
        paths.append(p)
    times = np.arange(150, dtype=float)

    def alone(p):
        same = np.all(np.abs(p[1:] - p[:-1]) <= 1e-8 + 1e-5 * np.abs(p[:-1]), axis=1)
        p = p[np.concatenate([[True], ~same])]
        return p if len(p) >= 2 else np.stack([p[0], p[0]])

    class Everything:                                     # no edge is forbidden
        def clear_paths(self, block):
            return block

    roadmap = Roadmap(np.zeros((0, 2)), np.zeros((0, 2), dtype=np.int64), paths, times)
    settings = RoadmapSettings(max_paths=120, max_path_time=100.5)
    got = list(candidate_paths(roadmap, settings, Everything()))
    want = [alone(p) for p in paths[:101]]
    assert len(got) == 101
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)
    got = list(candidate_paths(roadmap, with_(settings, max_path_time=None), Everything()))
    assert len(got) == 120
