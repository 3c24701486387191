"""The FCL 3D check of probe-arm plans: contacts found, distances as the 2D check's."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.kinds import load_kind, load_probe_spec
from rfp_twin.validation.probe import check_probe_plan, check_probe_plan_3d


@pytest.fixture(scope="module")
def spec():
    return load_probe_spec("miradas-probe")


def _parked(spec, t_end=20.0):
    park = np.array(spec.park_deg)
    return {i: (np.array([0.0, t_end]), np.array([park, park])) for i in range(spec.n_arms)}


def test_parked_bench_is_clear_and_far(spec):
    rep = check_probe_plan_3d(spec, _parked(spec), dt_s=5.0, margin_mm=10.0)
    rep2 = check_probe_plan(spec, _parked(spec), dt_s=5.0)
    assert rep.ok and not rep.contacts
    # parked arms are farther apart than the margin or measured exactly
    assert rep.min_distance_mm == pytest.approx(min(10.0, rep2.min_gap_mm), abs=1e-6)


def test_heads_driven_together_touch_and_distance_matches_2d(spec):
    kind = load_kind("miradas-probe")
    plan = _parked(spec)
    goal = kind.inverse(kind.to_arm(0, np.zeros((1, 2))))[0]
    for i in (0, 6):
        plan[i] = (np.array([0.0, 100.0]), np.array([spec.park_deg, goal]))
    rep = check_probe_plan_3d(spec, plan, dt_s=2.0)
    assert not rep.ok and rep.contacts and rep.min_distance_mm <= 0.0
    assert {rep.contacts[0][1], rep.contacts[0][2]} == {0, 6}
    # before they touch: the capsules lie in one plane, FCL's distance is the 2D gap
    early = {i: (t, q) for i, (t, q) in plan.items()}
    for i in (0, 6):
        early[i] = (np.array([0.0, 100.0]), np.array([spec.park_deg, spec.park_deg + 0.6 * (goal - spec.park_deg)]))
    r3 = check_probe_plan_3d(spec, early, dt_s=4.0, margin_mm=400.0, buffer_mm=1.0)
    r2 = check_probe_plan(spec, early, dt_s=4.0, buffer_mm=1.0)
    assert r3.min_distance_mm == pytest.approx(r2.min_gap_mm, abs=1e-6)
    assert r3.worst[1:3] == r2.worst[1:3]


def test_malformed_plans_are_refused(spec):
    plan = _parked(spec)
    del plan[3]
    with pytest.raises(TrajectoryError, match="every arm"):
        check_probe_plan_3d(spec, plan)
    with pytest.raises(TrajectoryError, match="dt_s"):
        check_probe_plan_3d(spec, _parked(spec), dt_s=0.0)
