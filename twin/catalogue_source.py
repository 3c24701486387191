"""A catalogue for an array from what a user types: a file, or ``mock:...``.

``--catalogue FILE`` reads a CSV or Parquet catalogue (:func:`rfp_twin.models.catalogue.read_catalogue`).
``--catalogue mock:PROCESS:DENSITY[/UNIT][,key=value...]`` draws one (seeded):

- PROCESS: ``uniform`` (Poisson) or ``clustered`` (Thomas process);
- DENSITY and UNIT: science targets per ``deg2`` (needs a telescope's plate scale; the
  default unit when the array has one), per robot ``patrol`` area (the default
  otherwise) or per ``robot`` (per hexagonal cell of the array's pitch,
  :func:`robot_area_mm2`: arrays of any pitch and reach compare in this unit);
- keys: ``sky=D`` and ``standard=D`` (calibration targets, same unit, priority
  :data:`CALIBRATION_PRIORITY`: taken for the quotas and where no science target
  competes), ``levels=K``
  (science priorities drawn from 1..K), ``fiber=boss|apogee|any`` (science targets;
  calibration targets accept any fiber), ``children=C`` and ``sigma=MM`` (clusters),
  ``exposures=N`` (exposures each science target needs: passes of one field).

The mock field is the telescope's field (a disc of its field radius about the plane's
origin) or, without a telescope, the disc about the robot bases' centre that covers
every patrol area.
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from rfp_twin.models.catalogue import (TELESCOPES, Catalogue, Disc, Telescope, density_per_mm2,
                                       mock_catalogue, read_catalogue)
from rfp_twin.models.catalogue.catalogue import MAX_EXPOSURES, bad_exposures
from rfp_twin.models.errors import CatalogueError

MOCK_PREFIX = "mock:"
#: Priority of mock sky and standard targets: far below a science target's (>= 1), above
#: parking (0).
CALIBRATION_PRIORITY = 0.001
MOCK_KEYS = ("sky", "standard", "levels", "fiber", "children", "sigma", "exposures")
TELESCOPE_CHOICES = ("auto", "apo", "lco", "none")


def telescope_for(choice: str, layout_name: str, spec_name: str) -> Telescope | None:
    """The telescope of ``--telescope CHOICE`` (auto: LCO for ``sdss-v-lco``, APO for the
    other SDSS-V layouts and presets, none for other arrays)."""
    if choice not in TELESCOPE_CHOICES:
        raise CatalogueError(f"--telescope {choice!r}; allowed: {', '.join(TELESCOPE_CHOICES)}")
    if choice == "none":
        return None
    if choice != "auto":
        return TELESCOPES[choice]
    name = str(layout_name).lower()
    if "lco" in name:
        return TELESCOPES["lco"]
    if name.startswith("sdss-v") or spec_name.startswith("sdss-v"):
        return TELESCOPES["apo"]
    return None


def parse_centre(text: str | None) -> tuple[float, float] | None:
    """``"RA,DEC"`` deg -> (ra, dec); None stays None."""
    if text is None:
        return None
    try:
        ra, dec = (float(v) for v in text.split(","))
    except ValueError:
        raise CatalogueError(f"--field-centre {text!r}; allowed: RA,DEC in deg") from None
    return ra, dec


def _mock_disc(geom, telescope: Telescope | None) -> Disc:
    if telescope is not None:
        return Disc((0.0, 0.0), telescope.field_radius_mm)
    c = geom.base_xy.mean(axis=0)
    r = float(np.hypot(*(geom.base_xy - c).T).max(initial=0.0)) + geom.spec.reach_mm
    return Disc((float(c[0]), float(c[1])), r)


def _patrol_area(spec) -> float:
    lo, hi = spec.patrol_annulus_mm
    return float(np.pi * (hi * hi - lo * lo))


def robot_area_mm2(spec) -> float:
    """Focal-plane area of one robot, mm^2: the hexagonal cell sqrt(3)/2 pitch^2 of the
    spec's pitch (the unit ``/robot`` of mock densities)."""
    return float(np.sqrt(3.0) / 2.0 * spec.pitch_mm ** 2)


def parse_mock(text: str) -> tuple[str, float, str | None, dict[str, str]]:
    """``mock:PROCESS:DENSITY[/UNIT][,k=v...]`` -> (process, density, unit or None, keys)."""
    body = text[len(MOCK_PREFIX):]
    head, *extras = body.split(",")
    parts = head.split(":")
    allowed = ("allowed: mock:uniform|clustered:DENSITY[/deg2|/patrol|/robot][,sky=D]"
               "[,standard=D][,levels=K][,fiber=boss|apogee|any][,children=C][,sigma=MM]"
               "[,exposures=N]")
    if len(parts) != 2:
        raise CatalogueError(f"--catalogue {text!r}; {allowed}")
    process, dens = parts
    unit = None
    if "/" in dens:
        dens, unit = dens.split("/", 1)
    try:
        density = float(dens)
    except ValueError:
        raise CatalogueError(f"--catalogue {text!r}: density {dens!r}; {allowed}") from None
    keys = {}
    for item in extras:
        k, _, v = item.partition("=")
        if k not in MOCK_KEYS or not v:
            raise CatalogueError(f"--catalogue {text!r}: {item!r}; {allowed}")
        keys[k] = v
    return process, density, unit, keys


def mock_from_text(text: str, geom, telescope: Telescope | None,
                   rng: np.random.Generator) -> Catalogue:
    """The mock catalogue of a ``mock:...`` text (module docstring) for ``geom``."""
    process, density, unit, keys = parse_mock(text)
    unit = unit or ("deg2" if telescope is not None else "patrol")
    scale = telescope.plate_scale_mm_per_deg if telescope is not None else None
    area = _patrol_area(geom.spec)

    def per_mm2(value: float) -> float:
        return density_per_mm2(value, unit, plate_scale_mm_per_deg=scale, patrol_area_mm2=area,
                               robot_area_mm2=robot_area_mm2(geom.spec))

    def number(key: str, default: float) -> float:
        try:
            value = float(keys.get(key, default))
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise CatalogueError(f"--catalogue {text!r}: {key}={keys[key]!r}; allowed: a "
                                 "finite number")
        return value

    disc = _mock_disc(geom, telescope)
    levels = number("levels", 1)
    if levels != int(levels):
        raise CatalogueError(f"--catalogue {text!r}: levels={keys['levels']!r}; allowed: an "
                             "integer in [1, 1000]")
    sigma = number("sigma", 2.0 * geom.spec.reach_mm)
    exposures = number("exposures", 1)
    if bad_exposures([exposures]).size:
        raise CatalogueError(f"--catalogue {text!r}: exposures={keys['exposures']!r}; allowed: "
                             f"an integer in [1, {MAX_EXPOSURES}]")
    science = mock_catalogue(rng, disc, per_mm2(density), process=process, kind="science",
                             fiber=keys.get("fiber", "boss"), priority_levels=int(levels),
                             children=number("children", 10.0), sigma_mm=sigma, source=text)
    parts = [replace(science, exposures=np.full(science.n_targets, int(exposures)))]
    for kind in ("sky", "standard"):
        if kind in keys:
            d = number(kind, 0.0)
            parts.append(mock_catalogue(rng, disc, per_mm2(d), process="uniform", kind=kind,
                                        fiber="any", priority=CALIBRATION_PRIORITY,
                                        first_id=sum(p.n_targets for p in parts),
                                        source=text))
    return Catalogue.concat(parts, source=text) if len(parts) > 1 else parts[0]


def load_catalogue(text: str, geom, *, telescope: Telescope | None,
                   field_centre: tuple[float, float] | None, seed: int) -> Catalogue:
    """The catalogue of ``--catalogue TEXT`` for ``geom`` (module docstring)."""
    if text.startswith(MOCK_PREFIX):
        return mock_from_text(text, geom, telescope, np.random.default_rng(seed))
    wok = "hole_id" in geom.layout.extra
    return read_catalogue(Path(text), field_centre=field_centre,
                          plate_scale_mm_per_deg=(telescope.plate_scale_mm_per_deg
                                                  if telescope is not None else None),
                          wok_frame=wok)
