"""The --layout / --calibration options every command that plans or simulates shares."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

from rfp_twin.models.errors import LayoutError

LAYOUT_HELP = ("sdss-v-fps (design focal plane) | sdss-v-apo | sdss-v-lco (the calibrated SDSS-V "
               "instruments) | sdss-v-curved (curved wok, CMM) | sdss-v-547 | hex:N | raft:N (N "
               "Spec-S5 rafts of 63 robots; raft:R=MM within a radius) | CSV file "
               "[default: sdss-v-fps for SDSS-V presets, hex:547 otherwise]")
CALIBRATION_HELP = ("Folder of SDSS-V calibration files (wokCoords.csv, positionerTable.csv, "
                    "fiducialCoords.csv; e.g. a newer fps_calibrations release) to plan on "
                    "instead of --layout.")


def chosen_layout(layout: Optional[str], calibration: Optional[Path], spec) -> str:
    """The layout name to load: ``--calibration`` (a folder) or ``--layout`` or the spec's
    default; both given is an error."""
    from rfp_twin.models.layout import default_layout_name

    if calibration is not None:
        if layout is not None:
            raise LayoutError(f"--layout {layout!r} and --calibration {str(calibration)!r}; "
                              "allowed: one of them")
        if not calibration.is_dir():
            raise LayoutError(f"--calibration {str(calibration)!r} is not a folder; allowed: a "
                              "folder with wokCoords.csv, positionerTable.csv, fiducialCoords.csv")
        return str(calibration)
    return layout or default_layout_name(spec)
