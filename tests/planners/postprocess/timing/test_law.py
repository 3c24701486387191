"""Time laws (planners/postprocess/timing/law.py): s(t) between and at gridpoints, scaling, static laws."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.planners.postprocess.smoothing import smooth_plan
from rfp_twin.planners.postprocess.timing import DEFAULT_BACKEND, TimeLaw, time_group
from rfp_twin.planners.postprocess.timing.law import law_times
from tests.planners.path_builders import A, CORNER, V


def test_static_group_and_scaling():
    still = smooth_plan(CORNER, window_steps=10)
    law = time_group(still, [0], (V, V), (A, A))
    slow = law.scaled(2.0)
    assert slow.duration == pytest.approx(2 * law.duration)
    np.testing.assert_allclose(slow.s_at(2 * np.array([0.3, 1.1])), law.s_at([0.3, 1.1]))
    s = law.s_at(np.linspace(-1, law.duration + 1, 999))
    assert np.all(np.diff(s) >= 0) and s[0] == law.s[0] and s[-1] == law.s[-1]
    static = TimeLaw.static(3.0)
    assert static.duration == 0.0 and static.s_at([0.0, 5.0]).tolist() == [3.0, 3.0]
    assert static.solver == "static" and slow.solver == law.solver == DEFAULT_BACKEND


def test_constant_acceleration_between_gridpoints():
    """x = sd^2 linear in s: from rest at sdd = 2 over s in [0, 4], then cruise."""
    s = np.array([0.0, 1.0, 4.0, 8.0])
    x = np.array([0.0, 4.0, 16.0, 16.0])                    # sd = 0, 2, 4, 4
    t = law_times(s, x)
    np.testing.assert_allclose(t, [0.0, 1.0, 2.0, 3.0])
    law = TimeLaw(s, np.sqrt(x), np.diff(x) / (2 * np.diff(s)), t)
    np.testing.assert_array_equal(law.s_at(law.t), law.s)   # exact at the gridpoints
    np.testing.assert_allclose(law.s_at([0.5, 1.5, 2.5]), [0.25, 2.25, 6.0])
    assert np.isnan(law.s_at([np.nan])[0])
    # sd = 0 at both ends of an interval: never crossed; zero length: no time
    np.testing.assert_array_equal(law_times(np.array([0.0, 1.0, 1.0]), np.zeros(3)),
                                  [0.0, np.inf, np.inf])
    np.testing.assert_array_equal(law_times(np.array([0.0, 0.0]), np.zeros(2)), [0.0, 0.0])
