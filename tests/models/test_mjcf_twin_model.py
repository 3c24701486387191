"""Tests of rfp_twin.models.mjcf.twin_model: driving the compiled twin.

Only robots whose parts can reach each other may make contacts; the 3D arms stay inside
the 2D capsule the planner checks (Sayres 2021 Eq. 3 with buffer 1.5 mm, the arm
half-width).
"""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.geometry import load_geometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.robot import load_spec


def _robot_contact_pairs(twin, d) -> set[tuple[int, int]]:
    g = np.asarray(d.contact.geom).reshape(-1, 2)
    r = twin.index.geom_robot[g]
    keep = (r[:, 0] >= 0) & (r[:, 1] >= 0) & (r[:, 0] != r[:, 1])
    return {tuple(sorted(map(int, p))) for p in r[keep]}


def test_only_neighbours_make_contacts_and_2d_clearance_means_no_3d_contact():
    """Random configurations of a 19-robot grid: every contact is between neighbours, and
    every pair whose 2D capsules (buffer 1.5 mm, the real head-centre segment) are clear has
    no contact; pairs that overlap by more than a millimetre do touch."""
    spec = load_spec("sdss-v")
    lay = Layout.hex_grid(2, spec.pitch_mm)
    geo = load_geometry("sdss-v")
    twin = build_model(spec, lay, geo)
    seg = geo.params.head_centre_mm + 1e-6
    arr = ArrayGeometry(spec.with_overrides(segment_end_mm=seg), lay, 1.5)
    neighbours = {tuple(p) for p in twin.neighbour_pairs().tolist()}
    d = mujoco.MjData(twin.model)
    rng = np.random.default_rng(11)
    clear_pairs = touching = deep = 0
    for _ in range(150):
        angles = rng.uniform(0, 360, (lay.n_robots, 2))
        twin.set_angles(d, angles)
        pairs = _robot_contact_pairs(twin, d)
        assert pairs <= neighbours
        clearance = arr.pair_clearance(angles)
        for (i, j), c in zip(arr.pairs.tolist(), clearance):
            if c > 1e-9:
                clear_pairs += 1
                assert (i, j) not in pairs, (i, j, c)
            elif c < -1.0:
                deep += 1
                touching += (i, j) in pairs
    assert clear_pairs > 1000 and deep > 50
    assert touching == deep


def test_make_data_starts_folded_and_holds_the_pose(sdss7):
    d = sdss7.make_data()
    assert sdss7.angles(d) == pytest.approx(np.tile(sdss7.spec.fold_deg, (7, 1)))
    assert np.degrees(d.ctrl[sdss7.index.actuator]) == pytest.approx(sdss7.angles(d))
    sdss7.set_angles(d, np.full((7, 2), 90.0), hold=False)
    assert sdss7.angles(d) == pytest.approx(np.full((7, 2), 90.0))
    assert np.degrees(d.ctrl[sdss7.index.actuator]) == pytest.approx(np.tile(sdss7.spec.fold_deg, (7, 1)))


def test_neighbour_pairs_are_the_bases_within_twice_the_arm_reach():
    spec = load_spec("sdss-v")
    lay = Layout.hex_grid(2, spec.pitch_mm)
    twin = build_model(spec, lay)
    reach = twin.geometry.beta_reach_mm()
    assert reach == pytest.approx(7.4 + np.hypot(16.2, 0.3))        # the flat tip's corner
    d = np.linalg.norm(lay.robot_xy[:, None, :] - lay.robot_xy[None, :, :], axis=2)
    expected = {(i, j) for i in range(19) for j in range(i + 1, 19) if d[i, j] <= 2 * reach}
    assert {tuple(p) for p in twin.neighbour_pairs().tolist()} == expected
    assert 0 < len(expected) < 19 * 18 // 2
