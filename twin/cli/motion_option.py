"""What `validate`, `simulate`, `render` and `record` replay: a run folder or a trajectory file.

A run folder (written by ``rfp-twin plan``) carries its own spec and layout
(:func:`rfp_twin.twin.run_dir.load_run`). A trajectory file (jaeger / kaiju JSON,
:mod:`rfp_twin.twin.trajectory_file`) needs the instrument: ``--layout sdss-v-apo |
sdss-v-lco | ...`` or ``--calibration DIR``, and a robot spec (``--preset``, default
:data:`FILE_PRESET`, the collision rule SDSS-V runs in production). Each command calls
:func:`load_motion` with its arguments and gets the same four things either way.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from rfp_twin.models.errors import LayoutError, RfpError, TrajectoryError
from rfp_twin.models.options import option

#: Robot spec a trajectory file is read with unless ``--preset`` says otherwise.
FILE_PRESET = "sdss-v-production"

SOURCE_HELP = ("Run folder written by `rfp-twin plan`, or a jaeger / kaiju trajectory JSON "
               "({positioner_id: {\"alpha\": [[deg, s], ...], \"beta\": [[deg, s], ...]}}, or "
               "jaeger's dump with a \"trajectory\" key) with --layout or --calibration.")
FILE_LAYOUT_HELP = ("Instrument of a trajectory file: sdss-v-apo | sdss-v-lco | sdss-v-curved | "
                    "sdss-v-fps | hex:N | CSV (not with a run folder, which has its own).")
FILE_CALIBRATION_HELP = ("Calibration folder (wokCoords.csv, positionerTable.csv, "
                         "fiducialCoords.csv) of a trajectory file's instrument, instead of "
                         "--layout.")
FILE_PRESET_HELP = (f"Robot preset or TOML of a trajectory file [default: {FILE_PRESET}, "
                    "SDSS-V's production collision rule] (not with a run folder).")
ANGLES_HELP = ("Angles of a trajectory file: encoder (what the firmware is sent; model = "
               "encoder + each robot's alphaOffset / betaOffset) | model.")


@dataclass(frozen=True)
class MotionOptions:
    """The options that say how to read a trajectory file (ignored for a run folder,
    where giving one is an error); commands take them through
    :func:`rfp_twin.twin.cli.options.with_options`."""

    layout: str | None = option(None, FILE_LAYOUT_HELP)
    calibration: Path | None = option(None, FILE_CALIBRATION_HELP)
    preset: str | None = option(None, FILE_PRESET_HELP)
    angles: str = option("encoder", ANGLES_HELP, choices=("encoder", "model"))


def is_trajectory_file(source: Path) -> bool:
    """True when ``source`` names a file (a trajectory file), False for a run folder."""
    return Path(source).is_file()


def load_motion(source: Path, options: MotionOptions = MotionOptions(), to_fold: bool = False):
    """``(spec, layout, trajectory, summary)`` of a run folder or a trajectory file.

    For a file, ``summary`` holds :meth:`rfp_twin.twin.trajectory_file.TrajectoryFile.summary`
    and ``"spec"``, ``"layout"``; ``to_fold`` plays the file backwards (as a run folder's
    ``trajectories_to_fold.json``)."""
    from rfp_twin.twin.run_dir import load_run

    source = Path(source)
    if not is_trajectory_file(source):
        given = [f"--{k}" for k, v in (("layout", options.layout),
                                        ("calibration", options.calibration),
                                        ("preset", options.preset)) if v is not None]
        if given and source.is_dir():
            raise RfpError(f"{source}: {given[0]} applies to a trajectory file; allowed: a run "
                           "folder alone (it holds its own spec and layout)")
        if not source.exists() and source.suffix.lower() == ".json":
            raise TrajectoryError(f"{source}: trajectory file not found; allowed: a trajectory "
                                  "JSON file with --layout or --calibration, or a run folder")
        return load_run(source, to_fold=to_fold)
    return _load_file(source, options, to_fold)


def _load_file(path: Path, options: MotionOptions, to_fold: bool):
    from rfp_twin.models.layout import layout_by_name
    from rfp_twin.models.robot import load_spec
    from rfp_twin.twin.cli.layout_option import chosen_layout
    from rfp_twin.twin.trajectory_file import read_trajectory_file

    if options.layout is None and options.calibration is None:
        raise LayoutError(f"{path}: a trajectory file needs its instrument; allowed: --layout "
                          "sdss-v-apo | sdss-v-lco | ... or --calibration DIR")
    spec = load_spec(options.preset or FILE_PRESET)
    name = chosen_layout(options.layout, options.calibration, spec)
    layout = layout_by_name(name, spec.pitch_mm)
    read = read_trajectory_file(path, spec, layout, options.angles)
    traj = read.trajectory.reversed() if to_fold else read.trajectory
    summary = {"spec": spec.source, "layout": name, **read.summary()}
    return spec, layout, traj, summary
