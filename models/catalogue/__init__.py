"""Target catalogues: the data type, files, sky projection and mock catalogues.

- :mod:`rfp_twin.models.catalogue.catalogue`: :class:`Catalogue` (ids, planning-frame
  positions mm, priorities, kinds science / sky / standard, fibers boss / apogee / any)
- :mod:`rfp_twin.models.catalogue.read`: :func:`read_catalogue` (CSV / Parquet, errors
  naming file, row and field)
- :mod:`rfp_twin.models.catalogue.sky`: :func:`sky_to_focal` (gnomonic projection and
  plate scale), :data:`TELESCOPES` (SDSS-V APO and LCO)
- :mod:`rfp_twin.models.catalogue.mock`: :func:`mock_catalogue` (uniform Poisson or
  clustered Thomas process), :func:`density_per_mm2`
"""
from rfp_twin.models.catalogue.catalogue import (ANY, APOGEE, BOSS, KINDS, SCIENCE, SKY,
                                                 STANDARD, TARGET_FIBERS, Catalogue)
from rfp_twin.models.catalogue.mock import (DENSITY_UNITS, MAX_MOCK_TARGETS, PROCESSES, Disc,
                                            density_per_mm2, mock_catalogue)
from rfp_twin.models.catalogue.read import read_catalogue
from rfp_twin.models.catalogue.sky import TELESCOPES, Telescope, check_field_centre, sky_to_focal

__all__ = ["ANY", "APOGEE", "BOSS", "DENSITY_UNITS", "KINDS", "MAX_MOCK_TARGETS", "PROCESSES",
           "SCIENCE", "SKY", "STANDARD", "TARGET_FIBERS", "TELESCOPES", "Catalogue", "Disc",
           "Telescope", "check_field_centre", "density_per_mm2", "mock_catalogue",
           "read_catalogue", "sky_to_focal"]
