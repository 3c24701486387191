"""Coverage of the focal plane by the fibers: how much of it 1, 2, 3 fibers reach.

Units: mm, mm^2. :func:`measure_coverage` grids the focal plane (the convex hull of the
robot bases) and counts, per cell, the robots whose patrol annulus holds it; the
result is a frozen :class:`Coverage` (``to_dict()`` for JSON) with per-raft
instrumented areas for raft layouts. :func:`write_coverage_png` draws its multiplicity
map (matplotlib, loaded on first use). Modules:

- :mod:`rfp_twin.models.coverage.measure`: the grid, its numba kernels and the results
- :mod:`rfp_twin.models.coverage.maps`: the PNG map
"""
from rfp_twin.models.coverage.maps import write_coverage_png
from rfp_twin.models.coverage.measure import (FOCAL_PLANE, Coverage, CoverageMap, RaftCoverage,
                                              measure_coverage)

__all__ = ["FOCAL_PLANE", "Coverage", "CoverageMap", "RaftCoverage", "measure_coverage",
           "write_coverage_png"]
