"""SDSS-V production's post-processing (planners/postprocess/production.py)."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.planners.plan import REACHED, Plan
from rfp_twin.planners.postprocess.production import (ProductionSettings, production_axis,
                                                      production_trajectories)

STEP = 0.1


def ramp_plan(n_steps: int = 400) -> Plan:
    """Robot 7: alpha 0 -> 40 deg over the plan at one step per step, beta still;
    robot 9 does not move."""
    ptr = np.array([0, 2, 4])
    steps = np.array([0.0, n_steps, 0.0, n_steps])
    angles = np.array([[0.0, 170.0], [n_steps * STEP, 170.0], [10.0, 170.0], [10.0, 170.0]])
    status = np.array([REACHED, REACHED], dtype=object)
    return Plan(np.array([7, 9]), STEP, STEP / 12.0, n_steps, ptr, steps, angles, status,
                np.zeros((2, 2)), np.zeros((2, 2)))


def test_a_ramp_keeps_its_speed_and_gains_the_padding():
    s = ProductionSettings()
    assert s.speed_deg_s == 12.0
    dense = np.arange(401) * STEP
    t, a = production_axis(dense, STEP, s)
    # padded by 21 steps at each end: the path lasts (400 + 42) steps at 12 deg/s
    assert t[-1] == pytest.approx(442 * STEP / 12.0)
    assert a[0] == pytest.approx(0.0, abs=1e-9) and a[-1] == pytest.approx(40.0, abs=1e-9)
    # a cubic filter reproduces the ramp away from its corners: RDP keeps a few points only
    assert 4 <= t.size <= 12
    mid = (t > 0.5) & (t < t[-1] - 0.5)
    slope = np.diff(a[mid]) / np.diff(t[mid])
    np.testing.assert_allclose(slope, 12.0, rtol=1e-6)


def test_from_destination_is_to_destination_played_backwards():
    to, back = production_trajectories(ramp_plan())
    times = np.linspace(0.0, to.duration, 97)
    np.testing.assert_allclose(back.sample(times), to.sample(to.duration - times), atol=1e-9)
    # the still robot stays where it is
    np.testing.assert_allclose(to.sample(times)[:, 1], np.tile([10.0, 170.0], (97, 1)))


def test_epsilon_bounds_the_simplification():
    rng = np.random.default_rng(3)
    dense = np.cumsum(rng.choice([-STEP, 0.0, STEP], 600))
    loose = production_axis(dense, STEP, ProductionSettings(epsilon_factor=4.0))
    tight = production_axis(dense, STEP, ProductionSettings(epsilon_factor=0.5))
    assert loose[0].size < tight[0].size


@pytest.mark.parametrize("field, value, message", [
    ("speed_rpm", 4.0, "speed_rpm 4.0; allowed: (0, 3] RPM"),
    ("smooth_points", 20, "smooth_points 20; allowed: an odd integer >= 5"),
    ("epsilon_factor", -1.0, "epsilon_factor -1.0; allowed: >= 0"),
])
def test_settings_out_of_range_name_the_field(field, value, message):
    with pytest.raises(SpecError, match=message.replace("(", r"\(").replace("]", r"\]")):
        ProductionSettings(**{field: value})
