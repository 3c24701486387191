"""The metrology spread of a real instrument, as a perturbation of the two robots (mm, deg).

The calibration of an SDSS-V instrument (:func:`rfp_twin.models.instrument.read_calibration`)
measures every robot: its alpha arm length, its fibers in the beta-arm frame and the
offset ``dx, dy`` of its alpha axis from its hole. :class:`MetrologySpread` keeps each
robot's deviations from the nominal robot the 2D model plans with:

- ``alpha``: alpha arm length - nominal (7.4 mm for SDSS-V);
- ``beta``: metrology fiber x - nominal (14.314 mm): read as a shift of the whole beta
  arm along its own x (the arm sits that much further out than modelled);
- ``dx, dy``: the base offset, in the robot's own x (alpha = 0) and y (a flat wok's hole
  axes i, j become the planning x, y, :mod:`rfp_twin.models.instrument.layout`).

One Monte Carlo draw picks two different robots of the instrument (bootstrap) and gives
their deviations to robots A and B (:meth:`MetrologySpread.draw`); the planner's 2D model
keeps the nominal robot. This is the case of a planner that ignores the per-robot
calibration: the buffer it needs on top of the angular errors.

The perturbed robots are checked with the nominal meshes by moving the configuration
(:func:`perturbed_configurations`): robot ``i`` at ``(alpha, beta)`` has its beta frame at
``base_i + d_i + (l + da_i) u(alpha) + db_i u(alpha + beta)``, heading ``alpha + beta``.
For a configuration ``c~`` of the nominal robots, the configuration ``c`` of the perturbed
robots with the same headings and the same vector between the two beta frames puts the
two beta arms exactly where the nominal ones are at ``c~``, up to a common translation:
their 3D distance is the same. Two equations (that vector) in two unknowns (the alpha
angles): two circles meet; the solution nearer ``c~`` is kept, and ``c~`` is skipped where
none exists (alpha arms near full stretch or fold). This is exact when only beta arms can
touch: :func:`rfp_twin.validation.buffer.pairs.MeshPairs.other_contacts` checks that the
other links stay apart by more than the perturbation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfp_twin.models.errors import SpecError, field_error

#: Nominal metrology fiber x of SDSS-V in the beta-arm frame (coordio/kaiju), mm.
NOMINAL_METROLOGY_X_MM = 14.314
#: Order of the four deviations of one robot in :meth:`MetrologySpread.draw`.
DEVIATIONS = ("alpha", "beta", "dx", "dy")


@dataclass(frozen=True)
class MetrologySpread:
    """Per-robot deviations from nominal of one instrument's calibration, mm.

    Attributes
    ----------
    instrument : str
        Name (``sdss-v-apo``) or calibration folder.
    deviations : (n, 4) float64
        Per robot: alpha arm - nominal, metrology x - nominal, dx, dy (:data:`DEVIATIONS`).
    nominal_alpha_mm, nominal_metrology_mm : float
    """

    instrument: str
    deviations: np.ndarray
    nominal_alpha_mm: float
    nominal_metrology_mm: float = NOMINAL_METROLOGY_X_MM

    @classmethod
    def from_instrument(cls, instrument, nominal_alpha_mm: float,
                        nominal_metrology_mm: float = NOMINAL_METROLOGY_X_MM) -> MetrologySpread:
        """Read a built-in instrument (``sdss-v-apo``, ``sdss-v-lco``) or a calibration folder.

        Raises
        ------
        SpecError
            An unknown instrument name / folder, or fewer than two measured robots.
        """
        from rfp_twin.models.instrument import (INSTRUMENTS, CalibrationError,
                                                calibration_folder, read_calibration)

        name = str(instrument)
        allowed = f"{', '.join(INSTRUMENTS)} or a calibration folder"
        if name in INSTRUMENTS:
            folder = calibration_folder(name)
        elif Path(name).is_dir():
            folder = Path(name)
        else:
            raise field_error(SpecError, "instrument", name, allowed, "calibrate_buffer")
        try:
            cal = read_calibration(folder)
        except CalibrationError as exc:
            raise SpecError(f"calibrate_buffer: field 'instrument' = {name!r}: {exc}") from None
        dev = np.column_stack([cal.alpha_len - float(nominal_alpha_mm),
                               cal.fibers[:, 0, 0] - float(nominal_metrology_mm),
                               cal.base_offset[:, 0], cal.base_offset[:, 1]])
        dev = dev[np.all(np.isfinite(dev), axis=1)]
        if len(dev) < 2:
            raise field_error(SpecError, "instrument", name,
                              f"a calibration with at least two measured robots ({allowed})",
                              "calibrate_buffer")
        return cls(name, np.ascontiguousarray(dev, dtype=np.float64), float(nominal_alpha_mm),
                   float(nominal_metrology_mm))

    @property
    def n_robots(self) -> int:
        return int(len(self.deviations))

    def draw(self, rng, n: int) -> np.ndarray:
        """Deviations of robots A and B for ``n`` draws, (n, 2, 4) mm: two different robots
        of the calibration per draw, picked uniformly (bootstrap)."""
        m = self.n_robots
        a = rng.integers(0, m, n)
        b = rng.integers(0, m - 1, n)
        b = b + (b >= a)
        return np.stack([self.deviations[a], self.deviations[b]], axis=1)

    def max_displacement_mm(self) -> float:
        """Largest planar displacement of a beta arm by one robot's deviations, mm."""
        d = self.deviations
        return float(np.max(np.abs(d[:, 0]) + np.abs(d[:, 1]) + np.hypot(d[:, 2], d[:, 3])))

    def summary(self) -> dict:
        """Per deviation: mean, standard deviation and largest |value| (mm); robots."""
        out = {"instrument": self.instrument, "n_robots": self.n_robots,
               "nominal_alpha_mm": self.nominal_alpha_mm,
               "nominal_metrology_mm": self.nominal_metrology_mm}
        for k, name in enumerate(DEVIATIONS):
            v = self.deviations[:, k]
            out[name] = {"mean": float(v.mean()), "std": float(v.std()),
                         "max_abs": float(np.abs(v).max())}
        return out


#: Common turns of both robots tried, in this order, where the headings of ``c~`` admit no
#: solution (deg): the whole scene turned about the origin keeps every 3D distance.
TURNS_DEG = tuple(t * sgn for t in np.arange(0.25, 5.001, 0.25) for sgn in (1.0, -1.0))


def perturbed_configurations(angles_deg, dev, l_alpha: float,
                             offsets) -> tuple[np.ndarray, np.ndarray]:
    """Configurations of the perturbed robots whose beta arms stand as the nominal ones.

    Solves for the alpha angles with the headings of ``c~``; where that has no solution,
    with both headings turned by the smallest of :data:`TURNS_DEG` that has one (the two
    beta arms then stand as at ``c~`` turned and moved as one rigid body).

    Parameters
    ----------
    angles_deg : (n, 4) deg
        Configurations ``c~`` of the nominal robots (alpha_A, beta_A, alpha_B, beta_B).
    dev : (2, 4) mm
        Deviations of robots A and B (:data:`DEVIATIONS`).
    l_alpha : float
        Nominal alpha arm, mm.
    offsets : (n, 2) or (2,) mm
        Robot B's nominal base (robot A's at the origin).

    Returns
    -------
    angles (n, 4) deg (the solution nearer ``c~``; NaN where none), ok (n,) bool
    """
    ang = np.radians(np.asarray(angles_deg, dtype=np.float64).reshape(-1, 4))
    dev = np.asarray(dev, dtype=np.float64).reshape(2, 4)
    off = np.broadcast_to(np.asarray(offsets, dtype=np.float64).reshape(-1, 2), (len(ang), 2))
    out, ok = _solve(ang, off, dev, float(l_alpha), 0.0)
    for turn in TURNS_DEG:
        if ok.all():
            break
        rows = np.flatnonzero(~ok)
        o, k = _solve(ang[rows], off[rows], dev, float(l_alpha), math.radians(turn))
        out[rows[k]] = o[k]
        ok[rows[k]] = True
    out[~ok] = np.nan
    return np.degrees(out), ok


def _solve(ang, off, dev, la, psi):
    """Alpha angles (rad) of the perturbed robots with both headings turned by ``psi``
    rad: the vector between their beta frames, ``o + d_B - d_A + r_B u(a_B) + s_B u(th_B)
    - r_A u(a_A) - s_A u(th_A)``, must be the nominal one ``o + l (u(a~_B) - u(a~_A))``
    turned by ``psi`` (``o``: robot B's base). Returns (angles (n, 4) rad, solvable (n,))."""
    a_a, a_b = ang[:, 0], ang[:, 2]
    th_a, th_b = a_a + ang[:, 1] + psi, a_b + ang[:, 3] + psi
    r_a, r_b = la + dev[0, 0], la + dev[1, 0]
    c, s = math.cos(psi), math.sin(psi)
    wx = la * (np.cos(a_b) - np.cos(a_a)) + off[:, 0]
    wy = la * (np.sin(a_b) - np.sin(a_a)) + off[:, 1]
    vx = (c * wx - s * wy - off[:, 0] - (dev[1, 2] - dev[0, 2])
          - dev[1, 1] * np.cos(th_b) + dev[0, 1] * np.cos(th_a))
    vy = (s * wx + c * wy - off[:, 1] - (dev[1, 3] - dev[0, 3])
          - dev[1, 1] * np.sin(th_b) + dev[0, 1] * np.sin(th_a))
    v = np.hypot(vx, vy)
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = (r_b * r_b - r_a * r_a - v * v) / (2.0 * r_a * v)
    ok = (v > 1e-12) & (np.abs(kappa) <= 1.0)
    phi = np.arctan2(vy, vx)
    half = np.arccos(np.clip(kappa, -1.0, 1.0))
    cand = np.stack([phi + half, phi - half])
    wrap = (cand - a_a + math.pi) % (2.0 * math.pi) - math.pi    # nearest to alpha_A
    pick = np.argmin(np.abs(wrap), axis=0)
    new_a = a_a + wrap[pick, np.arange(len(a_a))]
    qx = vx + r_a * np.cos(new_a)
    qy = vy + r_a * np.sin(new_a)
    new_b = a_b + (np.arctan2(qy, qx) - a_b + math.pi) % (2.0 * math.pi) - math.pi
    return np.column_stack([new_a, th_a - new_a, new_b, th_b - new_b]), ok
