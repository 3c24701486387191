"""Sky positions to the focal plane: a tangent-plane (gnomonic) projection and a plate scale.

A target at (ra, dec) deg is projected about the field centre (ra0, dec0) onto the plane
tangent to the sky there (the gnomonic projection), giving standard coordinates
(xi, eta) deg: xi toward increasing ra (east), eta toward increasing dec (north). The
focal-plane position is ``(xi, eta) * plate_scale`` mm, at position angle 0. This is
a first-order model: it leaves out the telescope's field distortion, refraction and
the focal surface's curvature (SDSS-V's coordio models them; at the edge of the APO
field they move a target by well under a patrol radius, so which robots can reach it
barely changes), and it puts east along +x as seen on the sky.

Plate scales and field radii of the SDSS-V telescopes (coordio defaults):
APO (Sloan 2.5 m) 217.7358 mm/deg, 1.5 deg; LCO (du Pont) 330.275 mm/deg, 1.1 deg.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfp_twin.models.errors import CatalogueError


@dataclass(frozen=True)
class Telescope:
    """A telescope's focal plane scale and field.

    name : str
    plate_scale_mm_per_deg : float
    field_radius_deg : float
    """

    name: str
    plate_scale_mm_per_deg: float
    field_radius_deg: float

    @property
    def field_radius_mm(self) -> float:
        return self.plate_scale_mm_per_deg * self.field_radius_deg

    @property
    def field_area_deg2(self) -> float:
        """Area of the field on the sky, deg^2 (a flat disc of the field radius)."""
        return float(np.pi * self.field_radius_deg ** 2)


#: The SDSS-V telescopes (coordio defaults).
TELESCOPES = {
    "apo": Telescope("apo", 217.7358, 1.5),
    "lco": Telescope("lco", 330.275, 1.1),
}


def check_field_centre(ra0: float, dec0: float, where: str = "field centre") -> None:
    """CatalogueError unless ra0 is in [0, 360) and dec0 in [-90, 90] deg (finite)."""
    if not (np.isfinite(ra0) and 0.0 <= ra0 < 360.0):
        raise CatalogueError(f"{where}: field 'ra' = {ra0!r}; allowed: [0, 360) deg")
    if not (np.isfinite(dec0) and -90.0 <= dec0 <= 90.0):
        raise CatalogueError(f"{where}: field 'dec' = {dec0!r}; allowed: [-90, 90] deg")


def sky_to_focal(ra_deg: np.ndarray, dec_deg: np.ndarray, ra0_deg: float, dec0_deg: float,
                 plate_scale_mm_per_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Gnomonic projection about (ra0, dec0), scaled to mm (module docstring).

    Parameters
    ----------
    ra_deg, dec_deg : (t,) float64 target positions, deg
    ra0_deg, dec0_deg : field centre, deg
    plate_scale_mm_per_deg : mm per degree on the sky

    Returns
    -------
    x_mm, y_mm : (t,) float64; NaN for a target 90 deg or more from the centre (it does
        not project onto the tangent plane)
    """
    ra = np.radians(np.asarray(ra_deg, dtype=np.float64))
    dec = np.radians(np.asarray(dec_deg, dtype=np.float64))
    ra0, dec0 = np.radians(ra0_deg), np.radians(dec0_deg)
    dra = ra - ra0
    cos_c = np.sin(dec0) * np.sin(dec) + np.cos(dec0) * np.cos(dec) * np.cos(dra)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = np.cos(dec) * np.sin(dra) / cos_c
        eta = (np.cos(dec0) * np.sin(dec) - np.sin(dec0) * np.cos(dec) * np.cos(dra)) / cos_c
    far = ~(cos_c > 0.0)
    xi[far] = np.nan
    eta[far] = np.nan
    s = float(plate_scale_mm_per_deg) * 180.0 / np.pi
    return xi * s, eta * s
