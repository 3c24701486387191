"""The real SDSS-V instruments from their calibration files.

- :mod:`rfp_twin.models.instrument.tables`: CSV tables with file/row/field errors
- :mod:`rfp_twin.models.instrument.calibration`: a calibration folder, read and checked
- :mod:`rfp_twin.models.instrument.layout`: the planning layout of an instrument (per-robot
  columns, production obstacles) and the built-in instruments ``sdss-v-apo``,
  ``sdss-v-lco``, ``sdss-v-curved``
"""
from rfp_twin.models.instrument.calibration import Calibration, read_calibration
from rfp_twin.models.instrument.layout import (INSTRUMENTS, calibration_folder, instrument_layout,
                                              plane_to_wok, wok_to_plane)
from rfp_twin.models.instrument.tables import CalibrationError

__all__ = ["INSTRUMENTS", "Calibration", "CalibrationError", "calibration_folder",
           "instrument_layout", "plane_to_wok", "read_calibration", "wok_to_plane"]
