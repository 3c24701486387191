"""Tests of the broadphase over time (validation/mesh3d/broadphase.py): the certificate
and minimum of :func:`capsule_min`, and that :func:`capsule_suspects` keeps every instant
the bound cannot clear.

Robot 0 swings its beta arm 90 -> 20 -> 90 deg past robot 1's parked arm
(tests/validation/conftest.py); the bars touch for beta <= 23.25 deg.
"""
from __future__ import annotations

import numpy as np
import pytest

from tests.validation.conftest import pair_layout, sdss_models, swing
from rfp_twin.validation.mesh3d.broadphase import bound_at, capsule_min, capsule_suspects
from rfp_twin.validation.mesh3d.check import CONTACT_MM
from rfp_twin.validation.mesh3d.check import TIGHT_MM
from rfp_twin.validation.mesh3d.scene import Scene
from rfp_twin.validation.numerics import axis_csr, time_span

MODELS = sdss_models()
THR, TOL, REL, RES, COARSE = 0.0, 0.01, 0.05, 1e-5, 4.0


def kernel_inputs(traj):
    """The arrays :func:`validate_trajectory` hands the kernels, and the span."""
    scene = Scene(traj, pair_layout(), MODELS, THR)
    pa, ta, aa, ra = axis_csr(traj, 0)
    pb, tb, ab, rb = axis_csr(traj, 1)
    t_lo, t_hi = time_span(traj)
    vglob, vmean = scene.link_speeds(MODELS, (pa, ta, ra), (pb, tb, rb), t_hi - t_lo)
    m = MODELS
    head = (scene.lp_oa, scene.lp_ka, scene.lp_ob, scene.lp_kb, scene.obj_rob, scene.obj_x,
            scene.obj_y, m.l_alpha)
    args = (*head, pa, ta, aa, ra, pb, tb, ab, rb, m.kind_ptr, m.cap, m.zlim, m.poly_ptr,
            m.poly_xy, m.rad_alpha, m.rad_beta, vglob, vmean, t_lo, t_hi, COARSE, TIGHT_MM, RES)
    geo = (m.kind_ptr, m.cap, m.zlim, m.poly_ptr, m.poly_xy)

    def tight_bound(p, t):
        return bound_at(p, t, *head, pa, ta, aa, pb, tb, ab, *geo, np.inf)

    return scene, args, tight_bound, np.linspace(t_lo, t_hi, 4001)


def test_capsule_minimum_is_attained_and_certified():
    traj = swing([0.0, 1.0, 2.0], [90.0, 30.0, 90.0], 2.0)
    scene, args, bound, times = kernel_inputs(traj)
    cmin, tmin, cert, n_eval = capsule_min(*args, THR, TOL, REL)
    assert scene.n_link_pairs == 3 and n_eval > 3
    for p in range(scene.n_link_pairs):
        dense = np.array([bound(p, t) for t in times])
        assert bound(p, tmin[p]) == pytest.approx(cmin[p], abs=1e-12)   # attained
        assert cert[p] <= cmin[p]
        assert dense.min() >= cert[p] - 1e-9                            # C >= cert
        # within the tolerance of the true minimum
        assert dense.min() >= cmin[p] - TOL - REL * max(cmin[p] - THR, 0.0) - 1e-9
    # beta bars closest at beta 30 (t = 1 s): 7.6 sin 30 - 3 = 0.8 mm
    bb = int(np.flatnonzero((scene.lp_ka == 2) & (scene.lp_kb == 2))[0])
    assert tmin[bb] == pytest.approx(1.0, abs=1e-3)
    assert cmin[bb] == pytest.approx(0.8, abs=0.01)


def test_suspect_intervals_cover_every_instant_the_bound_cannot_clear():
    traj = swing([0.0, 1.0, 2.0], [90.0, 20.0, 90.0], 2.0)
    scene, args, bound, times = kernel_inputs(traj)
    n_lp = scene.n_link_pairs
    cut = np.full(n_lp, 0.5)                     # keep everything below 0.5 mm
    tolp = np.full(n_lp, TOL)
    rows, _ = capsule_suspects(*args, THR, cut, tolp, np.arange(n_lp, dtype=np.int64),
                               CONTACT_MM)
    assert len(rows)
    for p in range(n_lp):
        mine = rows[rows[:, 0] == p]
        assert np.all(np.diff(mine[:, 1]) > 0) and np.all(mine[:, 2] > mine[:, 1])
        h = mine[:, 2] - mine[:, 1]
        # short enough for exact ends to settle them, or (bound at or below the threshold
        # at both ends: a contact) at most CONTACT_MM of relative motion, handed whole
        deep = (mine[:, 3] <= THR) & (mine[:, 4] <= THR) & (mine[:, 5] * h <= CONTACT_MM + 1e-12)
        assert np.all((mine[:, 5] * h <= 2 * TOL + 1e-12) | (h <= RES) | deep)
        for t in times:
            c = bound(p, t)
            if c <= THR or c < cut[p] - 1e-9:
                assert np.any((mine[:, 1] <= t) & (t <= mine[:, 2])), (p, t, c)
    # the contact (beta below 23.25 deg) is among them, on the beta bars
    bb = int(np.flatnonzero((scene.lp_ka == 2) & (scene.lp_kb == 2))[0])
    assert np.any((rows[:, 0] == bb) & (rows[:, 1] <= 1.0) & (1.0 <= rows[:, 2]))
    # inside the contact the rows are long: far fewer than at 2 TOL of motion each
    inside = rows[(rows[:, 0] == bb) & (rows[:, 3] <= THR) & (rows[:, 4] <= THR)]
    motion = float(np.sum(inside[:, 5] * (inside[:, 2] - inside[:, 1])))
    assert len(inside) < motion / (2 * TOL) / 5
