"""Layouts: where the robot and fiducial bases sit on the focal plane (mm).

:class:`Layout` holds ids ``(n,)``, base centres ``xy`` ``(n, 2)`` mm and kinds
(``robot`` / ``fiducial``). Modules:

- :mod:`rfp_twin.models.layout.core`: the :class:`Layout` type, its checks and generated grids
- :mod:`rfp_twin.models.layout.grids`: centred hex lattice arithmetic (counts, coordinates)
- :mod:`rfp_twin.models.layout.csv_io`: CSV read/write
- :mod:`rfp_twin.models.layout.neighbours`: neighbour lists (Sayres 2021 Eq. 4)
- :mod:`rfp_twin.models.layout.by_name`: a layout from a name (``sdss-v-fps``, ``hex:N``, a CSV)
"""
from rfp_twin.models.layout.by_name import default_layout_name, layout_by_name
from rfp_twin.models.layout.checks import KINDS
from rfp_twin.models.layout.core import SDSS_V_FPS_CSV, Layout
from rfp_twin.models.layout.csv_io import REQUIRED_COLUMNS
from rfp_twin.models.layout.grids import (SDSS_V_RINGS, hex_axial, hex_count, hex_rings, hex_xy,
                                 nearest_hex_counts)
from rfp_twin.models.layout.neighbours import REACH_TOL_MM


__all__ = ["KINDS", "REACH_TOL_MM", "REQUIRED_COLUMNS", "SDSS_V_FPS_CSV",
           "SDSS_V_RINGS", "Layout", "hex_axial", "hex_count", "hex_rings", "hex_xy",
           "default_layout_name", "layout_by_name", "nearest_hex_counts"]
