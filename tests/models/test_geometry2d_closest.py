"""segment_closest: the closest points that the Markov energy gradient relies on."""
from __future__ import annotations

import numpy as np

from models.geometry2d import segment_closest, segment_distance


def test_closest_points_realise_the_distance():
    rng = np.random.default_rng(5)
    for _ in range(500):
        a, b, c, d = rng.uniform(-10, 10, size=(4, 2))
        dist, s, px, py, qx, qy = segment_closest(*a, *b, *c, *d)
        ref = segment_distance(*a, *b, *c, *d)
        if ref == 0.0:
            continue  # crossing: not used by the planner
        assert abs(dist - ref) < 1e-9
        np.testing.assert_allclose([px, py], a + s * (b - a), atol=1e-9)
        assert 0.0 <= s <= 1.0
        assert abs(np.hypot(px - qx, py - qy) - dist) < 1e-9
