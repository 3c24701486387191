"""The buffer calibration's result, :class:`BufferCalibration` (mm, deg, s).

A plain dataclass with a JSON form (``to_dict``: non-finite numbers as ``None``) and a
terminal summary (``table``); :func:`rfp_twin.validation.buffer.calibrate_buffer` fills it and
:func:`rfp_twin.validation.buffer.write_report` writes it out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class BufferCalibration:
    """Result of :func:`rfp_twin.validation.buffer.calibrate_buffer` (mm, deg, s).

    Attributes
    ----------
    spec_name, geometry : str
    pitch_mm : float; directions_deg : list of float
    n_samples : int
        Uniform (Sobol) configurations per run, over all directions.
    n_boundary : int
        Extra configurations near the largest ``required`` (densified + local search).
    n_colliding : int
        3D-colliding configurations found (uniform + boundary).
    seed : int
    safe_buffer_mm : float
        (a) ``b*``: largest ``required`` over every 3D-colliding configuration found.
    safe_buffer_uniform_mm : float
        The same over the uniform samples only.
    worst : dict
        The configuration of ``b*``: angles, direction, ``D2``, links in contact.
    envelope_mm : float
        Beta-arm envelope of the mesh around the 2D segment (upper bound of ``b*`` when
        only beta arms touch).
    spec_buffer_mm : float
        The preset's buffer, for comparison.
    buffers_mm, forbidden_fraction, wasted_fraction, colliding_fraction : list
        (b) per buffer: share of the uniform samples the 2D model forbids; share of
        those that are 3D-safe; share of all samples colliding in 3D.
    angular_error_deg : (float, float); probability : float; n_draws : int
    mc_buffer_mm : float
        (c) ``b_p``.
    mc_share_mm : float
        ``b_p - b*``.
    corner_buffer_mm, corner_share_mm : float
        Worst corner error (all errors at their bounds) and its share.
    paper_sigma_eps_mm : float
        ``l_alpha ea + l_beta (ea + eb)`` (Sayres 2021 Eq. 12's 0.97 mm for SDSS-V).
    mc_quantiles : dict
        ``B(e)`` quantiles (0.5, 0.9, 0.99, 1.0).
    scatter_d2_mm, scatter_d3_mm : list
        A subsample (close configurations) of 2D and exact 3D (FCL) distances.
    seconds : dict
        Wall time per stage and in total.
    n_fcl_calls : int
    model : str
        ``mesh`` (3D meshes) or ``capsule`` (the 2D capsule model as the robot).
    instrument : str
        (d) The instrument whose metrology spread was added ("" if none).
    metrology : dict
        Its per-robot deviations (mean, std, max |.| of alpha, beta, dx, dy; mm).
    spread_buffer_mm : float
        ``b_p`` with angular errors and the metrology spread (NaN without an instrument).
    spread_change_mm : float
        ``spread_buffer_mm - mc_buffer_mm``: what the spread adds to ``b_p``.
    spread_quantiles : dict; spread_samples_mm : list
        ``B(e, m)`` quantiles and samples.
    """

    spec_name: str
    geometry: str
    pitch_mm: float
    directions_deg: list
    n_samples: int
    n_boundary: int
    n_colliding: int
    seed: int
    safe_buffer_mm: float
    safe_buffer_uniform_mm: float
    worst: dict
    envelope_mm: float
    spec_buffer_mm: float
    buffers_mm: list
    forbidden_fraction: list
    wasted_fraction: list
    colliding_fraction: float
    angular_error_deg: tuple
    probability: float
    n_draws: int
    mc_buffer_mm: float
    mc_share_mm: float
    corner_buffer_mm: float
    corner_share_mm: float
    paper_sigma_eps_mm: float
    mc_quantiles: dict
    scatter_d2_mm: list = field(default_factory=list, repr=False)
    scatter_d3_mm: list = field(default_factory=list, repr=False)
    mc_samples_mm: list = field(default_factory=list, repr=False)
    seconds: dict = field(default_factory=dict)
    n_fcl_calls: int = 0
    model: str = "mesh"
    instrument: str = ""
    metrology: dict = field(default_factory=dict)
    spread_buffer_mm: float = math.nan
    spread_change_mm: float = math.nan
    spread_quantiles: dict = field(default_factory=dict)
    spread_samples_mm: list = field(default_factory=list, repr=False)

    def to_dict(self) -> dict:
        def clean(v):
            if isinstance(v, float):
                return v if math.isfinite(v) else None
            if isinstance(v, (np.floating, np.integer)):
                return clean(v.item())
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            if isinstance(v, (list, tuple, np.ndarray)):
                return [clean(x) for x in v]
            return v
        return {k: clean(getattr(self, k)) for k in self.__dataclass_fields__}

    def wasted_at(self, buffer_mm: float) -> float:
        """Wasted fraction at the tabulated buffer nearest ``buffer_mm``."""
        k = int(np.argmin(np.abs(np.asarray(self.buffers_mm) - buffer_mm)))
        return float(self.wasted_fraction[k])

    def table(self) -> str:
        w = self.worst
        lines = [
            f"buffer calibration ({self.spec_name}, {self.geometry}): pitch "
            f"{self.pitch_mm:.3f} mm, "
            f"directions {', '.join(f'{d:g}' for d in self.directions_deg)} deg, "
            f"{self.n_samples} uniform + {self.n_boundary} boundary configurations, "
            f"seed {self.seed}",
            f"(a) smallest buffer with 2D-safe => 3D-safe: {self.safe_buffer_mm:.4f} mm "
            f"(uniform samples alone {self.safe_buffer_uniform_mm:.4f} mm; mesh envelope "
            f"{self.envelope_mm:.4f} mm)",
            f"    worst: A ({w['alpha_a']:.3f}, {w['beta_a']:.3f}) B ({w['alpha_b']:.3f}, "
            f"{w['beta_b']:.3f}) deg, direction {w['direction_deg']:g} deg, "
            f"D2 {w['d2_mm']:.4f} mm, "
            f"links {w['links']}",
            f"(b) wasted share of the 2D-forbidden space at {self.spec_buffer_mm:g} mm: "
            f"{self.wasted_at(self.spec_buffer_mm):.3f}",
            f"(c) angular errors +-{self.angular_error_deg[0]:g} / +-{self.angular_error_deg[1]:g} "
            f"deg, {self.n_draws} draws: buffer {self.mc_buffer_mm:.4f} mm keeps 3D safety with "
            f"p = {self.probability:g} (share {self.mc_share_mm:.4f} mm; worst corner "
            f"{self.corner_share_mm:.4f} mm; paper analytic {self.paper_sigma_eps_mm:.4f} mm)",
        ]
        if self.instrument:
            lines.append(
                f"(d) + metrology spread of {self.instrument} ({self.metrology.get('n_robots', 0)} "
                f"robots), same draws: buffer {self.spread_buffer_mm:.4f} mm for p = "
                f"{self.probability:g} ({self.spread_change_mm:+.4f} mm)")
        lines.append(f"    {self.seconds.get('total', 0.0):.1f} s, {self.n_fcl_calls} FCL calls")
        return "\n".join(lines)
