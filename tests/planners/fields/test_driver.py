"""Entry points of the potential-field planners: planners/fields/driver.py (plan_apf and the
CLI-shaped plan_apf_reconfiguration), checked by the independent 2D checker."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError, UnknownRobotError
from rfp_twin.models.layout import Layout
from rfp_twin.planners.fields import (ApfSettings, apf_target_margin_mm, plan_apf, plan_apf_reconfiguration,
                          random_tip_configs)
from rfp_twin.planners.plan import DEADLOCKED, OFFLINE, REACHED
from rfp_twin.planners.plan.targets import random_targets
from tests.planners.fields.cases import DESI, SDSS, angles_for, custom_geom, desi_geom
from rfp_twin.validation.checker2d import check_trajectory


def test_start_errors_name_robots():
    geom = custom_geom(DESI, [[0.0, 0.0], [DESI.pitch_mm, 0.0]])
    mid = DESI.pitch_mm / 2
    start = np.array([angles_for(geom, 0, [mid - 0.5, 0.0]), angles_for(geom, 1, [-(mid - 0.5), 0.0])])
    with pytest.raises(TargetError, match=r"start: robots 0 and 1: tips 1\.\d+ mm apart; allowed: > d = 2"):
        plan_apf(geom, start, start)
    with pytest.raises(TargetError, match="start: robot 1: field 'beta'"):
        plan_apf(geom, np.array([[0.0, 0.0], [0.0, 400.0]]), start)
    with pytest.raises(TargetError, match=r"targets: shape \(1, 2\)"):
        plan_apf(geom, start, start[:1])
    with pytest.raises(TargetError, match=r"movable: shape \(3,\)"):
        plan_apf(geom, start, start, movable=np.ones(3, bool))


def test_start_near_a_fiducial_is_named():
    geom = custom_geom(DESI, [[0.0, 0.0], [3.0, 4.0]], ["robot", "fiducial"])
    start = np.array([angles_for(geom, 0, [3.0, 3.5])])
    with pytest.raises(TargetError, match=r"start: robot 0: 0\.5000 mm from fiducial 1"):
        plan_apf(geom, start, start)


def test_segment_mode_passes_checker_at_buffer():
    buffer = 2.5
    geom = ArrayGeometry(SDSS, Layout.hex_grid_positions(7, SDSS.pitch_mm), buffer)
    settings = ApfSettings(model="segment")
    m = apf_target_margin_mm(geom, settings)
    rng = np.random.default_rng(0)
    start = random_targets(geom, rng, margin_mm=m + 0.05)
    targets = random_targets(geom, rng, margin_mm=m + 0.5)
    r = plan_apf(geom, start, targets, settings)
    assert r.complete and r.min_distance_mm > 2 * buffer
    report = check_trajectory(r.trajectory, SDSS, geom.layout, buffer)
    assert report.ok, report.table()
    assert report.min_clearance_mm > 0.1
    assert r.trajectory.point_counts().max() <= 1024
    assert np.all(r.trajectory.max_speed() <= np.array(SDSS.max_speed_deg_s) + 1e-6)


def test_reconfiguration_from_the_fold_with_an_offline_robot():
    geom = desi_geom(19)
    rng = np.random.default_rng(3)
    targets = random_tip_configs(geom, rng, 3.0)
    plan, res = plan_apf_reconfiguration(geom, targets, offline={4: (10.0, 170.0)})
    assert res.algorithm == "apf" and plan.step_s == 0.01 and plan.n_steps == res.steps
    assert set(plan.status) <= {REACHED, DEADLOCKED, OFFLINE}
    assert plan.status[4] == OFFLINE and np.all(plan.status[np.arange(19) != 4] == REACHED)
    expected = np.array([DESI.fold_deg] * 19)
    expected[4] = (10.0, 170.0)
    assert np.allclose(plan.start(), expected) and np.allclose(res.targets[4], (10.0, 170.0))
    assert plan.metrics["efficiency"] == 1.0 and plan.metrics["n_offline"] == 1


def test_offline_errors_name_the_robot():
    geom = custom_geom(DESI, [[0.0, 0.0], [DESI.pitch_mm, 0.0]])
    targets = np.array([[0.0, 150.0], [180.0, 150.0]])
    with pytest.raises(UnknownRobotError, match="offline robot 9"):
        plan_apf_reconfiguration(geom, targets, offline={9: (0.0, 0.0)})
    with pytest.raises(TargetError, match="offline: robot 1: field 'beta' = 400.0"):
        plan_apf_reconfiguration(geom, targets, offline={1: (0.0, 400.0)})
