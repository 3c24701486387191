"""The roadmap of one arm (Sabater 2018 Sect. 6.1): planners/roadmap/graph.py."""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.roadmap import RoadmapSettings, build_roadmap, edge_time
from tests.planners.roadmap.toys import RNG, plane_arm


def disk(q):
    """The zone of avoidance of these tests: a disk of radius 2 around (5, 5)."""
    return np.hypot(q[:, 0] - 5.0, q[:, 1] - 5.0) < 2.0


def test_roadmap_vertices_edges_and_paths_cheapest_first():
    arm = plane_arm([1.0, 1.0], [9.0, 9.0], forbidden=disk, t_static=0.0)
    rm = build_roadmap(arm, RoadmapSettings(grid=(6, 6), n_random_edges=5), RNG(1))
    assert not disk(rm.vertices).any()
    assert len(rm.vertices) == 36 - 4            # the 6 x 6 grid minus the ZoA
    used = rm.edges.ravel()
    assert len(used) == len(set(used.tolist()))  # a vertex is in one random edge at most
    assert np.all(np.diff(rm.est_times) >= 0)
    assert rm.est_times[0] == edge_time(arm.start, arm.goal, arm.vmax) == 8.0
    counts = sorted({len(p) for p in rm.paths})
    assert counts == [2, 3, 4]                   # direct, one vertex, a random edge


def test_edge_time_is_the_slowest_joint():
    """Sabater 2018 Eq. 5: max_k |dtheta_k| / vmax_k."""
    assert edge_time(np.array([0.0, 0.0]), np.array([4.0, -3.0]), np.array([2.0, 0.5])) == 6.0


def test_corner_vertices_join_the_roadmap():
    """One joint first, then the other, and both at full speed until one is done."""
    arm = plane_arm([0.0, 0.0], [4.0, 10.0], t_static=0.0)
    plain = build_roadmap(arm, RoadmapSettings(grid=(1, 1), n_random_edges=0), RNG(0))
    corners = build_roadmap(arm, RoadmapSettings(grid=(1, 1), n_random_edges=0,
                                                 corner_vertices=True), RNG(0))
    rows = {tuple(r) for r in corners.vertices}
    assert {(4.0, 0.0), (0.0, 10.0)} <= rows     # axis corners
    assert {(4.0, 4.0), (0.0, 6.0)} <= rows      # speed corners
    assert not {(4.0, 0.0), (4.0, 4.0)} & {tuple(r) for r in plain.vertices}
    # Eq. 5 per path: a speed corner costs no more than the direct move (10), an axis
    # corner is the sum of its two single-joint moves (4 + 10); the grid vertex is (5, 5)
    est = {tuple(map(tuple, p)): t for p, t in zip(corners.paths, corners.est_times)}
    assert est[((0.0, 0.0), (4.0, 4.0), (4.0, 10.0))] == est[((0.0, 0.0), (4.0, 10.0))] == 10.0
    assert est[((0.0, 0.0), (4.0, 0.0), (4.0, 10.0))] == 14.0


def test_via_paths_are_added():
    arm = plane_arm([1.0, 1.0], [9.0, 9.0], t_static=0.0,
                    via=lambda s, g: [np.array([[1.0, 9.0]]), np.array([[9.0, 1.0], [9.0, 5.0]])])
    rm = build_roadmap(arm, RoadmapSettings(grid=(1, 1), n_random_edges=0), RNG(0))
    shapes = sorted(len(p) for p in rm.paths)
    assert shapes == [2, 3, 3, 4]                # direct, the grid vertex, two via paths
    want = np.array([[1.0, 1.0], [9.0, 1.0], [9.0, 5.0], [9.0, 9.0]])
    assert any(p.shape == want.shape and np.allclose(p, want) for p in rm.paths)
