"""Timing backends (planners/postprocess/timing/backends/): chosen by name, the same laws, the fallback."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import PlanningError, SpecError
from rfp_twin.planners.postprocess.timing import BACKENDS, DEFAULT_BACKEND, law_excess, time_group
from rfp_twin.planners.postprocess.timing.backends import get_backend
from tests.planners.path_builders import A, V, numeric_kinematics, real_groups


def test_backends_are_chosen_by_name():
    assert BACKENDS == ("toppra", "numba") and DEFAULT_BACKEND in BACKENDS
    assert all(callable(get_backend(name)) for name in BACKENDS)
    with pytest.raises(SpecError, match="backend"):
        get_backend("ruckig")


def test_toppra_backend_solves_every_group_of_a_real_smoothed_plan():
    """The library (seidel) on real groups: every one solved, within the limits, and the
    same law as the numba kernel (the same discretised problem on the same grid)."""
    sp, groups = real_groups()
    assert max(g.size for g in groups) >= 2
    mrange = sp.moving_range()
    for robots in groups:
        lib = time_group(sp, robots, (V, V), (A, A), backend="toppra", fallback=False,
                         moving_range=mrange)
        ker = time_group(sp, robots, (V, V), (A, A), backend="numba", moving_range=mrange)
        if ker.solver == "static":
            assert lib.solver == "static"
            continue
        assert lib.solver == "toppra" and ker.solver == "numba"
        np.testing.assert_array_equal(lib.s, ker.s)
        assert lib.duration == pytest.approx(ker.duration, rel=1e-4)
        assert lib.sd[0] == 0.0 and lib.sd[-1] == 0.0
        # the smooth timed path, by finite differences: within the limits (1 %)
        vm, am = numeric_kinematics(sp, robots, lib, dt=5e-4)
        assert vm <= V * 1.01 and am <= A * 1.01
        # and the discretised constraints the law was solved under (limits * 0.999)
        k = robots.size
        qd = sp.evaluate(lib.s, robots, 1).reshape(lib.s.size, 2 * k)
        mid = 0.5 * (lib.s[1:] + lib.s[:-1])
        qdd = sp.evaluate(mid, robots, 2).reshape(mid.size, 2 * k)
        rv, ra = law_excess(np.diff(lib.s), qd, qdd, np.full(2 * k, V * 0.999),
                            np.full(2 * k, A * 0.999), lib.sd**2, 1e5)
        assert rv <= 1.0 + 1e-9 and ra <= 1.0 + 1e-6


def test_toppra_backend_falls_back_to_the_kernel_only_when_the_library_fails(monkeypatch):
    from rfp_twin.planners.postprocess.timing.backends import toppra_library

    sp, groups = real_groups()
    robots = max(groups, key=len)
    ker = time_group(sp, robots, (V, V), (A, A), backend="numba")
    monkeypatch.setattr(toppra_library, "solve", lambda *args: None)
    law = time_group(sp, robots, (V, V), (A, A), backend="toppra")
    assert law.solver == "fallback" and law.duration == ker.duration
    with pytest.raises(PlanningError, match="toppra"):
        time_group(sp, robots, (V, V), (A, A), backend="toppra", fallback=False)
