"""The independent probe-arm checker finds contacts, ZoA entries, speeding and cycles."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.kinds import load_kind, load_probe_spec
from rfp_twin.validation.probe import check_probe_plan, start_stop_cycles


@pytest.fixture(scope="module")
def spec():
    return load_probe_spec("miradas-probe")


def _parked(spec, t_end=60.0):
    park = np.array(spec.park_deg)
    return {i: (np.array([0.0, t_end]), np.array([park, park])) for i in range(spec.n_arms)}


def test_parked_bench_is_clear(spec):
    rep = check_probe_plan(spec, _parked(spec), buffer_mm=spec.buffer_mm, dt_s=1.0)
    assert rep.ok and rep.min_gap_mm > 0 and rep.start_stop == {i: 0 for i in range(12)}


def test_two_arms_driven_into_the_centre_touch(spec):
    plan = _parked(spec)
    # arms 0 and 6 face each other; the pose putting the tip on the field centre (the
    # model's inverse kinematics) puts both heads there
    kind = load_kind("miradas-probe")
    goal = kind.inverse(kind.to_arm(0, np.zeros((1, 2))))[0]
    for i in (0, 6):
        plan[i] = (np.array([0.0, 100.0]), np.array([spec.park_deg, goal]))
    rep = check_probe_plan(spec, plan, dt_s=0.5)
    assert not rep.ok and rep.contacts and {rep.contacts[0][1], rep.contacts[0][2]} == {0, 6}
    assert rep.min_gap_mm < 0 and rep.worst[1:3] == (0, 6)


def test_zoa_speed_and_cycles_are_checked(spec):
    plan = _parked(spec)
    plan[3] = (np.array([0.0, 10.0]), np.array([spec.park_deg, [178.0, 0.0]]))   # fine
    plan[4] = (np.array([0.0, 1.0]), np.array([spec.park_deg, [170.0, 0.0]]))    # 10 deg/s
    plan[5] = (np.array([0.0, 100.0]), np.array([spec.park_deg, [0.0, 0.0]]))    # ends in ZoA
    rep = check_probe_plan(spec, plan, dt_s=1.0)
    assert not rep.ok
    assert (4, 0, pytest.approx(10.0)) in rep.too_fast and not any(a == 3 for a, *_ in rep.too_fast)
    assert {a for a, _ in rep.zoa} == {5}
    # cycles: move, stop, move on = 1; move, turn = 1; a start from rest is free
    t = np.array([0.0, 1.0, 2.0, 3.0])
    q = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    assert start_stop_cycles(t, q) == 1
    assert start_stop_cycles(t[:3], np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])) == 1
    assert start_stop_cycles(t[:3], np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0]])) == 0


def test_malformed_plans_are_refused(spec):
    plan = _parked(spec)
    del plan[7]
    with pytest.raises(TrajectoryError, match="every arm"):
        check_probe_plan(spec, plan)
    plan = _parked(spec)
    plan[2] = (np.array([1.0, 0.0]), plan[2][1])
    with pytest.raises(TrajectoryError, match="^arm 2: "):
        check_probe_plan(spec, plan)
