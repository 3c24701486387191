"""Tests of where the calibration's configurations come from
(validation/buffer/sampling.py)."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.layout import Layout
from tests.validation.conftest import SPEC
from rfp_twin.validation.buffer import neighbour_directions
from rfp_twin.validation.buffer.sampling import climb, distinct_top, uniform_configurations


def test_neighbour_directions_of_hex_and_real_layouts():
    pitch, dirs = neighbour_directions(None, 22.4)
    assert pitch == 22.4 and list(dirs) == [0.0, 60.0, 120.0]
    pitch, dirs = neighbour_directions(Layout.hex_grid(3, 10.4), 10.4)
    assert pitch == pytest.approx(10.4) and list(dirs) == [0.0, 60.0, 120.0]
    pitch, dirs = neighbour_directions(Layout.sdss_v_fps(), 22.4)
    assert pitch == pytest.approx(22.4, abs=0.1)
    for want in (0.0, 60.0, 120.0):
        assert np.min(np.abs((dirs - want + 90) % 180 - 90)) < 1.0


def test_uniform_configurations_are_a_balanced_seeded_sample_of_the_joint_ranges():
    ang = uniform_configurations(SPEC, 1024, seed=4)
    lo = [SPEC.alpha_limits_deg[0], SPEC.beta_limits_deg[0]] * 2
    hi = [SPEC.alpha_limits_deg[1], SPEC.beta_limits_deg[1]] * 2
    assert ang.shape == (1024, 4)
    assert np.all(ang >= lo) and np.all(ang <= hi)
    # a (scrambled) Sobol net: every sixteenth of each range holds exactly 1024 / 16
    for k in range(4):
        counts, _ = np.histogram(ang[:, k], bins=16, range=(lo[k], hi[k]))
        assert counts.tolist() == [64] * 16
    np.testing.assert_array_equal(ang, uniform_configurations(SPEC, 1024, seed=4))
    assert not np.allclose(ang, uniform_configurations(SPEC, 1024, seed=5))
    assert uniform_configurations(SPEC, 100, seed=4).shape == (100, 4)


def test_climb_raises_the_objective_and_keeps_every_step_classified():
    # maximise x0 + x1 while staying in the disk |x| <= 10 (first two angles)
    def objective(a, d):
        return a[:, 0] + a[:, 1] + 0.0 * d

    def inside(a, d):
        return np.hypot(a[:, 0], a[:, 1]) <= 10.0

    start = np.array([[0.0, 0.0, 5.0, 5.0], [-5.0, 2.0, 1.0, 1.0]])
    rng = np.random.default_rng(1)
    best, val, acc, acc_dir, n_eval = climb(objective, inside, start, np.array([0, 1]), rng,
                                            rounds=200, batch=16, step_deg=2.0)
    assert np.all(val > objective(start, 0)) and n_eval > 0
    np.testing.assert_allclose(val, objective(best, 0))
    assert np.all(inside(best, 0)) and np.all(inside(acc, 0))
    assert set(acc_dir.tolist()) <= {0, 1}
    # close to the optimum 10 sqrt(2) on the boundary
    assert np.all(val > 10 * np.sqrt(2) - 0.2)


def test_distinct_top_keeps_one_configuration_per_cell():
    ang = np.array([[1.0, 1.0, 1.0, 1.0], [2.0, 2.0, 2.0, 2.0], [7.0, 1.0, 1.0, 1.0],
                    [1.0, 1.0, 1.0, 1.0], [30.0, 0.0, 0.0, 0.0]])
    values = np.array([5.0, 4.0, 3.0, 2.0, 1.0])
    dirs = np.array([0, 0, 0, 1, 0])
    # row 1 shares row 0's 5-deg cell; row 3 differs by its direction
    assert distinct_top(values, ang, dirs, 10).tolist() == [0, 2, 3, 4]
    assert distinct_top(values, ang, dirs, 2).tolist() == [0, 2]
