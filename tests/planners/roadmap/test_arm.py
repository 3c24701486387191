"""The roadmap planner's inputs and outputs: planners/roadmap/arm.py."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.planners.roadmap import ArmTrajectory, RoadmapSettings


@pytest.mark.parametrize("kw,field", [({"dt": 0.0}, "dt"), ({"dt": 1.0, "dt_col": 0.3}, "dt_col"),
                                      ({"n_stop": -1}, "n_stop"), ({"grid": (0, 2)}, "grid"),
                                      ({"n_random_edges": -1}, "n_random_edges"),
                                      ({"max_nodes": 0}, "max_nodes")])
def test_settings_are_checked(kw, field):
    with pytest.raises(SpecError, match=f"'{field}'.*allowed"):
        RoadmapSettings(**kw)


def test_sweep_needs_unlimited_start_stops():
    with pytest.raises(SpecError, match="'n_stop'"):
        RoadmapSettings(search="sweep", n_stop=1)
    with pytest.raises(SpecError, match="'search'"):
        RoadmapSettings(search="astar")
    assert RoadmapSettings(search="sweep", n_stop=None).search == "sweep"


def test_collision_checks_per_action():
    assert RoadmapSettings(dt=1.0).n_sub == 1
    assert RoadmapSettings(dt=2.0, dt_col=0.5).n_sub == 4


def test_trajectory_interpolates_and_holds_its_ends():
    tr = ArmTrajectory(times=np.array([1.0, 3.0]), configs=np.array([[0.0, 2.0], [4.0, 2.0]]),
                       path=np.array([[0.0, 2.0], [4.0, 2.0]]), n_start_stop=0, n_go=2,
                       n_stop_steps=0)
    assert tr.t_end == 3.0
    np.testing.assert_allclose(tr.at([0.0, 2.0, 5.0]), [[0.0, 2.0], [2.0, 2.0], [4.0, 2.0]])
