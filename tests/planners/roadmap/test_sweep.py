"""The time-layered search ("sweep", beyond Sabater 2018): planners/roadmap/sweep.py."""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.roadmap import RoadmapSettings, plan_arm
from tests.planners.roadmap.toys import (RNG, actions, direct_only, fig10_world, line_arm, region,
                                         vertex_trap)


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
    arm, hit = vertex_trap()
    tr, _ = plan_arm(arm, RoadmapSettings(dt=1.0, dt_col=0.25, grid=(1, 1), n_random_edges=0,
                                          n_stop=None, search="sweep"), RNG(0))
    t = np.arange(0.0, tr.t_end + 1e-9, 0.25)
    assert not hit(tr.at(t), t).any() and len(tr.path) == 3


def test_sweep_gives_up_when_nothing_is_reachable():
    """The whole line is blocked at t = 3: every position dies in that layer."""
    tr, stats = plan_arm(line_arm(region(0.0, 10.0, 3.0, 3.0), t_static=4.0),
                         direct_only(n_stop=None, search="sweep"), RNG(0))
    assert tr is None and stats.nodes > 0 and not stats.budget_exhausted
