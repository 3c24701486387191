"""The numba TOPP-RA kernel (planners/postprocess/timing/kernel.py): optimal laws within the constraints."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.planners.postprocess.timing.kernel import law_excess, topp, topp_kernel
from tests.planners.path_builders import A, V


@pytest.mark.parametrize("distance", [5.0, 40.0])
def test_straight_move_is_the_trapezoid(distance):
    """q = c s on a fine grid: accelerate at a, cruise at v, brake at a."""
    c = 0.1
    grid = np.linspace(0.0, distance / c, 4001)
    qd = np.full((grid.size, 1), c)
    law = topp(grid, qd, np.zeros((grid.size - 1, 1)), [V], [A])
    exact = distance / V + V / A if distance >= V * V / A else 2.0 * np.sqrt(distance / A)
    assert law.duration == pytest.approx(exact, rel=2e-3)
    assert law.sd[0] == 0.0 and law.sd[-1] == 0.0
    assert law.sd.max() * c <= V * (1 + 1e-9)


def test_numba_kernel_matches_the_toppra_library():
    """Same problem, same gridpoints: toppra's TOPPRA (seidel) and ours agree."""
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    ta.setup_logging("WARNING")
    rng = np.random.default_rng(1)
    for _ in range(3):
        path = ta.SplineInterpolator(np.linspace(0, 100, 12),
                                     rng.normal(size=(12, 4)).cumsum(0) * 3, bc_type="clamped")
        for n, rel in ((200, 0.03), (1000, 0.005)):
            grid = np.linspace(0, 100, n + 1)
            inst = algo.TOPPRA([constraint.JointVelocityConstraint(np.array([[-V, V]] * 4)),
                                constraint.JointAccelerationConstraint(np.array([[-A, A]] * 4))],
                               path, gridpoints=grid, solver_wrapper="seidel")
            _, sd, _ = inst.compute_parameterization(0, 0)
            t_lib = np.sum(2 * np.diff(grid) / (sd[1:] + sd[:-1]))
            mid = 0.5 * (grid[1:] + grid[:-1])
            law = topp(grid, path(grid, 1), path(mid, 2), np.full(4, V), np.full(4, A))
            assert law.duration == pytest.approx(t_lib, rel=rel)
            assert law.duration >= t_lib * (1 - 1e-3)     # ours is the conservative one


def test_kernel_law_meets_its_constraints_and_is_bounded_by_the_controllable_sets():
    """On random curved problems: x within the controllable sets, law_excess <= 1, and a
    law 1 % faster exceeds the constraints (the kernel's law is at the limit)."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        N, J = 80, 4
        grid = np.cumsum(np.r_[0.0, rng.uniform(0.5, 3.0, N)])
        qd = rng.normal(size=(N + 1, J)) * 0.05
        qdd = rng.normal(size=(N, J)) * 1e-3
        vmax, amax = np.full(J, V), np.full(J, A)
        x, u, X = topp_kernel(np.diff(grid), qd, qdd, vmax, amax, 1e5)
        assert x[0] == 0.0 and x[-1] == 0.0 and np.all(x <= X * (1 + 1e-12))
        np.testing.assert_allclose(u, np.diff(x) / (2 * np.diff(grid)), rtol=1e-9, atol=1e-12)
        rv, ra = law_excess(np.diff(grid), qd, qdd, vmax, amax, x, 1e5)
        assert rv <= 1.0 + 1e-9 and ra <= 1.0 + 1e-9
        assert max(rv, ra) >= 1.0 - 1e-6
        rv2, ra2 = law_excess(np.diff(grid), qd, qdd, vmax, amax, x * 1.0201, 1e5)
        assert max(rv2, ra2) > 1.0
