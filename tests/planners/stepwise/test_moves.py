"""One step of one robot (planners/stepwise/moves.py): the margin MD bounds a step's motion."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.planners.stepwise.moves import rotate_steps, step_toward, max_displacement

L_ALPHA, L_BETA = 7.4, 15.0


def arm_point(a_deg, b_deg, r):
    """(..., 2) position of the point r mm along the beta arm (base at the origin)."""
    a, ab = np.radians(a_deg), np.radians(a_deg + b_deg)
    return np.stack([L_ALPHA * np.cos(a) + r * np.cos(ab), L_ALPHA * np.sin(a) + r * np.sin(ab)], -1)


@pytest.mark.parametrize("seg_end", [15.0, 19.0, 25.0])
@pytest.mark.parametrize("step_deg", [0.1, 0.5, 2.0])
def test_no_point_of_the_segment_moves_more_than_md_in_a_step(seg_end, step_deg):
    """Path length of every point of the beta segment over one step of at most step_deg
    per axis, sampled finely, stays within MD (Sayres 2021 Eq. 7, raised for long segments)."""
    md = max_displacement(L_ALPHA, L_BETA, seg_end, step_deg)
    rng = np.random.default_rng(3)
    a0 = rng.uniform(0.0, 360.0, 400)
    b0 = rng.uniform(0.0, 180.0, 400)
    ka, kb = rng.integers(-1, 2, (2, 400))
    u = np.linspace(0.0, 1.0, 201)[:, None]
    worst = 0.0
    for r in np.linspace(0.0, seg_end, 7):
        p = arm_point(a0 + u * ka * step_deg, b0 + u * kb * step_deg, r)        # (201, 400, 2)
        worst = max(worst, np.linalg.norm(np.diff(p, axis=0), axis=-1).sum(axis=0).max())
    assert worst <= md
    eq7 = (L_ALPHA + L_BETA) * math.sin(math.radians(2.0 * step_deg))
    assert md >= eq7
    assert md == pytest.approx(max(eq7, (L_ALPHA + 2.0 * seg_end) * math.radians(step_deg)))


def test_rotation_by_whole_steps_matches_the_trig_functions():
    d = 0.25
    cd, sd = math.cos(math.radians(d)), math.sin(math.radians(d))
    c2d, s2d = math.cos(math.radians(2 * d)), math.sin(math.radians(2 * d))
    x = math.radians(37.0)
    for k in (-2, -1, 0, 1, 2):
        c, s = rotate_steps(math.cos(x), math.sin(x), k, cd, sd, c2d, s2d)
        assert c == pytest.approx(math.cos(x + math.radians(k * d)), abs=1e-15)
        assert s == pytest.approx(math.sin(x + math.radians(k * d)), abs=1e-15)


def test_a_move_is_clipped_to_the_limits_and_stops_at_the_destination():
    assert step_toward(10.0, 20.0, 1, 0.5, 0.0, 360.0) == 10.5
    assert step_toward(10.0, 10.2, 1, 0.5, 0.0, 360.0) == 10.2       # no overshoot
    assert step_toward(10.0, 10.2, -1, 0.5, 0.0, 360.0) == 9.5       # away from it: a full step
    assert step_toward(179.8, 90.0, 1, 0.5, 0.0, 180.0) == 180.0     # joint limit
    assert step_toward(10.0, 20.0, 0, 0.5, 0.0, 360.0) == 10.0
