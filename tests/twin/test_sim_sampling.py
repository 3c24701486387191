"""TrajectoryTable (twin/sim/sampling.py) against numpy.interp, robot by robot."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.sim.sampling import TrajectoryTable


def _random_trajectory(rng, n):
    times, angles = ([], []), ([], [])
    for _ in range(n):
        for ax in range(2):
            k = int(rng.integers(1, 7))
            t = np.sort(rng.uniform(0.0, 3.0, k))
            if k > 2:
                t[1] = t[2]          # two breakpoints at one time (a hold at a corner)
            times[ax].append(t)
            angles[ax].append(np.full(k, rng.uniform(0, 180)) if k > 2 else rng.uniform(0, 180, k))
    return Trajectory.from_breakpoints(np.arange(n), times[0], angles[0], times[1], angles[1])


def test_matches_numpy_interp_with_and_without_warp():
    rng = np.random.default_rng(3)
    n = 40
    traj = _random_trajectory(rng, n)
    rows = rng.permutation(n + 5)[:n]               # trajectory robot j -> layout row
    table = TrajectoryTable(traj, rows)
    stuck = np.where(rng.random(n + 5) < 0.3, rng.uniform(0.5, 2.0, n + 5), np.inf)
    scale = rng.uniform(0.5, 1.0, n + 5)
    for times in (np.linspace(-0.5, 3.5, 97), rng.uniform(-0.5, 3.5, 50)):   # sorted, any order
        for warped in (False, True):
            out = np.full((times.size, n + 5, 2), -1.0)
            if warped:
                table.sample_into(out, times, stuck, scale)
            else:
                table.sample_into(out, times)
            for j, k in enumerate(rows):
                tau = np.minimum(times, stuck[k]) * scale[k] if warped else times
                for ax in range(2):
                    want = np.interp(tau, traj.times[ax][j], traj.angles[ax][j])
                    np.testing.assert_allclose(out[:, k, ax], want, rtol=0, atol=1e-12)
            others = np.setdiff1d(np.arange(n + 5), rows)
            assert np.all(out[:, others] == -1.0)       # robots not in the trajectory untouched
