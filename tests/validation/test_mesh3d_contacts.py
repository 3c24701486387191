"""Long contacts and leaning pieces in the 3D check (validation/mesh3d/check.py, bounds.py).

A contact that lasts seconds is handed to FCL in intervals of up to ``CONTACT_MM`` of
relative motion instead of ``2 tol``: the contacts found, their start and end, and every
pair minimum must be those of the fine emission. On the P1 prototype arm (pieces that
lean, where the capsule prisms are mm below the true distance) the 3D capsules must stay
below the mesh distance and above the prisms where the pieces lean.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import rfp_twin.validation.mesh3d.check as check
from rfp_twin.models.geometry import LINKS, load_geometry
from rfp_twin.validation.mesh3d import LinkModels, link_pose, validate_trajectory
from rfp_twin.validation.mesh3d.bounds import capsule3_bound
from tests.validation.conftest import SPEC, pair_layout, swing, whole_link_distance

P1 = load_geometry("sdss-v-p1", SPEC)
P1_MODELS = LinkModels.from_geometry(P1)


def long_contact():
    """Robot 0's beta arm sweeps into robot 1's (parked at 180, 180) and stays 3 s."""
    return swing([0.0, 2.0, 5.0, 7.0], [90.0, 5.0, 5.0, 90.0], 7.0)


@pytest.mark.parametrize("models", [None, P1_MODELS], ids=["estimate", "p1"])
def test_contacts_handed_whole_are_those_of_the_fine_emission(monkeypatch, models):
    traj, lay = long_contact(), pair_layout(fiducial=True)
    coarse = validate_trajectory(traj, SPEC, lay, models)
    monkeypatch.setattr(check, "CONTACT_MM", 0.0)
    fine = validate_trajectory(traj, SPEC, lay, models)
    assert coarse.collisions and len(coarse.collisions) == len(fine.collisions)
    for c, f in zip(coarse.collisions, fine.collisions):
        assert (c.robot_a, c.other, c.link_a, c.link_b) == (f.robot_a, f.other, f.link_a, f.link_b)
        assert c.t_start == pytest.approx(f.t_start, abs=2e-5)
        assert c.t_end == pytest.approx(f.t_end, abs=2e-5)
    for c, f in zip(coarse.pairs, fine.pairs):
        assert c.ids == f.ids
        tol = 0.01 + 0.05 * max(min(c.min_distance_mm, f.min_distance_mm), 0.0)
        assert c.min_distance_mm == pytest.approx(f.min_distance_mm, abs=tol + 1e-9)
    # the contact is settled with far fewer FCL distances
    assert coarse.n_exact_evals < fine.n_exact_evals / 3


def test_p1_capsules_bound_the_mesh_and_beat_the_prisms_where_pieces_lean():
    m = P1_MODELS
    beta = LINKS.index("beta")
    rng = np.random.default_rng(3)
    gains = []
    for ang in rng.uniform(0, 360, (25, 4)):
        base_b = (rng.uniform(14, 24), rng.uniform(-6, 6))
        pa = link_pose(m, beta, (0.0, 0.0), *ang[:2])[:3]
        pb = link_pose(m, beta, base_b, *ang[2:])[:3]
        d = whole_link_distance(P1, (0, 0), ang[:2], "beta", base_b, ang[2:], "beta")
        ca, sa, cb, sb = math.cos(pa[0]), math.sin(pa[0]), math.cos(pb[0]), math.sin(pb[0])
        flat = (0.0, 0.0, 0.0)
        c3 = min(capsule3_bound(u, v, ca, sa, pa[1], pa[2], flat, cb, sb, pb[1], pb[2], flat,
                                0.0, 0.0, m.cap)
                 for u in range(m.kind_ptr[beta], m.kind_ptr[beta + 1])
                 for v in range(m.kind_ptr[beta], m.kind_ptr[beta + 1]))
        assert c3 <= d + 1e-9                                   # a lower bound
        if d > 0:
            gains.append(d - c3)
    # the tube's pieces are tessellated capsules: their own capsules are within the
    # tessellation's sagitta of the mesh
    assert len(gains) > 10 and max(gains) < 0.05
