"""The options several commands share, each declared once (help text, default, range).

:class:`ArrayOptions` is the array a command plans on (``plan``, ``assign``; ``unwind`` and
``explode`` take its layout, calibration and buffer), :class:`CatalogueOptions` how a
catalogue is assigned (``assign``, ``plan --catalogue``). Commands receive them through
:func:`rfp_twin.twin.cli.options.with_options`. The output folder and ``--force`` are
plain typer options built here (their default folder differs per command).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import typer

from rfp_twin.models.errors import LayoutError, TargetError
from rfp_twin.models.options import option
from rfp_twin.twin.cli.layout_option import CALIBRATION_HELP, LAYOUT_HELP, chosen_layout

PRESET_HELP = "Robot preset name or path to a robot TOML."
OUT_HELP = "Output folder (must not exist unless --force)."
FORCE_HELP = "Replace an existing output folder."


def out_option(default: Path, help: str = OUT_HELP):
    """``--out`` with the command's default folder."""
    return typer.Option(default, "--out", help=help)


def force_option():
    """``--force``: replace an existing output folder."""
    return typer.Option(False, help=FORCE_HELP)


def parse_ids(text: str, option_name: str) -> tuple[int, ...]:
    """``"1,2,3"`` -> (1, 2, 3); the error names the option."""
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise LayoutError(f"{option_name} {text!r}; allowed: comma-separated integer ids") from None


def parse_offline(items, fold_deg: tuple[float, float]) -> dict[int, tuple[float, float]]:
    """``ID`` (parked folded) or ``ID:ALPHA:BETA`` -> {id: (alpha, beta) deg}."""
    out: dict[int, tuple[float, float]] = {}
    for item in items:
        for part in filter(None, item.split(",")):
            bits = part.split(":")
            try:
                if len(bits) not in (1, 3):
                    raise ValueError
                rid = int(bits[0])
                ang = (float(bits[1]), float(bits[2])) if len(bits) == 3 else tuple(fold_deg)
            except ValueError:
                raise TargetError(f"--offline {part!r}; allowed: ID or ID:ALPHA:BETA") from None
            out[rid] = ang
    return out


@dataclass(frozen=True)
class ArrayOptions:
    """The array a command plans on: robot spec, layout, fiducials, buffer, offline robots."""

    preset: str = option("sdss-v", PRESET_HELP)
    layout: str | None = option(None, LAYOUT_HELP)
    calibration: Path | None = option(None, CALIBRATION_HELP)
    fiducials: str = option("", "Comma-separated position ids that are fiducials (generated "
                            "grids only)")
    buffer: float | None = option(None, "Collision buffer sigma_cb, mm [default: preset]")
    offline: tuple[str, ...] = option((), "Offline robot: ID (parked folded) or ID:ALPHA:BETA; "
                                      "it takes no target and the others clear its pose; "
                                      "repeat or comma-separate")

    def reconfiguration(self, options):
        """``(Reconfiguration, layout name, offline {id: (alpha, beta) deg})`` of this array
        planned with ``options`` (:class:`rfp_twin.twin.pipeline.PlanOptions`)."""
        from rfp_twin.models.robot import load_spec
        from rfp_twin.twin.pipeline import Reconfiguration

        spec = load_spec(self.preset)
        name = chosen_layout(self.layout, self.calibration, spec)
        still = parse_offline(self.offline, spec.fold_deg)
        rc = Reconfiguration.from_names(spec, name, buffer_mm=self.buffer,
                                        fiducial_ids=parse_ids(self.fiducials, "--fiducials"),
                                        options=options, offline=still)
        return rc, name, still


@dataclass(frozen=True)
class CatalogueOptions:
    """How a catalogue is read and assigned (``rfp-twin assign``, ``plan --catalogue``)."""

    telescope: str = option("auto", "Plate scale and field for deg^2 densities and ra/dec: "
                            "auto (SDSS-V layouts: apo, sdss-v-lco: lco) | apo (217.7358 "
                            "mm/deg, 1.5 deg) | lco (330.275 mm/deg, 1.1 deg) | none")
    field_centre: str | None = option(None, "RA,DEC of the field centre, deg (catalogues with "
                                      "ra_deg,dec_deg)")
    solver: str = option("auto", "auto (HiGHS up to 3000 robots, the heuristic above) | highs "
                         "| cpsat (exact) | greedy (greedy + local improvement)")
    arms: str = option("right", "Arm solutions that are candidates: right | both | left "
                       "(left-armed poses, beta in (180, 360), are much harder for the planner "
                       "to fold)")
    sky_quota: int = option(0, "Minimum sky fibers per region")
    standard_quota: int = option(0, "Minimum standard fibers per region")
    sectors: int = option(1, "Regions for the quotas: equal angular sectors about the "
                          "array's centre")
    parking: str = option("clear", "Pose of a robot without a target: clear (the fold or the "
                          "fold turned in alpha by k x 60 deg, chosen by the assigner to keep "
                          "a folded beta arm off a neighbour's target; the fold unless "
                          "another gains a target) | fold (always the fold)",
                          choices=("fold", "clear"))

    def settings(self, **changes):
        """:class:`rfp_twin.planners.assignment.AssignSettings` of these options (``changes``:
        its other fields)."""
        from rfp_twin.planners.assignment import AssignSettings, Quotas

        arms = ("right", "left") if self.arms == "both" else tuple(
            v for v in self.arms.split(",") if v)
        return AssignSettings(solver=self.solver, arms=arms, parking=self.parking,
                              quotas=Quotas(sky=self.sky_quota, standard=self.standard_quota,
                                            sectors=self.sectors), **changes)

    def load(self, source: str, geom, layout_name: str, spec_name: str, seed: int):
        """``(catalogue, telescope or None)``: ``source`` read (or drawn, for a mock, with
        ``seed``) for the array ``geom``."""
        from rfp_twin.twin.catalogue_source import load_catalogue, parse_centre, telescope_for

        tel = telescope_for(self.telescope, layout_name, spec_name)
        cat = load_catalogue(source, geom, telescope=tel,
                             field_centre=parse_centre(self.field_centre), seed=seed)
        return cat, tel
