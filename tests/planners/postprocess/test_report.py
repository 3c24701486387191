"""Post-processing reports (planners/postprocess/report.py): figures, serialisation, timed path."""
from __future__ import annotations

import json

import numpy as np
import pytest

from rfp_twin.planners.postprocess import postprocess
from tests.planners.conftest import make_geom, plan_random
from rfp_twin.validation.checker2d import check_trajectory


def test_report_serialises_and_is_deterministic():
    geom = make_geom(37, 2.0)
    _, plan = plan_random(geom, 7, step_deg=0.1)
    a, ra = postprocess(plan, geom, verifier=check_trajectory)
    b, rb = postprocess(plan, geom, verifier=check_trajectory)
    assert a.to_dict() == b.to_dict()
    d = json.loads(json.dumps(ra.to_dict()))
    for key in ("budget_mm", "duration_s", "max_speed_deg_s", "max_accel_deg_s2",
                "points_per_axis_median", "points_per_axis_max", "n_groups", "largest_group",
                "stage_seconds", "verified", "retries", "tolerance_deg", "window_steps"):
        assert key in d
    assert d["budget_mm"] == 0.03 and d["verified"] is True
    assert "timed" not in d and "final_check" not in d
    assert "verified" in ra.table()
    # the checker's report on the whole trajectory, re-checks merged in
    assert ra.final_check.ok and ra.final_check.min_clearance_mm == ra.min_clearance_mm


def test_unverified_report_says_so():
    """verifier=None (timing studies): not verified, no clearance (None in JSON)."""
    geom = make_geom(37, 2.0)
    _, plan = plan_random(geom, 7, step_deg=0.1)
    _, rep = postprocess(plan, geom, verifier=None, backend="numba")
    assert rep.verified is False and rep.check_rounds == 0 and rep.final_check is None
    assert np.isnan(rep.min_clearance_mm) and rep.to_dict()["min_clearance_mm"] is None
    assert "NOT VERIFIED" in rep.table()
    assert rep.timing_solvers.get("numba", 0) + rep.timing_solvers.get("static", 0) == rep.n_groups


def test_timed_path_is_the_motion_the_trajectory_simplifies():
    geom = make_geom(37, 2.0)
    _, plan = plan_random(geom, 4, step_deg=0.1)
    traj, rep = postprocess(plan, geom, verifier=check_trajectory)
    timed = rep.timed
    # it starts and ends where the plan does, and lasts as long as the trajectory
    np.testing.assert_allclose(timed.sample([0.0])[0], plan.start(), atol=1e-9)
    np.testing.assert_allclose(timed.sample([rep.duration_s])[0], plan.end(), atol=1e-9)
    assert max(timed.group_durations().values()) == pytest.approx(rep.duration_s, rel=1e-12)
    assert set(timed.group_durations()) == set(np.unique(timed.labels).tolist())
    # every robot of a group runs on its group's clock
    assert timed.labels.shape == (plan.n_robots,) and rep.n_groups == len(timed.laws)
    assert np.all(timed.window_steps <= rep.window_steps)
