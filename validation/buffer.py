"""Collision-buffer calibration: the 2D capsule model against the 3D meshes (FCL).

Two robots of one design sit at the layout's pitch, robot B in each neighbour direction
of the layout (modulo 180 deg: the two robots are identical). For a configuration ``c =
(alpha_A, beta_A, alpha_B, beta_B)`` (deg):

* ``D2(c; b)``: the 2D model's distance (Sayres 2021 Eq. 3), the distance of the two
  beta collision segments ``[segment_start, spec.segment_end(b)]``; "safe in 2D at
  buffer b" is ``D2 > 2 b``;
* ``D3(c)``: the true 3D (solid) distance of the two robots' collision meshes
  (:class:`validation.mesh3d.RobotPair`: lower bounds in numba, FCL where they cannot
  decide); "safe in 3D" is ``D3 > 0``.

``required(c)`` is the smallest buffer whose 2D model forbids ``c``: ``D2(c) / 2`` for a
fixed segment, found by bisection when the segment end depends on the buffer
(``D2(c; b) - 2 b`` does not increase with ``b`` because ``|d segment_end / d b| <=
1``).

What is computed (:func:`calibrate_buffer`)
-------------------------------------------
(a) *Smallest safe buffer* ``b*``: "safe in 2D implies safe in 3D" holds for a buffer
    ``b`` iff every 3D-colliding configuration has ``required(c) <= b``, so
    ``b* = max required(c)`` over 3D-colliding ``c``. Estimated on a Sobol sample of
    the joint ranges (``n_samples``), a densified set near the largest values
    (jittered copies) and a local search (hill climb on ``required`` while staying in
    3D collision, verified with FCL at every step). It is a lower estimate of the true
    supremum (every reported configuration is a verified 3D collision); the beta
    envelope of the mesh (:meth:`models.geometry.RobotGeometry.beta_envelope_mm`) is an
    upper bound when only the beta arms can touch.
(b) *Space wasted by the 2D model*: per buffer, among the uniform samples the 2D model
    forbids (``D2 <= 2 b``), the fraction that is safe in 3D. Uniform samples of the
    joint ranges measure volume, so this is the share of the forbidden configuration
    space that the 3D robot could use.
(c) *Angular errors* (Monte Carlo): a commanded configuration ``c`` is reached as ``c +
    e``, ``e`` uniform in ``[-ea, ea] x [-eb, eb]`` per robot (default the paper's
    worst-case 1.50 / 1.48 deg, Sayres 2021 Sect. 6). For one draw ``e``, every
    2D-safe ``c`` stays 3D-safe iff ``b >= B(e) = max required(c' - e)`` over the
    3D-colliding actual configurations ``c'``. ``b_p``, the ``p``-quantile of ``B(e)``
    over the draws, keeps 3D safety with probability ``p`` (over the angular errors);
    ``b_p - b*`` is the angular-error share of the buffer, set beside the paper's
    analytic ``sigma_eps = l_alpha ea + l_beta (ea + eb)`` (0.97 mm). The worst corner
    (every error at its bound, 16 sign combinations) is reported too.

Units: mm and degrees at the public boundary. Randomness: every function takes a seed;
same seed, same result.
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

import numpy as np
from numba import njit
from scipy.stats import qmc

from models.errors import SpecError, field_error
from models.geometry import RobotGeometry, geometry_for_spec
from models.layout import Layout
from models.robot import RobotSpec
from validation.mesh3d import LinkModels, RobotPair

__all__ = ["BufferCalibration", "calibrate_buffer", "neighbour_directions", "write_report",
           "pair_segment_distances", "DEFAULT_BUFFERS_MM"]

#: Buffers at which the wasted space is tabulated by default, mm.
DEFAULT_BUFFERS_MM = tuple(np.round(np.arange(1.0, 4.0001, 0.1), 3))


# =====================================================================================
# 2D model
# =====================================================================================
@njit(cache=True)
def _seg_dist(p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y):
    """Distance of two 2D segments (clamped line parameters)."""
    ux, uy = p1x - p0x, p1y - p0y
    vx, vy = q1x - q0x, q1y - q0y
    wx, wy = p0x - q0x, p0y - q0y
    a = ux * ux + uy * uy
    e = vx * vx + vy * vy
    f = vx * wx + vy * wy
    if a <= 1e-24:
        s = 0.0
        t = min(max(f / e, 0.0), 1.0) if e > 1e-24 else 0.0
    else:
        c = ux * wx + uy * wy
        if e <= 1e-24:
            t = 0.0
            s = min(max(-c / a, 0.0), 1.0)
        else:
            b = ux * vx + uy * vy
            den = a * e - b * b
            s = min(max((b * f - c * e) / den, 0.0), 1.0) if den > 1e-12 * a * e else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = min(max((b - c) / a, 0.0), 1.0)
    dx = wx + ux * s - vx * t
    dy = wy + uy * s - vy * t
    return math.sqrt(dx * dx + dy * dy)


@njit(cache=True)
def _d2_kernel(ang, ox, oy, la, s0, s1):
    """Beta-segment distances, (n,) mm; ``ang`` (n, 4) rad, ``ox``/``oy``/``s1`` (n,)."""
    n = ang.shape[0]
    out = np.empty(n)
    for k in range(n):
        ea_x = la * math.cos(ang[k, 0])
        ea_y = la * math.sin(ang[k, 0])
        ua = ang[k, 0] + ang[k, 1]
        eb_x = ox[k] + la * math.cos(ang[k, 2])
        eb_y = oy[k] + la * math.sin(ang[k, 2])
        ub = ang[k, 2] + ang[k, 3]
        ca, sa = math.cos(ua), math.sin(ua)
        cb, sb = math.cos(ub), math.sin(ub)
        e = s1[k]
        out[k] = _seg_dist(ea_x + s0 * ca, ea_y + s0 * sa, ea_x + e * ca, ea_y + e * sa,
                           eb_x + s0 * cb, eb_y + s0 * sb, eb_x + e * cb, eb_y + e * sb)
    return out


def pair_segment_distances(spec: RobotSpec, offsets: np.ndarray, angles_deg: np.ndarray,
                           buffer_mm: float | None = None) -> np.ndarray:
    """2D model distance ``D2`` of robot A (base at the origin) and robot B (base at
    ``offsets``) per configuration.

    Parameters
    ----------
    spec : RobotSpec
        ``alpha_length_mm``, ``segment_start_mm``, ``segment_end(buffer)``.
    offsets : (n, 2) or (2,) float, mm
    angles_deg : (n, 4) float, deg: (alpha_A, beta_A, alpha_B, beta_B)
    buffer_mm : float, optional
        Selects the segment end when it depends on the buffer (default: the spec's).

    Returns
    -------
    (n,) float64, mm
    """
    ang = np.ascontiguousarray(np.deg2rad(np.asarray(angles_deg, dtype=np.float64).reshape(-1, 4)))
    off = np.broadcast_to(np.asarray(offsets, dtype=np.float64).reshape(-1, 2), (len(ang), 2))
    s1 = np.full(len(ang), float(spec.segment_end(buffer_mm)))
    return _d2_kernel(ang, np.ascontiguousarray(off[:, 0]), np.ascontiguousarray(off[:, 1]),
                      float(spec.alpha_length_mm), float(spec.segment_start_mm), s1)


_END_TABLES: dict = {}


def _segment_end_table(spec: RobotSpec, hi_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """``spec.segment_end(b)`` on 4097 buffers in [0, hi] (for a buffer-dependent
    segment end; interpolated linearly, error < 1e-6 mm for the SDSS-V production rule)."""
    key = (spec, float(hi_mm))
    if key not in _END_TABLES:
        grid = np.linspace(0.0, hi_mm, 4097)
        _END_TABLES[key] = (grid, np.array([spec.segment_end(float(b)) for b in grid]))
    return _END_TABLES[key]


def _required(spec: RobotSpec, offsets, angles, hi_mm: float) -> np.ndarray:
    """Smallest buffer whose 2D model forbids each configuration (``D2(b) <= 2 b``), (n,) mm;
    ``hi_mm`` when even that buffer does not forbid it."""
    if not isinstance(spec.segment_end_mm, str):
        return np.minimum(pair_segment_distances(spec, offsets, angles) / 2.0, hi_mm)
    ang = np.ascontiguousarray(np.deg2rad(np.asarray(angles, dtype=np.float64).reshape(-1, 4)))
    n = len(ang)
    off = np.broadcast_to(np.asarray(offsets, dtype=np.float64).reshape(-1, 2), (n, 2))
    ox, oy = np.ascontiguousarray(off[:, 0]), np.ascontiguousarray(off[:, 1])
    grid, ends = _segment_end_table(spec, hi_mm)
    lo, hi = np.zeros(n), np.full(n, float(hi_mm))
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        d = _d2_kernel(ang, ox, oy, float(spec.alpha_length_mm), float(spec.segment_start_mm),
                       np.interp(mid, grid, ends))
        forb = d <= 2.0 * mid
        hi = np.where(forb, mid, hi)
        lo = np.where(forb, lo, mid)
    return hi


# =====================================================================================
# Directions, samples
# =====================================================================================
def neighbour_directions(layout: Layout | None, pitch_mm: float) -> tuple[float, np.ndarray]:
    """Pitch and neighbour directions (deg, in [0, 180)) of a layout.

    With no layout: a hex grid of ``pitch_mm`` (0, 60, 120 deg). With a layout: the
    median nearest-neighbour base distance, and the directions of the robot pairs
    within 5 % of it, rounded to 0.1 deg and folded into [0, 180).
    """
    if layout is None or layout.n_robots < 2:
        return float(pitch_mm), np.array([0.0, 60.0, 120.0])
    xy = np.asarray(layout.robot_xy, dtype=np.float64)
    from scipy.spatial import cKDTree

    tree = cKDTree(xy)
    d, _ = tree.query(xy, k=2)
    pitch = float(np.median(d[:, 1]))
    pairs = tree.query_pairs(r=1.05 * pitch, output_type="ndarray")
    v = xy[pairs[:, 1]] - xy[pairs[:, 0]]
    dist = np.hypot(v[:, 0], v[:, 1])
    keep = np.abs(dist - pitch) <= 0.05 * pitch
    ang = np.round(np.degrees(np.arctan2(v[keep, 1], v[keep, 0])) % 180.0, 1) % 180.0
    dirs, counts = np.unique(ang, return_counts=True)
    # directions seen by at least 1 % of the pairs (drops a few crooked real-layout pairs)
    dirs = dirs[counts >= max(1, 0.01 * keep.sum())]
    return pitch, dirs


def _uniform(spec: RobotSpec, n: int, seed: int) -> np.ndarray:
    """Sobol (scrambled) sample of the joint ranges, (n, 4) deg."""
    lo_a, hi_a = spec.alpha_limits_deg
    lo_b, hi_b = spec.beta_limits_deg
    m = int(math.ceil(math.log2(max(n, 2))))
    u = qmc.Sobol(d=4, scramble=True, seed=np.random.default_rng(seed)).random_base2(m)[:n]
    return qmc.scale(u, [lo_a, lo_b, lo_a, lo_b], [hi_a, hi_b, hi_a, hi_b])


# =====================================================================================
# Report
# =====================================================================================
@dataclass
class BufferCalibration:
    """Result of :func:`calibrate_buffer` (mm, deg, s).

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
            f"    {self.seconds.get('total', 0.0):.1f} s, {self.n_fcl_calls} FCL calls",
        ]
        return "\n".join(lines)


# =====================================================================================
# The calibration
# =====================================================================================
def _check(value, name: str, lo: float, hi: float, integer: bool = False):
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if ok:
        ok = math.isfinite(float(value)) and lo <= float(value) <= hi
        if integer:
            ok = ok and float(value) == int(value)
    if not ok:
        kind = "an integer" if integer else "a number"
        raise field_error(SpecError, name, value, f"{kind} in [{lo}, {hi}]", "calibrate_buffer")
    return int(value) if integer else float(value)


def calibrate_buffer(spec: RobotSpec, geometry: RobotGeometry | None = None,
                     layout: Layout | None = None, *, n_samples: int = 131072,
                     buffers_mm=DEFAULT_BUFFERS_MM, angular_error_deg=None,
                     probability: float = 0.99, n_draws: int = 2000, seed: int = 0,
                     n_scatter: int = 3000, mc_starts: int = 3, mc_rounds: int = 20,
                     progress: Optional[Callable[[str, float], None]] = None
                     ) -> BufferCalibration:
    """Calibrate the 2D collision buffer against the 3D meshes (see the module docstring).

    Parameters
    ----------
    spec : RobotSpec
    geometry : RobotGeometry, optional
        Default :func:`models.geometry.geometry_for_spec`.
    layout : Layout, optional
        Supplies the pitch and the neighbour directions (default a hex grid of the
        spec's pitch).
    n_samples : int
        Uniform (Sobol) configurations, over all directions.
    buffers_mm : sequence of float
        Buffers for the wasted-space table, mm.
    angular_error_deg : (float, float), optional
        Bounds of the uniform alpha / beta angular errors, deg (default the spec's
        ``angular_error_deg``).
    probability : float
        ``p`` of part (c), in (0, 1].
    n_draws : int
        Monte Carlo draws of the angular errors.
    seed : int
    n_scatter : int
        Configurations whose exact 3D distance is computed for the scatter figure.
    mc_starts, mc_rounds : int
        Per Monte Carlo draw, the local search's starts and rounds (0 rounds: the
        best candidate only). The 16 corners get 4x both.
    progress : callable(stage, fraction), optional

    Returns
    -------
    BufferCalibration

    Raises
    ------
    SpecError
        A parameter out of range.
    """
    clock = time.perf_counter()
    n_samples = _check(n_samples, "n_samples", 64, 1 << 24, integer=True)
    n_draws = _check(n_draws, "n_draws", 1, 1 << 22, integer=True)
    n_scatter = _check(n_scatter, "n_scatter", 0, 1 << 20, integer=True)
    mc_starts = _check(mc_starts, "mc_starts", 1, 1000, integer=True)
    mc_rounds = _check(mc_rounds, "mc_rounds", 0, 10000, integer=True)
    probability = _check(probability, "probability", 1e-9, 1.0)
    seed = _check(seed, "seed", 0, 2 ** 63 - 1, integer=True)
    if angular_error_deg is None:
        angular_error_deg = spec.angular_error_deg
    if len(tuple(angular_error_deg)) != 2:
        raise field_error(SpecError, "angular_error_deg", angular_error_deg,
                          "a pair (alpha, beta) of degrees in [0, 90]", "calibrate_buffer")
    ea, eb = (_check(v, f"angular_error_deg[{ax}]", 0.0, 90.0)
              for ax, v in zip(("alpha", "beta"), angular_error_deg))
    buffers = np.asarray([_check(b, "buffers_mm", 1e-6, spec.pitch_mm) for b in buffers_mm])
    if buffers.size == 0:
        raise field_error(SpecError, "buffers_mm", list(buffers_mm), "at least one buffer",
                          "calibrate_buffer")
    report = progress or (lambda stage, frac: None)
    geometry = geometry if geometry is not None else geometry_for_spec(spec)
    models = LinkModels.from_geometry(geometry)
    rng = np.random.default_rng(seed)
    seconds: dict[str, float] = {}
    hi_mm = float(spec.pitch_mm)

    pitch, dirs = neighbour_directions(layout, spec.pitch_mm)
    offs = pitch * np.column_stack([np.cos(np.radians(dirs)), np.sin(np.radians(dirs))])
    pairs = [RobotPair(models, o) for o in offs]

    def classify(ang: np.ndarray, dir_idx: np.ndarray) -> np.ndarray:
        """3D collision (exact) per configuration."""
        out = np.zeros(len(ang), dtype=bool)
        for k, pr in enumerate(pairs):
            sel = np.flatnonzero(dir_idx == k)
            if sel.size == 0:
                continue
            lb = pr.bounds(ang[sel])
            maybe = sel[lb <= 0.0]
            if maybe.size:
                out[maybe] = pr.collides(ang[maybe])
        return out

    # -- uniform samples -------------------------------------------------------------
    t0 = time.perf_counter()
    report("uniform samples", 0.0)
    ang_u = _uniform(spec, n_samples, seed)
    dir_u = np.arange(n_samples) % len(dirs)
    coll_u = classify(ang_u, dir_u)
    seconds["uniform_3d"] = time.perf_counter() - t0
    report("uniform samples", 1.0)

    # -- (b) wasted space ---------------------------------------------------------------
    t0 = time.perf_counter()
    forb_frac, waste_frac = [], []
    fixed = not isinstance(spec.segment_end_mm, str)
    d2_fixed = pair_segment_distances(spec, offs[dir_u], ang_u) if fixed else None
    for b in buffers:
        d2 = d2_fixed if fixed else pair_segment_distances(spec, offs[dir_u], ang_u, float(b))
        forb = d2 <= 2.0 * b
        nf = int(forb.sum())
        forb_frac.append(nf / n_samples)
        waste_frac.append(float(np.sum(forb & ~coll_u)) / nf if nf else 0.0)
    seconds["wasted_space"] = time.perf_counter() - t0

    # -- (a) smallest safe buffer ----------------------------------------------------------
    t0 = time.perf_counter()
    report("boundary", 0.0)
    ang_c = ang_u[coll_u]
    dir_c = dir_u[coll_u]
    req_c = _required(spec, offs[dir_c], ang_c, hi_mm)
    b_uniform = float(req_c.max()) if req_c.size else 0.0
    # densify: jittered copies of the configurations with the largest requirement
    # largest displacement of a 2D segment point by the angular errors, per robot, mm
    r_seg = max(abs(float(spec.segment_start_mm)),
                max(float(spec.segment_end(float(b))) for b in (1e-6, *buffers, hi_mm)))
    shift = math.radians(ea) * float(spec.alpha_length_mm) + math.radians(ea + eb) * r_seg
    n_boundary = 0
    if req_c.size:
        top = np.argsort(req_c)[::-1][:min(2000, req_c.size)]
        seeds_ang, seeds_dir = ang_c[top], dir_c[top]
        copies = 16
        jit = np.repeat(seeds_ang, copies, axis=0) + rng.normal(0.0, 2.0, (len(top) * copies, 4))
        jdir = np.repeat(seeds_dir, copies)
        jcol = classify(jit, jdir)
        n_boundary += len(jit)
        ang_c = np.vstack([ang_c, jit[jcol]])
        dir_c = np.concatenate([dir_c, jdir[jcol]])
        req_c = np.concatenate([req_c, _required(spec, offs[jdir[jcol]], jit[jcol], hi_mm)])
        # local search from the best few distinct configurations
        req_fn = lambda a, d: _required(spec, offs[d], a, hi_mm)  # noqa: E731
        top = _distinct_top(req_c, ang_c, dir_c, 8)
        _, _, extra_a, extra_d, n_eval = _climb(req_fn, classify, ang_c[top], dir_c[top], rng,
                                                rounds=80, batch=32)
        n_boundary += n_eval
        if len(extra_a):
            ang_c = np.vstack([ang_c, extra_a])
            dir_c = np.concatenate([dir_c, extra_d])
            req_c = np.concatenate([req_c, _required(spec, offs[extra_d], extra_a, hi_mm)])
    seconds["boundary"] = time.perf_counter() - t0
    report("boundary", 1.0)
    if req_c.size:
        w = int(np.argmax(req_c))
        b_star, wang, wdir = float(req_c[w]), ang_c[w], int(dir_c[w])
    else:
        b_star, wang, wdir = 0.0, None, -1

    # -- (c) angular errors -------------------------------------------------------------
    t0 = time.perf_counter()
    report("monte carlo", 0.0)
    cand = req_c >= b_star - 2.0 * shift - 0.05
    s_ang, s_dir = ang_c[cand], dir_c[cand]
    s_off = offs[s_dir]
    draws = rng.uniform(-1.0, 1.0, (n_draws, 4)) * np.array([ea, eb, ea, eb])
    corners = np.array([[sa * ea, sb * eb, sc * ea, sd * eb] for sa in (-1, 1) for sb in (-1, 1)
                        for sc in (-1, 1) for sd in (-1, 1)], dtype=float)

    def b_of(err: np.ndarray, starts: int, rounds: int):
        """B(e): the best of the candidates, then a local search in the actual
        configuration c' (kept in 3D collision) raising required(c' - e).
        Returns (B, c', direction index)."""
        if not len(s_ang):
            return 0.0, None, -1
        vals = _required(spec, s_off, s_ang - err, hi_mm)
        i = int(np.argmax(vals))
        best = (float(vals[i]), s_ang[i], int(s_dir[i]))
        if rounds == 0:
            return best
        top = _distinct_top(vals, s_ang, s_dir, starts)
        fn = lambda a, d: _required(spec, offs[d], a - err, hi_mm)  # noqa: E731
        ang_b, val_b, _, _, ne = _climb(fn, classify, s_ang[top], s_dir[top], rng,
                                        rounds=rounds, batch=16, step_deg=0.5)
        counts["mc"] += ne
        j = int(np.argmax(val_b))
        if val_b[j] > best[0]:
            best = (float(val_b[j]), ang_b[j], int(s_dir[top][j]))
        return best

    counts = {"mc": 0}
    # (a) once more: the same local search without errors, from the candidates
    b0, a0, d0 = b_of(np.zeros(4), 4 * mc_starts, 4 * max(mc_rounds, 10))
    if a0 is not None and b0 > b_star:
        b_star, wang, wdir = b0, a0, d0
    samples = np.empty(n_draws)
    for k in range(n_draws):
        samples[k] = b_of(draws[k], mc_starts, mc_rounds)[0]
        if progress is not None and k % 50 == 0:
            report("monte carlo", k / n_draws)
    corner = max(b_of(c, 4 * mc_starts, 4 * max(mc_rounds, 10))[0] for c in corners)
    b_p = float(np.quantile(samples, probability, method="higher"))
    seconds["monte_carlo"] = time.perf_counter() - t0
    report("monte carlo", 1.0)
    if wang is not None:
        d3, links = pairs[wdir].distances(wang[None, :], with_links=True)
        worst = {"alpha_a": float(wang[0]), "beta_a": float(wang[1]), "alpha_b": float(wang[2]),
                 "beta_b": float(wang[3]), "direction_deg": float(dirs[wdir]),
                 "d2_mm": float(pair_segment_distances(spec, offs[wdir], wang[None, :],
                                                       b_star)[0]),
                 "d3_mm": float(d3[0]), "links": "-".join(links[0]), "required_mm": b_star}
    else:
        worst = {"alpha_a": math.nan, "beta_a": math.nan, "alpha_b": math.nan,
                 "beta_b": math.nan, "direction_deg": math.nan, "d2_mm": math.nan,
                 "d3_mm": math.nan, "links": "none", "required_mm": 0.0}

    # -- scatter: exact 3D distances of close configurations ------------------------------
    t0 = time.perf_counter()
    d2_all = pair_segment_distances(spec, offs[dir_u], ang_u, float(spec.buffer_mm))
    close = np.flatnonzero(d2_all < 4.0 * max(float(buffers.max()), b_star) + 2.0)
    pick = (rng.choice(close, size=min(n_scatter, close.size), replace=False) if close.size
            else close)
    sc_d2 = d2_all[pick]
    sc_d3 = np.empty(len(pick))
    for k, pr in enumerate(pairs):
        sel = np.flatnonzero(dir_u[pick] == k)
        if sel.size:
            sc_d3[sel] = pr.distances(ang_u[pick[sel]])
    seconds["scatter"] = time.perf_counter() - t0
    seconds["total"] = time.perf_counter() - clock

    seg = (float(spec.segment_start_mm), float(spec.segment_end(spec.buffer_mm)))
    return BufferCalibration(
        spec_name=spec.name, geometry=str(geometry.params.source), pitch_mm=pitch,
        directions_deg=[float(d) for d in dirs], n_samples=n_samples, n_boundary=n_boundary,
        n_colliding=int(len(req_c)), seed=seed, safe_buffer_mm=b_star,
        safe_buffer_uniform_mm=b_uniform, worst=worst,
        envelope_mm=float(geometry.beta_envelope_mm(*seg)),
        spec_buffer_mm=float(spec.buffer_mm), buffers_mm=[float(b) for b in buffers],
        forbidden_fraction=forb_frac, wasted_fraction=waste_frac,
        colliding_fraction=float(coll_u.mean()), angular_error_deg=(ea, eb),
        probability=probability, n_draws=n_draws, mc_buffer_mm=b_p,
        mc_share_mm=b_p - b_star, corner_buffer_mm=corner, corner_share_mm=corner - b_star,
        paper_sigma_eps_mm=float(spec.alpha_length_mm * math.radians(ea)
                                 + spec.beta_length_mm * math.radians(ea + eb)),
        mc_quantiles={str(q): float(np.quantile(samples, q)) for q in (0.5, 0.9, 0.99, 1.0)},
        scatter_d2_mm=sc_d2.tolist(), scatter_d3_mm=sc_d3.tolist(),
        mc_samples_mm=samples.tolist(), seconds=seconds,
        n_fcl_calls=int(sum(p.n_fcl_calls for p in pairs)))


def _climb(objective, classify, ang0: np.ndarray, dir0: np.ndarray, rng, rounds: int,
           batch: int, step_deg: float = 1.0):
    """Local search raising ``objective`` while staying in 3D collision.

    From each start (rows of ``ang0`` (k, 4) deg, directions ``dir0``), every round
    proposes ``batch`` Gaussian steps; the best proposal whose objective is higher
    *and* that is verified in 3D collision (``classify``: bounds, FCL where needed) is
    kept; the step shrinks (x 0.6) when none is. All starts advance together (one
    ``classify`` call per round).

    Returns
    -------
    best_ang (k, 4) deg, best_val (k,), accepted (m, 4) deg, accepted_dir (m,),
    evaluations (int: 3D classifications).
    """
    cur = np.array(ang0, dtype=np.float64).reshape(-1, 4)
    d = np.asarray(dir0, dtype=np.int64).reshape(-1)
    k = len(cur)
    val = objective(cur, d)
    step = np.full(k, float(step_deg))
    acc_a, acc_d = [], []
    n_eval = 0
    for _ in range(rounds):
        live = np.flatnonzero(step >= 1e-4)
        if live.size == 0:
            break
        noise = rng.normal(0.0, 1.0, (live.size * batch, 4))
        prop = np.repeat(cur[live], batch, axis=0) + noise * np.repeat(step[live], batch)[:, None]
        pdir = np.repeat(d[live], batch)
        owner = np.repeat(live, batch)
        pv = objective(prop, pdir)
        better = np.flatnonzero(pv > val[owner])
        col = np.zeros(len(prop), dtype=bool)
        if better.size:
            col[better] = classify(prop[better], pdir[better])
            n_eval += better.size
        moved = np.zeros(k, dtype=bool)
        for j in np.flatnonzero(col)[np.argsort(-pv[col])]:
            i = owner[j]
            if not moved[i]:
                cur[i], val[i], moved[i] = prop[j], pv[j], True
                acc_a.append(prop[j])
                acc_d.append(d[i])
        step[live[~moved[live]]] *= 0.6
    return (cur, val, np.asarray(acc_a).reshape(-1, 4), np.asarray(acc_d, dtype=np.int64),
            n_eval)


def _distinct_top(values: np.ndarray, ang: np.ndarray, dirs: np.ndarray, k: int,
                  cell_deg: float = 5.0) -> np.ndarray:
    """Indices of the ``k`` largest values whose configurations differ (5-deg cells)."""
    out, seen = [], set()
    for i in np.argsort(values)[::-1]:
        key = (int(dirs[i]), *np.floor(ang[i] / cell_deg).astype(int))
        if key in seen:
            continue
        seen.add(key)
        out.append(int(i))
        if len(out) == k:
            break
    return np.asarray(out, dtype=np.int64)


# =====================================================================================
# Markdown report + figures
# =====================================================================================
def write_report(cal: BufferCalibration, out_dir: str | Path, command: str = "") -> dict:
    """Write ``buffer_calibration.md``, ``calibration.json`` and the figures
    (``scatter_2d_3d.png``, ``wasted_space.png``, ``mc_buffer.png``) to ``out_dir``.

    Returns {"markdown": path, "json": path, "figures": [paths]}. Files are written to
    temporary names and renamed.
    """
    import json

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from models.files import atomic_write_text

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figs = []

    def save(fig, name):
        path = out / name
        tmp = out / f".{name}.tmp.png"
        fig.savefig(tmp, dpi=120, bbox_inches="tight")
        plt.close(fig)
        os.replace(tmp, path)
        figs.append(path)

    d2 = np.asarray(cal.scatter_d2_mm)
    d3 = np.asarray(cal.scatter_d3_mm)
    fig, ax = plt.subplots(figsize=(6.4, 5.0))
    col = d3 <= 0.0
    ax.scatter(d2[~col], d3[~col], s=4, alpha=0.5, label="clear in 3D")
    ax.scatter(d2[col], d3[col], s=6, color="tab:red", label="colliding in 3D (distance 0)")
    for b, style, lab in ((cal.safe_buffer_mm, "-", f"2 b* = {2 * cal.safe_buffer_mm:.3f} mm"),
                          (cal.spec_buffer_mm, "--",
                           f"2 x preset buffer {cal.spec_buffer_mm:g} mm"),
                          (cal.mc_buffer_mm, ":", f"2 b_p = {2 * cal.mc_buffer_mm:.3f} mm")):
        ax.axvline(2 * b, color="k", linestyle=style, linewidth=1, label=lab)
    ax.set_xlabel("2D model distance D2 (beta segments), mm")
    ax.set_ylabel("3D mesh distance D3 (FCL), mm")
    ax.set_title(f"{cal.spec_name}: 2D vs 3D distance ({len(d2)} configurations)")
    ax.legend(fontsize=8)
    save(fig, "scatter_2d_3d.png")

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(cal.buffers_mm, cal.wasted_fraction, marker="o", ms=3,
            label="2D-forbidden but 3D-safe (share of forbidden)")
    ax.plot(cal.buffers_mm, cal.forbidden_fraction, marker=".", ms=3,
            label="2D-forbidden (share of all configurations)")
    ax.axvline(cal.safe_buffer_mm, color="k", linewidth=1, label=f"b* {cal.safe_buffer_mm:.3f} mm")
    ax.axvline(cal.mc_buffer_mm, color="k", linestyle=":", linewidth=1,
               label=f"b_p (p = {cal.probability:g}) {cal.mc_buffer_mm:.3f} mm")
    ax.set_xlabel("collision buffer, mm")
    ax.set_ylabel("fraction")
    ax.set_ylim(0, 1)
    ax.set_title(f"{cal.spec_name}: space wasted by the 2D model ({cal.n_samples} samples)")
    ax.legend(fontsize=8)
    save(fig, "wasted_space.png")

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.hist(cal.mc_samples_mm, bins=50)
    ax.axvline(cal.mc_buffer_mm, color="k", linestyle=":", label=f"b_p {cal.mc_buffer_mm:.3f} mm")
    ax.axvline(cal.safe_buffer_mm + cal.paper_sigma_eps_mm, color="tab:red", linestyle="--",
               label=f"b* + paper sigma_eps {cal.safe_buffer_mm + cal.paper_sigma_eps_mm:.3f} mm")
    ax.set_xlabel("buffer needed for one draw of angular errors B(e), mm")
    ax.set_ylabel("draws")
    ax.set_title(f"{cal.n_draws} draws, errors +-{cal.angular_error_deg[0]:g} / "
                 f"+-{cal.angular_error_deg[1]:g} deg")
    ax.legend(fontsize=8)
    save(fig, "mc_buffer.png")

    w = cal.worst
    rows = "\n".join(f"| {b:.2f} | {f:.4f} | {wf:.4f} |"
                     for b, f, wf in zip(cal.buffers_mm, cal.forbidden_fraction,
                                         cal.wasted_fraction))
    md = f"""# Collision-buffer calibration: {cal.spec_name}

{('Command: `' + command + '`') if command else ''}

Geometry: `{cal.geometry}`. Two robots at pitch {cal.pitch_mm:.3f} mm in the neighbour
directions {', '.join(f'{d:g}' for d in cal.directions_deg)} deg. 2D model: beta segments,
"safe in 2D at buffer b" = D2 > 2 b. 3D: exact solid distance of the collision meshes
(FCL), "safe in 3D" = D3 > 0.

Samples: **{cal.n_samples} uniform (Sobol) configurations**, {cal.n_boundary} more near the
boundary (jittered copies + local search), {cal.n_colliding} of them 3D-colliding;
{cal.n_draws} Monte Carlo draws; seed {cal.seed}. {cal.n_fcl_calls} FCL calls;
run time {cal.seconds.get('total', 0.0):.1f} s.

## (a) Smallest buffer for which safe in 2D implies safe in 3D

**b\\* = {cal.safe_buffer_mm:.4f} mm** (uniform samples alone: {cal.safe_buffer_uniform_mm:.4f} mm;
the mesh's beta envelope around the 2D segment, an upper bound when only beta arms touch:
{cal.envelope_mm:.4f} mm). Preset buffer: {cal.spec_buffer_mm:g} mm.

Worst configuration found (verified 3D contact, links {w['links']}, 3D distance
{w['d3_mm']:.4f} mm):

| robot | alpha deg | beta deg |
|---|---|---|
| A (origin) | {w['alpha_a']:.4f} | {w['beta_a']:.4f} |
| B (direction {w['direction_deg']:g} deg) | {w['alpha_b']:.4f} | {w['beta_b']:.4f} |

2D distance there: {w['d2_mm']:.4f} mm (= 2 b\\*).

![2D vs 3D distance](scatter_2d_3d.png)

## (b) Space wasted by the 2D model

Share of the {cal.n_samples} uniform configurations that the 2D model forbids (D2 <= 2 b),
and the share of those that are safe in 3D. 3D-colliding share of all configurations:
{cal.colliding_fraction:.4f}.

| buffer mm | 2D-forbidden | of which 3D-safe (wasted) |
|---|---|---|
{rows}

![wasted space](wasted_space.png)

## (c) Angular errors (Monte Carlo)

Errors uniform in +-{cal.angular_error_deg[0]:g} deg (alpha) and +-{cal.angular_error_deg[1]:g}
deg (beta), independent per robot and axis; {cal.n_draws} draws. For each draw, B(e) is the
buffer needed for every 2D-safe commanded configuration to stay 3D-safe.

| quantity | mm |
|---|---|
| b\\* (no errors) | {cal.safe_buffer_mm:.4f} |
| **b_p, p = {cal.probability:g}** | **{cal.mc_buffer_mm:.4f}** |
| angular-error share b_p - b\\* | {cal.mc_share_mm:.4f} |
| worst corner (all errors at their bounds) | {cal.corner_buffer_mm:.4f} (share {cal.corner_share_mm:.4f}) |
| paper's analytic sigma_eps (Sayres 2021 Eq. 12) | {cal.paper_sigma_eps_mm:.4f} |
| B(e) median / 90 % / 99 % / max | {' / '.join(f"{cal.mc_quantiles[k]:.4f}" for k in ('0.5', '0.9', '0.99', '1.0'))} |

![Monte Carlo](mc_buffer.png)

Stage times (s): {', '.join(f'{k} {v:.1f}' for k, v in cal.seconds.items())}.
"""
    md_path = out / "buffer_calibration.md"
    atomic_write_text(md_path, md)
    js_path = out / "calibration.json"
    atomic_write_text(js_path, json.dumps(cal.to_dict(), indent=1))
    return {"markdown": md_path, "json": js_path, "figures": figs}
