"""Target configurations: seeded random assignment (Sayres 2021 Sect. 4.1) and checks.

A target is an (alpha, beta) configuration in degrees. Random targets put the fiber
uniformly in the patrol annulus, right-armed, and are redrawn until the robot's capsule
is clear of every robot already assigned and of every fiducial.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.models.errors import TargetError
from rfp_twin.models.geometry2d import beta_segment, segment_distance
from rfp_twin.models.kinematics import fiber_polar, inverse_fiber, sample_patrol_zone
from rfp_twin.models.layout.columns import FIBER_COLUMNS, fit_to_limits, robot_fibers

#: Draws per robot before random assignment gives up.
POOL_SIZE = 256


@njit(cache=True)
def _assign_from_pool(base_xy, pool, fixed, order, nbr_ptr, nbr_idx, fid_ptr, fid_idx, fid_xy,
                      fid_end_xy, fid_buffer, l_alpha, seg_start, seg_end, buffer, margin, out):
    """Pick for each robot (in ``order``) the first pool entry clear of assigned robots.

    pool : (n, k, 2) candidate configurations; fixed : (n,) bool, robots whose ``out``
    row is already set (offline robots, kept targets). ``l_alpha, seg_start, seg_end,
    buffer`` (n,) mm per robot; obstacles are segments ``fid_xy``-``fid_end_xy`` (m, 2) mm
    with keep-out ``fid_buffer`` (m,) mm. Returns the index of the first robot for which
    no candidate fits, or -1.
    """
    n = base_xy.shape[0]
    assigned = fixed.copy()
    for oi in range(order.shape[0]):
        i = order[oi]
        if fixed[i]:
            continue
        found = False
        for c in range(pool.shape[1]):
            a = pool[i, c, 0]
            b = pool[i, c, 1]
            x0, y0, x1, y1 = beta_segment(base_xy[i, 0], base_xy[i, 1], a, b, l_alpha[i],
                                          seg_start[i], seg_end[i])
            ok = True
            for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
                j = nbr_idx[k]
                if not assigned[j]:
                    continue
                u0, v0, u1, v1 = beta_segment(base_xy[j, 0], base_xy[j, 1], out[j, 0], out[j, 1],
                                              l_alpha[j], seg_start[j], seg_end[j])
                if segment_distance(x0, y0, x1, y1, u0, v0, u1, v1) <= buffer[i] + buffer[j] + margin:
                    ok = False
                    break
            if ok:
                for k in range(fid_ptr[i], fid_ptr[i + 1]):
                    f = fid_idx[k]
                    if segment_distance(x0, y0, x1, y1, fid_xy[f, 0], fid_xy[f, 1],
                                        fid_end_xy[f, 0], fid_end_xy[f, 1]) <= \
                            buffer[i] + fid_buffer[f] + margin:
                        ok = False
                        break
            if ok:
                out[i, 0] = a
                out[i, 1] = b
                assigned[i] = True
                found = True
                break
        if not found:
            return i
    return -1


def random_targets(geom, rng: np.random.Generator, *, fixed: np.ndarray | None = None,
                   initial: np.ndarray | None = None, margin_mm: float = 0.0,
                   robots: np.ndarray | None = None, attempts: int = 20) -> np.ndarray:
    """Seeded random right-armed, mutually clear targets.

    Parameters
    ----------
    geom : rfp_twin.models.array.ArrayGeometry
        Layout, spec and buffers of the array.
    rng : numpy Generator
    fixed : (n,) bool, robots that keep their row of ``initial`` (offline robots, or
        targets already assigned when only a few are redrawn).
    initial : (n, 2) deg, rows for fixed robots.
    margin_mm : extra clearance beyond Eq. 3 (the reverse planner uses its MD so that no
        robot starts inside another's step-rule band).
    robots : indices to (re)draw, in this order; default all non-fixed robots in index
        order, as in the paper.
    attempts : when some robot has no clear spot left (crowded buffers), the whole draw
        starts again, up to this many times.

    Returns
    -------
    (n, 2) float64 configurations, deg.
    """
    error = None
    for _ in range(max(1, attempts)):
        try:
            return _draw_targets(geom, rng, fixed, initial, margin_mm, robots)
        except TargetError as exc:
            error = exc
    raise error


def _draw_targets(geom, rng, fixed, initial, margin_mm, robots) -> np.ndarray:
    n = geom.n_robots
    out = np.zeros((n, 2)) if initial is None else np.array(initial, dtype=np.float64)
    fixed_mask = np.zeros(n, dtype=bool) if fixed is None else np.asarray(fixed, dtype=bool).copy()
    if robots is None:
        order = np.flatnonzero(~fixed_mask)
    else:
        order = np.asarray(robots, dtype=np.int64)
        fixed_mask[order] = False
    args = (geom.nbr_ptr, geom.nbr_idx, geom.fid_ptr, geom.fid_idx, geom.fid_xy,
            geom.fid_end_xy, geom.fid_buffer, geom.alpha_len, geom.seg_start, geom.seg_end,
            geom.buffer, margin_mm, out)
    sample = patrol_sampler(geom)
    pos = 0
    while pos < order.size:
        rest = order[pos:]
        pool = np.zeros((n, POOL_SIZE, 2))
        pool[rest] = sample(rng, rest, POOL_SIZE)
        bad = _assign_from_pool(geom.base_xy, pool, fixed_mask, rest, *args)
        if bad < 0:
            break
        # a crowded spot: keep drawing for this robot alone, in larger batches
        pos += int(np.flatnonzero(rest == bad)[0])
        fixed_mask[order[:pos]] = True
        for size in (4096,):
            big = np.zeros((n, size, 2))
            big[bad] = sample(rng, np.array([bad]), size)[0]
            if _assign_from_pool(geom.base_xy, big, fixed_mask, np.array([bad]), *args) < 0:
                break
        else:
            raise TargetError(f"robot {int(geom.robot_ids[bad])}: no clear random target found in "
                              f"{POOL_SIZE + 4096} draws (buffer {geom.buffer[bad]:.3f} mm is "
                              "too crowded)")
        fixed_mask[bad] = True
        pos += 1
    return out


#: Rounds of redrawing the configurations that fall outside a robot's travel range.
MAX_LIMIT_REDRAWS = 64


def patrol_sampler(geom):
    """``sample(rng, robots (r,), k) -> (r, k, 2)`` deg: right-armed configurations with the
    fiber uniform (by area) in each robot's patrol annulus, within its travel range.

    Nominal layouts draw with the spec's arms (Sayres 2021 Sect. 4.1, the paper's fiber at
    ``beta_length_mm``); a layout that carries fibers (a calibrated instrument) draws each
    robot's metrology fiber in its own annulus (its alpha arm, its fiber), as SDSS-V does.
    Alpha is then turned into the robot's range and a draw whose beta falls outside it
    (a spec with a narrower beta range, or encoder offsets that shift it) is drawn again.
    """
    spec = geom.spec
    # draw(rng, robots, k): k draws of each of ``robots``, (robots.size * k, 2) deg, robot-major
    if not any(c in geom.layout.extra for c in FIBER_COLUMNS["metrology"]) and geom.uniform:
        def draw(rng, robots, k=1):
            return sample_patrol_zone(rng, robots.size * k, spec.alpha_length_mm,
                                      spec.beta_length_mm)
    else:
        met = robot_fibers(geom.layout, {"metrology": (spec.beta_length_mm, 0.0)})[:, 0]
        length, _ = fiber_polar(met)
        la = geom.alpha_len

        def draw(rng, robots, k=1):
            rows = np.repeat(robots, k)
            la_r, lb_r = la[rows], length[rows]
            r_in, r_out = np.abs(la_r - lb_r), la_r + lb_r
            r = np.sqrt(rng.uniform(r_in * r_in, r_out * r_out))
            r = np.clip(r, r_in + 1e-9, r_out - 1e-9)
            ang = rng.uniform(0.0, 2.0 * np.pi, size=r.size)
            xy = np.column_stack([r * np.cos(ang), r * np.sin(ang)])
            return inverse_fiber(np.zeros_like(xy), xy, la_r, met[rows])

    def sample(rng, robots, k):
        # k draws of each robot, fitted with its limits broadcast (not repeated k times)
        out, inside = fit_to_limits(draw(rng, robots, k).reshape(robots.size, k, 2),
                                    geom.limits[robots][:, None, :])
        out, inside = out.reshape(-1, 2), inside.reshape(-1)
        for _ in range(MAX_LIMIT_REDRAWS):
            if inside.all():
                return out.reshape(robots.size, k, 2)
            again = np.flatnonzero(~inside)
            rows_again = robots[again // k]
            out[again], inside[again] = fit_to_limits(draw(rng, rows_again),
                                                      geom.limits[rows_again])
        bad = int(robots[np.flatnonzero(~inside)[0] // k])
        raise TargetError(f"robot {int(geom.robot_ids[bad])}: no random target within its "
                          f"travel range {geom.limits[bad].tolist()} deg in "
                          f"{MAX_LIMIT_REDRAWS} redraws")
    return sample


def check_angles(geom, angles, what: str | None = None) -> np.ndarray:
    """(n, 2) float64 configurations, deg, after checking shape and joint limits.

    Raises TargetError if ``angles`` is not one (alpha, beta) row per robot, or a value
    is NaN or outside the spec's limits; the message names the robot, the field and the
    allowed range. ``what`` names the array in the messages ("start", ...); None: the
    messages of :func:`check_targets`.
    """
    a = np.asarray(angles, dtype=np.float64)
    if a.shape != (geom.n_robots, 2):
        raise TargetError(f"{what or 'targets'}: shape {a.shape}; allowed: ({geom.n_robots}, 2) "
                          "(one (alpha, beta) row per robot)")
    check_limits(geom, a, geom.robot_ids, what)
    return a


def check_limits(geom, angles: np.ndarray, ids, what: str | None = None) -> None:
    """Raise TargetError for the first NaN or out-of-limit angle of ``angles`` (m, 2) deg,
    whose rows belong to robots ``ids`` (m,); each robot has its own range
    (:attr:`rfp_twin.models.array.ArrayGeometry.limits`); ``what`` prefixes the message."""
    prefix = f"{what}: " if what else ""
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    rows = np.arange(geom.n_robots) if np.array_equal(ids, geom.robot_ids) else \
        np.array([geom.layout.robot_index(int(r)) for r in ids], dtype=np.int64)
    lim = geom.limits[rows]
    for axis, col in (("alpha", 0), ("beta", 1)):
        v = angles[:, col]
        lo, hi = lim[:, 2 * col], lim[:, 2 * col + 1]
        bad = np.flatnonzero(~np.isfinite(v) | (v < lo) | (v > hi))
        if bad.size:
            k = int(bad[0])
            raise TargetError(f"{prefix}robot {int(ids[k])}: field '{axis}' = "
                              f"{float(v[k])!r}; allowed: [{float(lo[k])}, {float(hi[k])}] deg")


def _first_overlap(clearance: np.ndarray, pairs: np.ndarray):
    """(first pair whose clearance is <= 0, its overlap mm, how many pairs overlap), or None."""
    hit = np.flatnonzero(clearance <= 0.0)
    if hit.size == 0:
        return None
    return pairs[hit[0]], float(-clearance[hit[0]]), int(hit.size)


def check_targets(geom, targets: np.ndarray, movable: np.ndarray | None = None) -> None:
    """Raise TargetError if targets are NaN, out of range, or collide (Eq. 3).

    targets : (n, 2) deg. The message names the robot(s), the field and the allowed range.
    """
    targets = check_angles(geom, targets)
    bad = _first_overlap(geom.pair_clearance(targets), geom.pairs)
    if bad is not None:
        (i, j), overlap, count = bad
        raise TargetError(f"robots {int(geom.robot_ids[i])} and {int(geom.robot_ids[j])}: targets "
                          f"collide (capsules overlap by {overlap:.3f} mm; allowed: clearance > 0 "
                          f"at buffer {geom.buffer[i]:.3f} mm); {count} colliding pair(s) in all")
    bad = _first_overlap(geom.fiducial_clearance(targets), geom.robot_fid_pairs)
    if bad is not None:
        (i, f), overlap, _ = bad
        raise TargetError(f"robot {int(geom.robot_ids[i])}: target collides with fiducial "
                          f"{int(geom.fiducial_ids[f])} (overlap {overlap:.3f} mm)")
