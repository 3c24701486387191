"""Pieces of the probe arms' search over priorities: the order it returns and its
pairwise conflict test (the search itself runs on a whole bench in
benchmarks/bench_miradas.py)."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.kinds import load_kind
from rfp_twin.planners.roadmap.probe import ObstacleTime, ProbePlanSettings
from rfp_twin.planners.roadmap.probe.search import topological_order
from rfp_twin.planners.roadmap.probe.world import trajectories_touch


def test_topological_order_respects_every_pair():
    pairs = {(3, 0), (0, 2), (1, 2)}
    order = topological_order(4, pairs)
    assert sorted(order) == [0, 1, 2, 3]
    assert all(order.index(h) < order.index(lo) for h, lo in pairs)


def test_conflict_of_two_sampled_arms():
    kind = load_kind("miradas-probe")
    world = ObstacleTime(kind, 0.1, 30.0)
    park = np.array(kind.spec.park_deg)
    centre = {k: kind.inverse(kind.to_arm(k, np.zeros((1, 2))))[0] for k in (0, 6)}
    t = np.array([0.0, 20.0])
    a = world.sample(0, t, np.array([park, centre[0]]))
    b = world.sample(6, t, np.array([park, centre[6]]))
    still = world.sample(6, t, np.array([park, park]))
    assert trajectories_touch(*a, *b, world.pad)            # both heads end on the centre
    assert not trajectories_touch(*a, *still, world.pad)    # arm 6 stays parked
    assert ProbePlanSettings(search_nodes=8).search_nodes == 8
