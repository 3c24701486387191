"""What a potential-field run returns (planners/fields/result.py): the Plan of an ApfResult
replays its trajectory on the Euler step clock and carries the solver's metric keys."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.fields import (ApfSettings, apf_plan, plan_apf, plan_apf_reconfiguration,
                          random_tip_configs)
from tests.planners.fields.cases import DESI, desi_geom


def test_plan_replays_the_trajectory_on_the_step_clock():
    geom = desi_geom(19)
    targets = random_tip_configs(geom, np.random.default_rng(3), 3.0)
    plan, res = plan_apf_reconfiguration(geom, targets, offline={4: (10.0, 170.0)})
    assert plan.step_s == res.settings.dt_s == 0.01 and plan.n_steps == res.steps
    assert plan.step_deg == pytest.approx(0.01 * max(DESI.max_speed_deg_s))
    assert np.allclose(plan.path_step, np.round(plan.path_step))      # whole Euler steps
    t = np.linspace(0.0, res.motion_time_s, 57)
    back = Trajectory.from_plan(plan)
    assert np.allclose(back.sample(t), res.trajectory.sample(t), atol=1e-9)
    np.testing.assert_array_equal(plan.targets, res.targets)


def test_metrics_use_the_solver_keys():
    geom = desi_geom(19)
    targets = random_tip_configs(geom, np.random.default_rng(3), 3.0)
    plan, res = plan_apf_reconfiguration(geom, targets, offline={4: (10.0, 170.0)})
    m = plan.metrics
    for key in ("efficiency", "convergence", "tau_pg_s", "tau_sr_s", "fold_time_s",
                "n_deadlocked", "n_replaced", "n_offline", "rounds", "n_steps"):
        assert key in m
    assert m["n_offline"] == 1 and m["n_movable"] == 18 and m["n_replaced"] == 0
    assert m["efficiency"] == m["convergence"] == res.n_converged / 18
    assert m["fold_time_s"] == res.motion_time_s and m["n_steps"] == res.steps
    assert m["max_tip_error_mm"] == pytest.approx(float(res.tip_error_mm.max()))
    assert m["max_tip_error_mm"] < res.settings.tol_mm


def test_unconverged_robots_are_deadlocked_and_an_unrecorded_run_has_no_plan():
    geom = desi_geom(7)
    targets = random_tip_configs(geom, np.random.default_rng(0), 3.0)
    start = np.tile(DESI.fold_deg, (7, 1))
    short = plan_apf(geom, start, targets, ApfSettings(max_time_s=0.05))
    assert short.stop_reason == "max_time" and not short.complete
    plan = apf_plan(short)
    assert not plan.complete and plan.metrics["n_deadlocked"] == 7 - short.n_converged > 0
    bare = plan_apf(geom, start, targets, ApfSettings(max_time_s=0.05), record=False)
    assert bare.trajectory is None and bare.steps == short.steps
    with pytest.raises(SpecError, match="record=True"):
        apf_plan(bare)
