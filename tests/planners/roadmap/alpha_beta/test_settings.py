"""Settings of the deadlock-resolving search (planners/roadmap/alpha_beta/settings.py)."""
from __future__ import annotations

import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.planners.roadmap.alpha_beta.settings import SearchResolveSettings


@pytest.mark.parametrize("kwargs,field", [
    ({"action_deg": 0.0}, "action_deg"), ({"action_deg": float("nan")}, "action_deg"),
    ({"priority_nodes": 0}, "priority_nodes"), ({"max_recruits": -1}, "max_recruits"),
])
def test_settings_are_checked(kwargs, field):
    with pytest.raises(SpecError, match=f"'{field}'"):
        SearchResolveSettings(**kwargs)


@pytest.mark.parametrize("action_deg,step_deg,k", [(2.0, 0.1, 20), (2.0, 0.25, 8), (0.3, 0.25, 1),
                                                   (0.01, 0.5, 1)])
def test_one_action_is_a_whole_number_of_planner_steps(action_deg, step_deg, k):
    rs = SearchResolveSettings(action_deg=action_deg, grid=(13, 11), max_paths=7).roadmap_settings(step_deg)
    assert rs.dt == float(k)
    assert rs.dt_col == 1.0                      # collisions checked at every step
    assert rs.edge_check_step == step_deg
    assert rs.grid == (13, 11) and rs.max_paths == 7 and rs.corner_vertices
