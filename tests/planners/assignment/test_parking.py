"""Parking poses chosen by the assigner: a folded neighbour in the way of a target is turned
in alpha (``parking="clear"``) so the target is kept; the fold stays when nothing is gained."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.catalogue import Catalogue
from rfp_twin.models.errors import AssignmentError
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.assignment import (PARKED, AssignSettings, assign, build_candidates,
                                          miss_reasons, parking_angles)
from rfp_twin.planners.assignment.candidates import CLEAR_PARKING_STEP_DEG, PARKING_PENALTY
from rfp_twin.planners.stepwise import array_max_displacement

from tests.planners.assignment.test_assign import static_check


def blocked_case():
    """Seven robots (hex); one target on the folded beta arm of an outer robot ``j``,
    within reach of the centre robot and not of ``j``, that no robot takes when every
    idle robot parks at the fold. Returns ``(geom, margin, catalogue, j)``."""
    spec = load_spec("sdss-v")
    geom = ArrayGeometry(spec, Layout.hex_grid_positions(7, spec.pitch_mm), 2.0)
    margin = array_max_displacement(geom, 0.1)
    empty = Catalogue([], np.zeros((0, 2)), [], [], [])
    fold_seg = build_candidates(geom, empty).seg
    base = geom.base_xy
    lo, hi = spec.patrol_annulus_mm
    c = int(np.argmin(np.hypot(*(base - base.mean(axis=0)).T)))
    for j in (k for k in range(geom.n_robots) if k != c):
        x0, y0, x1, y1 = fold_seg[j]
        for f in np.linspace(0.0, 1.0, 41):
            p = np.array([x0 + f * (x1 - x0), y0 + f * (y1 - y0)])
            r = np.hypot(*(base - p).T)
            reach = (r >= lo + 0.5) & (r <= hi - 0.5)
            if not reach[c] or reach[j]:
                continue
            cat = Catalogue([7], p[None, :], [1], [0], [2])
            if assign(geom, cat, AssignSettings(margin_mm=margin, parking="fold")).n_assigned == 0:
                return geom, margin, cat, j
    raise AssertionError("no point of a folded arm that blocks the centre robot")


def test_a_folded_neighbour_blocks_the_target_and_a_clear_parking_keeps_it():
    geom, margin, cat, j = blocked_case()
    fold = assign(geom, cat, AssignSettings(margin_mm=margin, parking="fold"))
    assert fold.n_assigned == 0
    cands = build_candidates(geom, cat, margin_mm=margin)
    wanted = np.ones(1, dtype=bool)
    assert miss_reasons(geom, cands, fold, margin, wanted)["parked_neighbour"] == 1
    for solver in ("highs", "cpsat", "greedy"):
        a = assign(geom, cat, AssignSettings(margin_mm=margin, parking="clear", solver=solver))
        assert a.n_assigned == 1, solver
        assert a.objective == pytest.approx(1.0)        # the penalty is not reported
        parked = a.target < 0
        assert np.all(a.arm[parked] == PARKED)
        fold_angles = parking_angles(geom)
        moved = parked & np.any(np.abs(a.angles - fold_angles) > 1e-9, axis=1)
        # the neighbour in the way leaves the fold: beta stays folded, alpha turned
        assert moved[j] and moved.sum() <= 2, solver
        assert a.counts()["parked_off_fold"] == moved.sum()
        assert np.allclose(a.angles[moved, 1], fold_angles[moved, 1])
        turn = (a.angles[moved, 0] - fold_angles[moved, 0]) / CLEAR_PARKING_STEP_DEG
        assert np.allclose(turn, np.round(turn)) and np.all(np.round(turn) % 6 != 0)
        assert static_check(geom, a.angles, float(geom.buffer_mm)).ok
        c = build_candidates(geom, cat, margin_mm=margin, parking="clear")
        assert sum(miss_reasons(geom, c, a, margin, wanted).values()) == 0


def test_clear_parking_candidates_and_the_fold_stays_when_nothing_is_gained():
    geom, margin, cat, _ = blocked_case()
    far = Catalogue([], np.zeros((0, 2)), [], [], [])
    a = assign(geom, far, AssignSettings(margin_mm=margin, parking="clear"))
    assert np.allclose(a.angles, parking_angles(geom))
    c = build_candidates(geom, cat, margin_mm=margin, parking="clear")
    for r in range(geom.n_robots):
        lo, hi = c.ptr[r], c.ptr[r + 1]
        park = np.flatnonzero(c.target[lo:hi] < 0) + lo
        assert park[0] == lo and c.weight[lo] == 0.0          # the fold first
        assert np.allclose(c.weight[park[1:]], -PARKING_PENALTY) and park.size == 6
        assert np.allclose(c.angles[park, 1], geom.spec.fold_deg[1])
    with pytest.raises(AssignmentError, match="--parking 'away'; allowed: fold, clear"):
        AssignSettings(parking="away")
