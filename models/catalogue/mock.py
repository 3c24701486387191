"""Mock catalogues: uniform (Poisson) and clustered (Thomas / Neyman-Scott) targets in a disc.

Densities are in targets per mm^2 of the focal plane; :func:`density_per_mm2` converts
targets per deg^2 (with a plate scale), targets per robot patrol area (generic arrays
without a telescope) or targets per robot (per focal-plane area of one robot, e.g. the
hexagonal cell sqrt(3)/2 pitch^2 of a hex grid: the unit in which arrays of different
pitch and reach compare, since a robot takes at most one target). Every draw takes a ``numpy.random.Generator``: same generator
state, same catalogue.

- Uniform: the number of targets is Poisson(density x area), positions uniform by area.
- Thomas process (a Neyman-Scott cluster process): cluster centres are Poisson with
  density ``density / children``, each has Poisson(``children``) targets displaced by an
  isotropic Gaussian of ``sigma_mm`` per axis. Centres are drawn in the disc grown by
  4 sigma and targets outside the disc dropped, so the density is ``density`` inside.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfp_twin.models.catalogue.catalogue import KINDS, TARGET_FIBERS, Catalogue
from rfp_twin.models.errors import CatalogueError

#: Most targets a mock catalogue may hold (~40 bytes each: a 0.4 GB catalogue).
MAX_MOCK_TARGETS = 10_000_000
PROCESSES = ("uniform", "clustered")
DENSITY_UNITS = ("deg2", "patrol", "robot")


@dataclass(frozen=True)
class Disc:
    """A disc of the focal plane: centre (x, y) mm and radius mm."""

    centre: tuple[float, float]
    radius_mm: float

    @property
    def area_mm2(self) -> float:
        return float(np.pi * self.radius_mm ** 2)


def density_per_mm2(value: float, unit: str, *, plate_scale_mm_per_deg: float | None = None,
                    patrol_area_mm2: float | None = None,
                    robot_area_mm2: float | None = None) -> float:
    """Targets per mm^2 of ``value`` targets per deg^2 (``unit="deg2"``, with the plate scale
    in mm/deg), per robot patrol area (``unit="patrol"``, with that area in mm^2) or per
    robot (``unit="robot"``, with the focal-plane area of one robot in mm^2).

    Raises CatalogueError for a density that is not a finite number > 0, an unknown unit,
    or a unit without its scale."""
    if not (np.isfinite(value) and value > 0.0):
        raise CatalogueError(f"mock catalogue: density {value!r}; allowed: a finite number > 0 "
                             "(targets per deg^2 or per patrol area)")
    if unit == "deg2":
        if plate_scale_mm_per_deg is None:
            raise CatalogueError("mock catalogue: a density per deg^2 needs a plate scale; "
                                 "allowed: a telescope (apo, lco) or a density per patrol area "
                                 "(/patrol)")
        return float(value) / float(plate_scale_mm_per_deg) ** 2
    if unit == "patrol":
        if not patrol_area_mm2 or patrol_area_mm2 <= 0.0:
            raise CatalogueError(f"mock catalogue: patrol area {patrol_area_mm2!r} mm^2; "
                                 "allowed: > 0")
        return float(value) / float(patrol_area_mm2)
    if unit == "robot":
        if not robot_area_mm2 or robot_area_mm2 <= 0.0:
            raise CatalogueError(f"mock catalogue: area per robot {robot_area_mm2!r} mm^2; "
                                 "allowed: > 0")
        return float(value) / float(robot_area_mm2)
    raise CatalogueError(f"mock catalogue: density unit {unit!r}; allowed: "
                         f"{', '.join(DENSITY_UNITS)}")


def _check_count(expected: float, what: str) -> None:
    if expected > MAX_MOCK_TARGETS:
        raise CatalogueError(f"mock catalogue: {what} gives {expected:.3g} targets; allowed: at "
                             f"most {MAX_MOCK_TARGETS:.0e} targets (memory); lower the density")


def uniform_xy(rng: np.random.Generator, disc: Disc, density: float) -> np.ndarray:
    """(t, 2) mm Poisson points of ``density`` per mm^2, uniform by area in ``disc``."""
    expected = density * disc.area_mm2
    _check_count(expected, f"density {density:.4g} /mm^2 over {disc.area_mm2:.4g} mm^2")
    t = int(rng.poisson(expected))
    r = disc.radius_mm * np.sqrt(rng.uniform(0.0, 1.0, t))
    phi = rng.uniform(0.0, 2.0 * np.pi, t)
    return np.column_stack([disc.centre[0] + r * np.cos(phi), disc.centre[1] + r * np.sin(phi)])


def thomas_xy(rng: np.random.Generator, disc: Disc, density: float, children: float,
              sigma_mm: float) -> np.ndarray:
    """(t, 2) mm points of a Thomas process of ``density`` per mm^2 in ``disc`` (module
    docstring): ``children`` mean targets per cluster, Gaussian ``sigma_mm`` per axis."""
    if not (np.isfinite(children) and children > 0.0):
        raise CatalogueError(f"mock catalogue: field 'children' = {children!r}; allowed: > 0 "
                             "targets per cluster")
    if not (np.isfinite(sigma_mm) and sigma_mm > 0.0):
        raise CatalogueError(f"mock catalogue: field 'sigma_mm' = {sigma_mm!r}; allowed: > 0 mm")
    grown = Disc(disc.centre, disc.radius_mm + 4.0 * sigma_mm)
    _check_count(density * grown.area_mm2, f"density {density:.4g} /mm^2 over "
                 f"{grown.area_mm2:.4g} mm^2")
    parents = uniform_xy(rng, grown, density / children)
    k = rng.poisson(children, parents.shape[0])
    xy = np.repeat(parents, k, axis=0) + rng.normal(0.0, sigma_mm, (int(k.sum()), 2))
    inside = np.hypot(xy[:, 0] - disc.centre[0], xy[:, 1] - disc.centre[1]) <= disc.radius_mm
    return xy[inside]


def mock_catalogue(rng: np.random.Generator, disc: Disc, density: float, *,
                   process: str = "uniform", kind: str = "science", fiber: str = "boss",
                   priority_levels: int = 1, priority: float | None = None,
                   children: float = 10.0, sigma_mm: float = 20.0,
                   first_id: int = 0, source: str = "mock") -> Catalogue:
    """A mock catalogue of one kind in ``disc`` at ``density`` targets per mm^2.

    Parameters
    ----------
    process : ``uniform`` (Poisson) or ``clustered`` (Thomas; ``children``, ``sigma_mm``)
    kind, fiber : the kind (:data:`KINDS`) and fiber (:data:`TARGET_FIBERS`) of every target
    priority_levels : priorities drawn uniformly from 1..levels (1: every target weighs 1)
    priority : one priority for every target instead (a finite number >= 0)
    first_id : ids are ``first_id, first_id + 1, ...``
    """
    if process not in PROCESSES:
        raise CatalogueError(f"mock catalogue: process {process!r}; allowed: "
                             f"{', '.join(PROCESSES)}")
    if kind not in KINDS:
        raise CatalogueError(f"mock catalogue: kind {kind!r}; allowed: {', '.join(KINDS)}")
    if fiber not in TARGET_FIBERS:
        raise CatalogueError(f"mock catalogue: fiber {fiber!r}; allowed: "
                             f"{', '.join(TARGET_FIBERS)}")
    if not (isinstance(priority_levels, (int, np.integer)) and 1 <= priority_levels <= 1000):
        raise CatalogueError(f"mock catalogue: priority levels {priority_levels!r}; allowed: an "
                             "integer in [1, 1000]")
    if not (np.isfinite(density) and density > 0.0):
        raise CatalogueError(f"mock catalogue: density {density!r} /mm^2; allowed: > 0")
    xy = (uniform_xy(rng, disc, density) if process == "uniform"
          else thomas_xy(rng, disc, density, children, sigma_mm))
    t = xy.shape[0]
    if priority is not None:
        prio = np.full(t, float(priority))
    else:
        prio = (np.ones(t) if priority_levels == 1
                else rng.integers(1, priority_levels + 1, t).astype(np.float64))
    return Catalogue(first_id + np.arange(t, dtype=np.int64), xy, prio,
                     np.full(t, KINDS.index(kind), dtype=np.int8),
                     np.full(t, TARGET_FIBERS.index(fiber), dtype=np.int8), source=source)
