"""The buffer calibration: :func:`calibrate_buffer` (mm, deg, s).

Two robots of one design sit at the layout's pitch, robot B in each neighbour direction
of the layout (modulo 180 deg: the two robots are identical). For a configuration ``c =
(alpha_A, beta_A, alpha_B, beta_B)`` (deg), ``D2(c; b)`` is the 2D model's distance
(:mod:`rfp_twin.validation.buffer.model2d`; "safe in 2D at buffer b" is ``D2 > 2 b``) and
``D3(c)`` the true 3D (solid) distance of the two robots' collision meshes
(:class:`rfp_twin.validation.mesh3d.RobotPair`: lower bounds in numba, FCL where they cannot
decide; "safe in 3D" is ``D3 > 0``). ``required(c)`` is the smallest buffer whose 2D
model forbids ``c``.

What is computed
----------------
(a) *Smallest safe buffer* ``b*``: "safe in 2D implies safe in 3D" holds for a buffer
    ``b`` iff every 3D-colliding configuration has ``required(c) <= b``, so
    ``b* = max required(c)`` over 3D-colliding ``c``. Estimated on a Sobol sample of
    the joint ranges (``n_samples``), a densified set near the largest values
    (jittered copies) and a local search (hill climb on ``required`` while staying in
    3D collision, verified with FCL at every step). It is a lower estimate of the true
    supremum (every reported configuration is a verified 3D collision); the beta
    envelope of the mesh (:meth:`rfp_twin.models.geometry.RobotGeometry.beta_envelope_mm`) is an
    upper bound when only the beta arms can touch.
(b) *Space wasted by the 2D model*: per buffer, among the uniform samples the 2D model
    forbids (``D2 <= 2 b``), the fraction that is safe in 3D. Uniform samples of the
    joint ranges measure volume, so this is the share of the forbidden configuration
    space that the 3D robot could use.
(c) *Angular errors* (Monte Carlo, :mod:`rfp_twin.validation.buffer.montecarlo`): ``b_p``, the
    ``p``-quantile of the buffer ``B(e)`` one draw ``e`` of the errors calls for, keeps
    3D safety with probability ``p`` (over the angular errors); ``b_p - b*`` is the
    angular-error share of the buffer, set beside the paper's analytic ``sigma_eps =
    l_alpha ea + l_beta (ea + eb)`` (0.97 mm, Sayres et al. 2021, Eq. 12). The worst
    corner (every error at its bound, 16 sign combinations) is reported too.
(d) *Metrology spread* (optional, ``instrument``): the same Monte Carlo with each draw's
    angular errors (the same draws as (c)) plus the measured deviations of two robots of
    a real instrument (:mod:`rfp_twin.validation.buffer.metrology`): ``b_p`` with the
    spread, next to the angular-only one.

The robot is the 3D meshes of a geometry (:class:`rfp_twin.validation.buffer.pairs.MeshPairs`)
or, with ``capsule_radius_mm``, the 2D capsule model itself
(:class:`rfp_twin.validation.buffer.pairs.CapsulePairs`: ``b* = r`` by construction, the
reference for the other two parts).

Randomness: every function takes a seed; same seed, same result.
"""
from __future__ import annotations

import math
import time
from typing import Callable, Optional

import numpy as np

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.models.geometry import RobotGeometry, geometry_for_spec
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import RobotSpec
from rfp_twin.validation.buffer.metrology import MetrologySpread, perturbed_configurations
from rfp_twin.validation.buffer.model2d import pair_segment_distances, required_buffer
from rfp_twin.validation.buffer.montecarlo import (ErrorBuffer, corner_errors, error_buffers,
                                                   spread_buffers)
from rfp_twin.validation.buffer.pairs import CapsulePairs, MeshPairs
from rfp_twin.validation.buffer.report import BufferCalibration
from rfp_twin.validation.buffer.sampling import (climb, distinct_top, neighbour_directions,
                                        uniform_configurations)

#: Buffers at which the wasted space is tabulated by default, mm.
DEFAULT_BUFFERS_MM = tuple(np.round(np.arange(1.0, 4.0001, 0.1), 3))


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
                     instrument=None, capsule_radius_mm: float | None = None,
                     label: str | None = None,
                     progress: Optional[Callable[[str, float], None]] = None
                     ) -> BufferCalibration:
    """Calibrate the 2D collision buffer against the 3D meshes (see the module docstring).

    Parameters
    ----------
    spec : RobotSpec
    geometry : RobotGeometry, optional
        Default :func:`rfp_twin.models.geometry.geometry_for_spec`. Not used with
        ``capsule_radius_mm``.
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
    instrument : str or MetrologySpread, optional
        Part (d): ``sdss-v-apo``, ``sdss-v-lco`` or a calibration folder (deviations from
        the spec's alpha arm and the geometry's metrology fiber x).
    capsule_radius_mm : float, optional
        Calibrate the 2D capsule model of this radius instead of meshes.
    label : str, optional
        Name of the robot in the report (default: the geometry's source).
    progress : callable(stage, fraction), optional

    Returns
    -------
    BufferCalibration

    Raises
    ------
    SpecError
        A parameter out of range; an instrument spread on robots whose links other than
        the beta arms could touch (the spread is applied by moving the configuration,
        exact for beta-beta contacts only).
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
    rng = np.random.default_rng(seed)
    seconds: dict[str, float] = {}
    hi_mm = float(spec.pitch_mm)

    pitch, dirs = neighbour_directions(layout, spec.pitch_mm)
    offs = pitch * np.column_stack([np.cos(np.radians(dirs)), np.sin(np.radians(dirs))])
    if capsule_radius_mm is not None:
        radius = _check(capsule_radius_mm, "capsule_radius_mm", 1e-6, spec.pitch_mm / 2.0)
        pairs = CapsulePairs(spec, radius, offs)
        name = label or f"2D capsule model, radius {radius:g} mm"
        metrology_x = None
    else:
        geometry = geometry if geometry is not None else geometry_for_spec(spec)
        pairs = MeshPairs(geometry, offs)
        name = label or str(geometry.params.source)
        metrology_x = next((x for n, x, _ in geometry.params.fibers if n == "metrology"), None)
    spread = _spread(instrument, spec, metrology_x, pairs)
    classify = pairs.classify

    def required(ang: np.ndarray, dir_idx: np.ndarray) -> np.ndarray:
        """Smallest buffer whose 2D model forbids each configuration, mm."""
        return required_buffer(spec, offs[dir_idx], ang, hi_mm)

    # -- uniform samples -------------------------------------------------------------
    t0 = time.perf_counter()
    report("uniform samples", 0.0)
    ang_u = uniform_configurations(spec, n_samples, seed)
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
    req_c = required(ang_c, dir_c)
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
        req_c = np.concatenate([req_c, required(jit[jcol], jdir[jcol])])
        # local search from the best few distinct configurations
        top = distinct_top(req_c, ang_c, dir_c, 8)
        _, _, extra_a, extra_d, n_eval = climb(required, classify, ang_c[top], dir_c[top], rng,
                                               rounds=80, batch=32)
        n_boundary += n_eval
        if len(extra_a):
            ang_c = np.vstack([ang_c, extra_a])
            dir_c = np.concatenate([dir_c, extra_d])
            req_c = np.concatenate([req_c, required(extra_a, extra_d)])
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
    draws = rng.uniform(-1.0, 1.0, (n_draws, 4)) * np.array([ea, eb, ea, eb])
    b_of = ErrorBuffer(required, classify, ang_c[cand], dir_c[cand], rng)
    (b0, a0, d0), samples, corner = error_buffers(b_of, draws, corner_errors(ea, eb),
                                                  mc_starts, mc_rounds, report)
    # (a) once more: the same local search without errors, from the candidates
    if a0 is not None and b0 > b_star:
        b_star, wang, wdir = b0, a0, d0
    b_p = float(np.quantile(samples, probability, method="higher"))
    seconds["monte_carlo"] = time.perf_counter() - t0
    report("monte carlo", 1.0)

    # -- (d) metrology spread: the same angular draws plus two real robots each ----------
    spread_out = {}
    if spread is not None:
        t0 = time.perf_counter()
        report("metrology spread", 0.0)
        srng = np.random.default_rng([seed, 1])     # own stream: (a)-(c) stay as without it
        devs = spread.draw(srng, n_draws)
        reach = shift + spread.max_displacement_mm()
        cand_s = req_c >= b_star - 2.0 * reach - 0.05
        la = float(spec.alpha_length_mm)
        b_of_s = ErrorBuffer(required, classify, ang_c[cand_s], dir_c[cand_s], srng,
                             actual=lambda a, d, dev: perturbed_configurations(a, dev, la,
                                                                               offs[d]))
        s_samples = spread_buffers(b_of_s, draws, devs, mc_starts, mc_rounds, report)
        b_ps = float(np.quantile(s_samples, probability, method="higher"))
        spread_out = dict(
            instrument=spread.instrument, metrology=spread.summary(), spread_buffer_mm=b_ps,
            spread_change_mm=b_ps - b_p, spread_samples_mm=s_samples.tolist(),
            spread_quantiles={str(q): float(np.quantile(s_samples, q))
                              for q in (0.5, 0.9, 0.99, 1.0)})
        seconds["metrology_spread"] = time.perf_counter() - t0
        report("metrology spread", 1.0)

    if wang is not None:
        d3, links = pairs.contact(wang, wdir)
        worst = {"alpha_a": float(wang[0]), "beta_a": float(wang[1]), "alpha_b": float(wang[2]),
                 "beta_b": float(wang[3]), "direction_deg": float(dirs[wdir]),
                 "d2_mm": float(pair_segment_distances(spec, offs[wdir], wang[None, :],
                                                       b_star)[0]),
                 "d3_mm": d3, "links": links, "required_mm": b_star}
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
    sc_d3 = pairs.distances(ang_u[pick], dir_u[pick])
    seconds["scatter"] = time.perf_counter() - t0
    seconds["total"] = time.perf_counter() - clock

    seg = (float(spec.segment_start_mm), float(spec.segment_end(spec.buffer_mm)))
    return BufferCalibration(
        spec_name=spec.name, geometry=name, model=pairs.kind, pitch_mm=pitch,
        directions_deg=[float(d) for d in dirs], n_samples=n_samples, n_boundary=n_boundary,
        n_colliding=int(len(req_c)), seed=seed, safe_buffer_mm=b_star,
        safe_buffer_uniform_mm=b_uniform, worst=worst,
        envelope_mm=pairs.envelope_mm(seg),
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
        n_fcl_calls=pairs.n_fcl_calls, **spread_out)


def _spread(instrument, spec: RobotSpec, metrology_x, pairs) -> MetrologySpread | None:
    """The instrument's :class:`MetrologySpread` (None without one), checked usable: the
    spread moves the configuration, which is exact only when beta arm to beta arm is the
    only contact the moved robots can make."""
    if instrument is None:
        return None
    if isinstance(instrument, MetrologySpread):
        spread = instrument
    else:
        kw = {} if metrology_x is None else {"nominal_metrology_mm": float(metrology_x)}
        spread = MetrologySpread.from_instrument(instrument, float(spec.alpha_length_mm), **kw)
    other = pairs.other_contacts(2.0 * spread.max_displacement_mm())
    if other:
        raise field_error(SpecError, "instrument", spread.instrument,
                          "robots whose only possible contact is beta arm to beta arm (these "
                          f"links could touch too: {', '.join(other)})", "calibrate_buffer")
    return spread
