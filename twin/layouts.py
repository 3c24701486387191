"""Layouts by name, as the CLI and the studies give them.

``sdss-v-fps`` (the real 500-robot instrument), ``sdss-v-547`` (the paper's all-robot
grid), ``hex:N`` (a hex grid of N positions: 7, 19, 37, 61, 91, ...) or a CSV path.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from models.errors import LayoutError
from models.layout import Layout
from models.robot import RobotSpec


def default_layout_name(spec: RobotSpec) -> str:
    """``sdss-v-fps`` for the SDSS-V presets, ``hex:547`` otherwise."""
    return "sdss-v-fps" if spec.name.startswith("sdss-v") else "hex:547"


def resolve_layout(name: str, pitch_mm: float, fiducial_ids: tuple[int, ...] = ()) -> Layout:
    """Layout from a name (see the module docstring); ``pitch_mm`` spaces generated grids.
    ``fiducial_ids`` turns positions of a generated grid into fiducials."""
    if fiducial_ids and (name == "sdss-v-fps" or not (name == "sdss-v-547" or name.startswith("hex:"))):
        raise LayoutError(f"--fiducials applies to generated grids (sdss-v-547, hex:N), not {name!r}; "
                          "a CSV layout says each position's kind itself")
    if name == "sdss-v-fps":
        return Layout.sdss_v_fps()
    if name == "sdss-v-547":
        return Layout.sdss_v_grid(pitch_mm=pitch_mm, fiducial_ids=fiducial_ids)
    if name.startswith("hex:"):
        try:
            n = int(name[4:])
        except ValueError:
            raise LayoutError(f"layout {name!r}: 'hex:N' needs an integer N") from None
        grid = Layout.hex_grid_positions(n, pitch_mm)
        if fiducial_ids:
            grid.robot_indices(list(fiducial_ids))  # names an unknown id
            kinds = grid.kinds.copy()
            kinds[np.isin(grid.ids, fiducial_ids)] = "fiducial"
            grid = Layout(grid.ids, grid.xy, kinds, name=grid.name)
        return grid
    path = Path(name)
    if path.suffix.lower() != ".csv" and not path.exists():
        raise LayoutError(f"layout {name!r}: allowed: sdss-v-fps, sdss-v-547, hex:N or a CSV file")
    return Layout.from_csv(path, min_separation_mm=min(1.0, pitch_mm / 4))
