"""A layout from its name, as the command line gives it.

Names: ``sdss-v-fps`` (the SDSS-V design focal plane: 500 robots, 60 fiducials), the
calibrated instruments ``sdss-v-apo``, ``sdss-v-lco``, ``sdss-v-curved``
(:mod:`rfp_twin.models.instrument`) or a calibration folder,
``sdss-v-547`` (the all-robot 13-ring grid of Sayres 2021 Sect. 3.2), ``hex:N`` (a
centred hex grid of N positions: 7, 19, 37, 61, 91, ...), ``raft:N`` / ``raft:R=600`` (N
triangular rafts of 63 robots, Spec-S5, or every raft inside a radius in mm:
:mod:`rfp_twin.models.layout.rafts`), ``miradas-N`` (N MIRADAS probe arms on the bench of
the ``miradas-probe`` preset, :mod:`rfp_twin.models.kinds`) or the path of a layout CSV.
Pitch in mm; fiducial ids turn positions of a generated grid into fiducials. A bad name
raises :class:`rfp_twin.models.errors.LayoutError` (an unknown fiducial id
:class:`rfp_twin.models.errors.UnknownRobotError`) with a one-line message.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.layout.checks import check_size
from rfp_twin.models.layout.core import Layout


#: Layouts that are not generated grids: the design focal plane and the calibrated instruments.
FIXED_LAYOUTS = ("sdss-v-fps", "sdss-v-apo", "sdss-v-lco", "sdss-v-curved")


def default_layout_name(spec) -> str:
    """The layout a robot spec plans on by default: ``sdss-v-fps`` for the SDSS-V
    presets, ``hex:547`` otherwise."""
    return "sdss-v-fps" if spec.name.startswith("sdss-v") else "hex:547"


def layout_by_name(name: str, pitch_mm: float, fiducial_ids: tuple[int, ...] = ()) -> Layout:
    """Layout from a name: ``sdss-v-fps`` (the 500-robot design focal plane),
    ``sdss-v-apo`` / ``sdss-v-lco`` / ``sdss-v-curved`` (calibrated instruments, or the path
    of a calibration folder: :func:`rfp_twin.models.instrument.instrument_layout`), ``sdss-v-547``
    (the paper's all-robot grid), ``hex:N`` (a hex grid of N positions: 7, 19, 37, 61, 91,
    ...), ``raft:N`` / ``raft:R=MM`` / ``raft:N,robots=75,side=80,gap=2,pitch=6.2`` (rafts:
    :func:`rfp_twin.models.layout.rafts.raft_from_name`), or a CSV path.

    Parameters
    ----------
    name : str
    pitch_mm : float
        Grid pitch of generated grids, mm; a CSV is read with a minimum base separation
        of ``min(1, pitch_mm / 4)`` mm.
    fiducial_ids : tuple of int
        Positions of a generated grid (``sdss-v-547``, ``hex:N``) that are fiducials.

    Raises
    ------
    LayoutError
        Unknown name, ``hex:N`` with a bad N, fiducial ids on a layout that is not
        generated, or a bad CSV.
    UnknownRobotError
        A fiducial id that is not a position of the grid.
    """
    if fiducial_ids and (name in FIXED_LAYOUTS or not (name == "sdss-v-547" or name.startswith("hex:"))):
        raise LayoutError(f"--fiducials applies to generated grids (sdss-v-547, hex:N), not {name!r}; "
                          "a CSV layout says each position's kind itself")
    if name == "sdss-v-fps":
        return Layout.sdss_v_fps()
    from rfp_twin.models.instrument.layout import INSTRUMENTS, instrument_layout
    if name in INSTRUMENTS or Path(name).is_dir():
        return instrument_layout(name)
    if name == "sdss-v-547":
        return Layout.sdss_v_grid(pitch_mm=pitch_mm, fiducial_ids=fiducial_ids)
    if name.startswith("hex:"):
        try:
            n = int(name[4:])
        except ValueError:
            raise LayoutError(f"layout {name!r}: 'hex:N' needs an integer N") from None
        check_size(n, f"layout {name!r}")
        grid = Layout.hex_grid_positions(n, pitch_mm)
        if fiducial_ids:
            grid.robot_indices(list(fiducial_ids))  # names an unknown id
            kinds = grid.kinds.copy()
            kinds[np.isin(grid.ids, fiducial_ids)] = "fiducial"
            grid = Layout(grid.ids, grid.xy, kinds, name=grid.name)
        return grid
    if name.startswith("miradas-"):
        from rfp_twin.models.kinds.bench import probe_bench_layout  # probe arms, Sabater 2018
        return probe_bench_layout(name)
    if name == "raft" or name.startswith("raft:"):
        from rfp_twin.models.layout.rafts import raft_from_name  # raft:N, raft:R=600, ...
        return raft_from_name(name, pitch_mm)
    path = Path(name)
    if path.suffix.lower() != ".csv" and not path.exists():
        raise LayoutError(f"layout {name!r}: allowed: {', '.join(FIXED_LAYOUTS)}, sdss-v-547, "
                          "hex:N, a CSV file, a calibration folder, raft:N or miradas-N")
    return Layout.from_csv(path, min_separation_mm=min(1.0, pitch_mm / 4))
