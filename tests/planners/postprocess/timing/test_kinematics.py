"""Piecewise-linear kinematics (planners/postprocess/timing/kinematics.py): slopes, three-point accelerations."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.planners.postprocess.timing import pl_kinematics


def test_pl_kinematics_three_point_definition():
    t = np.array([0.0, 1.0, 3.0, 4.0])
    y = np.array([0.0, 2.0, 2.0, 5.0])        # slopes 2, 0, 3
    vm, am = pl_kinematics(t, y)
    assert vm == 3.0
    # a_0 = 2*2/1 = 4 (from rest); 2*(0-2)/3; 2*(3-0)/3 = 2; a_end = 2*3/1 = 6
    assert am == pytest.approx(6.0)
    assert pl_kinematics(np.array([0.0]), np.array([1.0])) == (0.0, 0.0)
    assert pl_kinematics(np.array([0.0, 0.0]), np.array([0.0, 1.0]))[0] == np.inf


def test_samples_of_a_parabola_have_its_acceleration():
    """The three-point value is the acceleration of the parabola through the points."""
    t = np.cumsum(np.r_[0.0, np.random.default_rng(0).uniform(0.1, 1.0, 20)])
    vm, am = pl_kinematics(t, 1.5 * t**2)
    slopes = np.diff(1.5 * t**2) / np.diff(t)
    assert vm == pytest.approx(slopes.max())
    # interior breakpoints: exactly 3; the last one brakes from the largest slope to rest
    assert am == pytest.approx(max(3.0, 2 * slopes[-1] / (t[-1] - t[-2])))
