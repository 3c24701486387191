"""The yield axes of a design study, declared once (:func:`rfp_twin.models.options.option`).

A grid point with a ``catalogue`` plans a mock target catalogue through the plannable
loop (:mod:`rfp_twin.twin.studies.yield_trial`) instead of random per-robot targets. The
study file's help texts (:data:`rfp_twin.twin.studies.spec.GRID_KEYS`), the parser's range
checks and the trial all read the declarations of :class:`YieldOptions`:

- grid keys (:data:`YIELD_GRID_KEYS`): ``catalogue`` (uniform | clustered), ``density``
  and ``density_unit`` (targets per robot, per patrol area or per deg^2),
  ``priority_levels``, ``assign_rounds``;
- the ``[study]`` key ``exposure_s``: the exposure time that targets per hour adds to the
  reconfiguration time (it changes no trial, so it is not a grid key).

Units: s; densities as their unit says.
"""
from __future__ import annotations

from dataclasses import dataclass

from rfp_twin.models.catalogue import DENSITY_UNITS, PROCESSES
from rfp_twin.models.options import check_options, option, option_info

#: Default assign -> plan rounds: the plan command's (``rfp_twin.twin.plannable.MAX_ROUNDS``;
#: not imported, so that reading a study file loads no planner).
MAX_ROUNDS = 5

__all__ = ["YieldOptions", "YIELD_GRID_KEYS", "YIELD_STUDY_KEYS", "yield_help", "mock_text"]


@dataclass(frozen=True)
class YieldOptions:
    """The catalogue of a yield trial and how it is counted (module docstring)."""

    catalogue: str | None = option(
        None, "Mock science catalogue of the trial: uniform (Poisson) or clustered (Thomas "
        "process, clusters of 10 targets, sigma = 2 reaches); unset: random per-robot targets",
        choices=PROCESSES, optional=True)
    density: float = option(1.0, "Science target density, in density_unit", lo=1e-3, hi=1e6)
    density_unit: str = option(
        "robot", "Unit of density: robot (targets per hexagonal cell sqrt(3)/2 pitch^2), "
        "patrol (per robot patrol area) or deg2 (per square degree: SDSS-V layouts only)",
        choices=DENSITY_UNITS)
    priority_levels: int = option(
        1, "Science priorities drawn uniformly from 1..K; completeness is reported per level",
        lo=1, hi=1000)
    assign_rounds: int = option(MAX_ROUNDS, "Assign -> plan rounds at most (the plannable "
                                "loop)", lo=1, hi=50)
    exposure_s: float = option(900.0, "Exposure time per pointing, added to the "
                               "reconfiguration time for targets per hour", unit="s",
                               lo=0.0, hi=1e5)

    def __post_init__(self) -> None:
        check_options(self)


#: Grid keys of the yield axes (in a point's identity only when ``catalogue`` is set).
YIELD_GRID_KEYS = ("catalogue", "density", "density_unit", "priority_levels", "assign_rounds")
#: [study] keys declared here.
YIELD_STUDY_KEYS = ("exposure_s",)


def yield_help(name: str) -> str:
    """The study file's help text of a yield key: the declaration's, with range or choices."""
    return option_info(YieldOptions, name).describe()


def mock_text(catalogue: str, density: float, unit: str, levels: int) -> str:
    """The ``--catalogue`` text of a yield point (:mod:`rfp_twin.twin.catalogue_source`):
    ``rfp-twin plan --catalogue TEXT --seed SEED`` draws the trial's catalogue again."""
    text = f"mock:{catalogue}:{density:g}/{unit}"
    return text + (f",levels={int(levels)}" if levels > 1 else "")
