"""Tests of the objects and candidate link pairs of a 3D check (validation/mesh3d/scene.py).

SDSS-V link kinds (robot frame): body z [-20, 0] reach 5; alpha z [0.3, 4.3] reach
10.6; beta z [4.3, 7.8] reach 23.6; fiducial z [-20, 7.8] reach 1 (mm).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.geometry import LINKS
from rfp_twin.models.layout import Layout
from rfp_twin.models.trajectory import Trajectory
from tests.validation.conftest import PITCH, sdss_models, static
from rfp_twin.validation.mesh3d.scene import Scene
from rfp_twin.validation.numerics import axis_csr

MODELS = sdss_models()
BODY, ALPHA, BETA, FID = (LINKS.index(k) for k in ("body", "alpha", "beta", "fiducial"))


def layout() -> Layout:
    """Robots 0, 1 at the pitch, robot 2 far away, fiducial 7 20 mm above robot 0."""
    return Layout([0, 1, 2, 7], [[0.0, 0.0], [PITCH, 0.0], [100.0, 0.0], [0.0, 20.0]],
                  ["robot", "robot", "robot", "fiducial"], name="scene")


def test_candidate_link_pairs_follow_z_intervals_and_reaches():
    # trajectory order 1, 0, 2: objects are robots in that order, then the fiducial
    scene = Scene(static([[0, 180]] * 3, ids=(1, 0, 2)), layout(), MODELS, 0.0)
    assert scene.robot_ids.tolist() == [1, 0, 2] and scene.n_fiducials == 1
    assert scene.obj_rob.tolist() == [0, 1, 2, -1]
    np.testing.assert_array_equal(np.column_stack([scene.obj_x, scene.obj_y]),
                                  [[PITCH, 0], [0, 0], [100, 0], [0, 20]])
    # robot pair at 22.4 mm: alpha-beta and beta-beta (same heights, reaches suffice);
    # alpha arms (10.6 + 10.6 < 22.4) and the bodies cannot meet; the fiducial 20 mm from
    # robot 0 only meets its beta arm (23.6 + 1), robot 1 (30 mm away) not at all
    assert scene.groups.tolist() == [[0, 1], [1, 3]]
    assert [scene.pair_ids(g) for g in range(2)] == [("robot", 1, 0), ("fiducial", 0, 7)]
    rows = np.column_stack([scene.lp_oa, scene.lp_ka, scene.lp_ob, scene.lp_kb,
                            scene.lp_group]).tolist()
    assert rows == [[0, ALPHA, 1, BETA, 0], [0, BETA, 1, ALPHA, 0], [0, BETA, 1, BETA, 0],
                    [1, BETA, 3, FID, 1]]
    assert scene.n_link_pairs == 4
    # a gap of 2 mm lets the alpha arms count too (21.2 + 2 >= 22.4)
    wide = Scene(static([[0, 180]] * 3, ids=(1, 0, 2)), layout(), MODELS, 2.0)
    kinds = {(int(a), int(b)) for a, b, g in zip(wide.lp_ka, wide.lp_kb, wide.lp_group)
             if g == 0}
    assert kinds == {(ALPHA, ALPHA), (ALPHA, BETA), (BETA, ALPHA), (BETA, BETA)}


def test_link_speeds_are_speed_radii_times_slopes():
    traj = Trajectory.from_breakpoints([0, 1], [[0.0, 1.0, 2.0], [0.0, 2.0]],
                                       [[0.0, 90.0, 90.0], [180.0, 180.0]],
                                       [[0.0, 0.5, 2.0], [0.0, 2.0]],
                                       [[0.0, 45.0, 45.0], [180.0, 180.0]])
    scene = Scene(traj, layout(), MODELS, 0.0)
    pa, ta, _, ra = axis_csr(traj, 0)
    pb, tb, _, rb = axis_csr(traj, 1)
    vglob, vmean = scene.link_speeds(MODELS, (pa, ta, ra), (pb, tb, rb), 2.0)
    q = math.pi / 2                                   # 90 deg/s on both axes
    np.testing.assert_allclose(vglob[0], MODELS.rad_alpha * q + MODELS.rad_beta * q)
    # mean over the 2 s span: 90 deg and 45 deg of travel
    np.testing.assert_allclose(vmean[0], (MODELS.rad_alpha * q + MODELS.rad_beta * q / 2) / 2)
    assert vglob[0, BODY] == 0.0 and vglob[0, BETA] > vglob[0, ALPHA] > 0.0
    assert not vglob[1:].any() and not vmean[1:].any()    # parked robot, fiducial
    assert not scene.link_speeds(MODELS, (pa, ta, ra), (pb, tb, rb), 0.0)[1].any()


def test_a_robot_listed_twice_is_refused():
    with pytest.raises(TrajectoryError, match="robot 0: appears more than once"):
        Scene(static([[0, 180]] * 2, ids=(0, 0)), layout(), MODELS, 0.0)


def test_candidate_link_pairs_of_a_whole_array_are_those_of_can_touch():
    # the 500-robot SDSS-V layout with its fiducials, bases at every distance: the
    # vectorised candidate table equals the pair-by-pair rule of LinkModels.link_pairs
    from rfp_twin.models.layout import layout_by_name
    from rfp_twin.validation.mesh3d.links import FIDUCIAL_KINDS, ROBOT_KINDS

    lay = layout_by_name("sdss-v-fps", PITCH)
    ids = np.asarray(lay.robot_ids)
    scene = Scene(static([[0, 180]] * len(ids), ids=tuple(ids.tolist())), lay, MODELS, 0.3)
    xy = np.column_stack([scene.obj_x, scene.obj_y])
    n_r = len(ids)
    rows, groups = [], []
    for i in range(n_r):
        for j in range(i + 1, len(xy)):
            d = float(np.hypot(*(xy[i] - xy[j])))
            kinds = MODELS.link_pairs(ROBOT_KINDS, ROBOT_KINDS if j < n_r else FIDUCIAL_KINDS,
                                      d, 0.3)
            if kinds:
                rows += [(i, ka, j, kb) for ka, kb in kinds]
                groups.append((i, j))
    got = sorted(zip(scene.lp_oa.tolist(), scene.lp_ka.tolist(), scene.lp_ob.tolist(),
                     scene.lp_kb.tolist()))
    assert got == sorted(rows) and len(rows) > 1000
    assert sorted(map(tuple, scene.groups.tolist())) == sorted(groups)
    # each link pair's group is the pair of its two objects
    assert np.array_equal(scene.groups[scene.lp_group], np.column_stack([scene.lp_oa,
                                                                         scene.lp_ob]))
