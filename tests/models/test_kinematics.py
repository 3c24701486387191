"""Tests of rfp_twin.models.kinematics: Sayres 2021 Eqs. 1-2 forward/inverse, Eq. 13, patrol sampling."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import RfpError, TargetError
from rfp_twin.models.kinematics import forward, inverse, sample_patrol_zone

LA, LB = 7.4, 15.0          # SDSS-V arms, Sayres 2021 Sect. 3.1
R_IN, R_OUT = abs(LA - LB), LA + LB


def fwd(base, angles, la=LA, lb=LB):
    return forward(np.ascontiguousarray(base, dtype=np.float64),
                   np.ascontiguousarray(angles, dtype=np.float64), la, lb)


def test_forward_eqs_1_2_explicit():
    base = np.array([[1.0, -2.0], [0.0, 0.0], [5.0, 5.0]])
    ang = np.array([[0.0, 0.0], [90.0, 90.0], [30.0, 200.0]])
    fiber, elbow = fwd(base, ang)
    for k in range(3):
        a, b = np.deg2rad(ang[k])
        e = base[k] + LA * np.array([math.cos(a), math.sin(a)])
        f = e + LB * np.array([math.cos(a + b), math.sin(a + b)])
        np.testing.assert_allclose(elbow[k], e, atol=1e-12)
        np.testing.assert_allclose(fiber[k], f, atol=1e-12)
    # (0, 0): arm stretched along +x; (90, 90): elbow on +y, fiber towards -x
    np.testing.assert_allclose(fiber[0], [1.0 + 22.4, -2.0], atol=1e-12)
    np.testing.assert_allclose(elbow[1], [0.0, 7.4], atol=1e-12)
    np.testing.assert_allclose(fiber[1], [-15.0, 7.4], atol=1e-12)


@pytest.mark.parametrize("right_arm", [True, False])
def test_round_trip_random(right_arm):
    rng = np.random.default_rng(1234 + right_arm)
    n = 500
    base = rng.uniform(-300, 300, size=(n, 2))
    alpha = rng.uniform(0, 360, n)
    # keep off the singular beta = 0 / 180 where both arms coincide
    beta = rng.uniform(1.0, 179.0, n)
    if not right_arm:
        beta = 360.0 - beta
    ang = np.column_stack([alpha, beta])
    fiber, _ = fwd(base, ang)
    back = inverse(base, fiber, LA, LB, right_arm=right_arm)
    assert back.shape == (n, 2)
    assert np.all((back >= 0.0) & (back < 360.0))
    if right_arm:
        assert np.all((back[:, 1] >= 0.0) & (back[:, 1] <= 180.0))
    else:
        assert np.all((back[:, 1] >= 180.0) & (back[:, 1] < 360.0))
    fiber2, _ = fwd(base, back)
    np.testing.assert_allclose(fiber2, fiber, rtol=0, atol=1e-9)
    # the same arm-handedness recovers the original angles (mod 360)
    d = (back - ang + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(d, 0.0, atol=1e-7)


def test_inverse_other_arm_reaches_same_fiber():
    rng = np.random.default_rng(7)
    base = np.zeros((200, 2))
    ang = np.column_stack([rng.uniform(0, 360, 200), rng.uniform(5, 175, 200)])
    fiber, _ = fwd(base, ang)
    left = inverse(base, fiber, LA, LB, right_arm=False)
    assert np.all(left[:, 1] > 180.0)
    np.testing.assert_allclose(left[:, 1], 360.0 - ang[:, 1], atol=1e-7)
    np.testing.assert_allclose(fwd(base, left)[0], fiber, atol=1e-9)


def test_inverse_annulus_edges():
    base = np.zeros((3, 2))
    fiber = np.array([[R_OUT, 0.0], [0.0, -R_IN], [-R_OUT * 0.5, R_OUT * math.sqrt(0.75)]])
    ang = inverse(base, fiber, LA, LB)
    assert np.all(np.isfinite(ang)) and np.all((ang >= 0.0) & (ang < 360.0))
    # acos loses precision at the rim (~sqrt(eps)): compare angles mod 360, loosely
    wrap = lambda d: (np.asarray(d) + 180.0) % 360.0 - 180.0  # noqa: E731
    np.testing.assert_allclose(wrap(ang[0] - [0.0, 0.0]), 0.0, atol=1e-4)
    np.testing.assert_allclose(ang[1, 1], 180.0, atol=1e-4)
    np.testing.assert_allclose(wrap(ang[2] - [120.0, 0.0]), 0.0, atol=1e-4)
    np.testing.assert_allclose(fwd(base, ang)[0], fiber, atol=1e-6)


def test_sayres_eq13_angular_error_displacement():
    """Sayres 2021 Eq. 13: +1.50 / +1.48 deg worst-case error moves the fiber 0.97 mm.

    The paper's fiber at (0, 0) lies along +x in our convention (both arms stretched).
    """
    base = np.zeros((2, 2))
    fiber, _ = fwd(base, np.array([[0.0, 0.0], [1.50, 1.48]]))
    np.testing.assert_allclose(fiber[0], [22.4, 0.0], atol=1e-12)
    assert float(np.hypot(*(fiber[1] - fiber[0]))) == pytest.approx(0.97, abs=0.01)


@pytest.mark.parametrize("r", [R_IN - 0.01, R_OUT + 0.01, 0.0, 100.0])
def test_unreachable_target_names_robot_and_annulus(r):
    base = np.array([[0.0, 0.0], [22.4, 0.0], [44.8, 0.0]])
    fiber = base + np.array([[10.0, 0.0], [0.0, r], [-12.0, 3.0]])
    with pytest.raises(TargetError) as exc:
        inverse(base, fiber, LA, LB, ids=np.array([101, 202, 303]))
    msg = str(exc.value)
    assert "robot 202" in msg
    assert "allowed" in msg and "7.600" in msg and "22.400" in msg
    assert issubclass(TargetError, RfpError)


def test_unreachable_without_ids_names_index():
    base = np.zeros((2, 2))
    with pytest.raises(TargetError, match=r"robot 1\b"):
        inverse(base, np.array([[10.0, 0.0], [30.0, 0.0]]), LA, LB)


def test_nan_target_raises():
    base = np.zeros((2, 2))
    with pytest.raises(TargetError, match="robot 8"):
        inverse(base, np.array([[10.0, 0.0], [np.nan, 0.0]]), LA, LB, ids=np.array([7, 8]))


def test_sample_patrol_zone_reproducible_and_in_annulus():
    a = sample_patrol_zone(np.random.default_rng(42), 2000, LA, LB)
    b = sample_patrol_zone(np.random.default_rng(42), 2000, LA, LB)
    c = sample_patrol_zone(np.random.default_rng(43), 2000, LA, LB)
    assert a.shape == (2000, 2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert np.all((a[:, 1] >= 0.0) & (a[:, 1] <= 180.0))          # right-armed
    fiber, _ = fwd(np.zeros((2000, 2)), a)
    r = np.hypot(fiber[:, 0], fiber[:, 1])
    assert np.all((r >= R_IN - 1e-9) & (r <= R_OUT + 1e-9))


def test_sample_patrol_zone_left_armed():
    a = sample_patrol_zone(np.random.default_rng(5), 500, LA, LB, right_arm=False)
    assert np.all((a[:, 1] >= 180.0) & (a[:, 1] < 360.0))


def test_sample_patrol_zone_area_uniform():
    n = 20000
    ang = sample_patrol_zone(np.random.default_rng(2021), n, LA, LB)
    fiber, _ = fwd(np.zeros((n, 2)), ang)
    r = np.hypot(fiber[:, 0], fiber[:, 1])
    phi = np.arctan2(fiber[:, 1], fiber[:, 0])
    r_mid = 0.5 * (R_IN + R_OUT)
    p = (r_mid ** 2 - R_IN ** 2) / (R_OUT ** 2 - R_IN ** 2)   # area fraction, 0.3875 here
    sigma = math.sqrt(p * (1 - p) / n)
    frac = float(np.mean(r < r_mid))
    assert abs(frac - p) < 3 * sigma, (frac, p, sigma)
    # a radius-uniform sampler would put half the points inside r_mid
    assert abs(0.5 - p) > 10 * sigma
    # azimuth uniform: each quadrant holds a quarter
    counts = np.histogram(phi, bins=4, range=(-math.pi, math.pi))[0] / n
    q_sigma = math.sqrt(0.25 * 0.75 / n)
    assert np.all(np.abs(counts - 0.25) < 4 * q_sigma), counts


def test_sample_patrol_zone_desi_equal_arms():
    ang = sample_patrol_zone(np.random.default_rng(0), 1000, 3.0, 3.0)
    assert np.all(np.isfinite(ang))
    fiber, _ = fwd(np.zeros((1000, 2)), ang, 3.0, 3.0)
    assert np.all(np.hypot(fiber[:, 0], fiber[:, 1]) <= 6.0 + 1e-9)


def test_inverse_rejects_mismatched_shapes():
    with pytest.raises(TargetError, match=r"allowed: both \(n, 2\)"):
        inverse(np.zeros((1, 2)), np.ones((5, 2)), 7.4, 15.0)
