"""Numba kernels of the search's collision tests: beta segments along a path and the
step rule (Sayres 2021 Eqs. 6-7) against moving obstacles, static obstacles and points.

:class:`rfp_twin.planners.roadmap.alpha_beta.world.AlphaBetaWorld` builds the obstacle tables and
calls these in its ``collides`` / ``forbidden`` black boxes; :func:`pair_conflict`
also serves :func:`rfp_twin.planners.deadlocks.search.trim.trim_tails`.

Units: angles in deg, lengths in mm; a segment is (x0, y0, x1, y1), the beta arm from
``s0`` to ``s1`` mm along it; shapes in each docstring (T = steps of a time table).
``l_alpha``, ``s0``, ``s1`` are scalars of the one robot concerned (its own alpha length
and collision segment, ``geom.alpha_len[i]`` etc.); the other robots enter as segment
tables built with their own values, the thresholds carry each pair's buffers.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.geometry2d import (beta_segment, point_segment_distance, segment_distance,
                                        segments_within)
from rfp_twin.planners.roadmap.sweep import ACTIONS, action_step, action_taken


@njit(cache=True)
def segments_at(base_x, base_y, ang, l_alpha, s0, s1):
    """Beta segments (x0, y0, x1, y1) of one robot at each row of ang (T, 2) deg: (T, 4)."""
    out = np.empty((ang.shape[0], 4))
    for k in range(ang.shape[0]):
        x0, y0, x1, y1 = beta_segment(base_x, base_y, ang[k, 0], ang[k, 1], l_alpha, s0, s1)
        out[k, 0] = x0
        out[k, 1] = y0
        out[k, 2] = x1
        out[k, 3] = y1
    return out


#: Steps per block of :func:`block_discs`.
DISC_BLOCK = 16


@njit(cache=True)
def block_discs(obs_seg):
    """Discs holding each moving obstacle's beta segment over blocks of
    :data:`DISC_BLOCK` steps: (n_blocks, n_obs, 3) centre x, y and radius, mm, from
    ``obs_seg`` (T + 1, n_obs, 4). Block b holds steps ``b * DISC_BLOCK`` to
    ``(b + 1) * DISC_BLOCK - 1``."""
    n_t = obs_seg.shape[0]
    n_b = (n_t + DISC_BLOCK - 1) // DISC_BLOCK
    out = np.empty((n_b, obs_seg.shape[1], 3))
    for b in range(n_b):
        lo = b * DISC_BLOCK
        hi = min(n_t, lo + DISC_BLOCK)
        for o in range(obs_seg.shape[1]):
            x_lo = y_lo = math.inf
            x_hi = y_hi = -math.inf
            for k in range(lo, hi):
                for e in range(2):
                    x_lo = min(x_lo, obs_seg[k, o, 2 * e])
                    x_hi = max(x_hi, obs_seg[k, o, 2 * e])
                    y_lo = min(y_lo, obs_seg[k, o, 2 * e + 1])
                    y_hi = max(y_hi, obs_seg[k, o, 2 * e + 1])
            cx = 0.5 * (x_lo + x_hi)
            cy = 0.5 * (y_lo + y_hi)
            r = 0.0
            for k in range(lo, hi):
                for e in range(2):
                    r = max(r, math.hypot(obs_seg[k, o, 2 * e] - cx, obs_seg[k, o, 2 * e + 1] - cy))
            out[b, o, 0] = cx
            out[b, o, 1] = cy
            out[b, o, 2] = r * (1.0 + 1e-12) + 1e-9
    return out


@njit(cache=True)
def listed_blocker(x0, y0, x1, y1, rho, t, obs_seg, obs_rho, obs_d, obs_th, listed, n_listed):
    """The first of the moving obstacles ``listed[:n_listed]`` (increasing; the others
    known to be clear) that a beta segment (x0, y0, x1, y1) mm, rho its farthest point
    from the robot's base, meets at step t, or -1. Tables as :func:`moving_collisions`; t
    is clamped to the table. Two base disks farther apart than the threshold are skipped
    before the exact test."""
    n_t = obs_seg.shape[0]
    k = int(round(t))
    if k < 0:
        k = 0
    elif k >= n_t:
        k = n_t - 1
    for r in range(n_listed):
        o = listed[r]
        if obs_d[o] - rho - obs_rho[k, o] > obs_th[o]:
            continue
        if segments_within(x0, y0, x1, y1, obs_seg[k, o, 0], obs_seg[k, o, 1],
                           obs_seg[k, o, 2], obs_seg[k, o, 3], obs_th[o]):
            return o
    return -1


@njit(cache=True)
def moving_collisions(q, t, bx, by, l_alpha, s0, s1, obs_seg, obs_rho, obs_d, obs_th, out, hits):
    """Moving-obstacle test of one robot.

    q : (m, 2) deg; t : (m,) step index (whole numbers; clamped to the table)
    obs_seg : (T + 1, n_obs, 4) obstacle beta segments at each step, mm
    obs_rho : (T + 1, n_obs) farthest point of each obstacle segment from its base, mm
    obs_d : (n_obs,) base-to-base distance, mm
    obs_th : (n_obs,) clearance threshold per obstacle (buffer_i + buffer_j + MD), mm
    out : (m,) bool, written
    hits : (n_obs,) int64, incremented for the first obstacle each colliding query meets
    """
    everyone = np.arange(obs_seg.shape[1])
    for r in range(q.shape[0]):
        x0, y0, x1, y1 = beta_segment(bx, by, q[r, 0], q[r, 1], l_alpha, s0, s1)
        rho = math.sqrt(max((x0 - bx) ** 2 + (y0 - by) ** 2, (x1 - bx) ** 2 + (y1 - by) ** 2))
        o = listed_blocker(x0, y0, x1, y1, rho, t[r], obs_seg, obs_rho, obs_d, obs_th,
                           everyone, everyone.size)
        if o >= 0:
            hits[o] += 1
        out[r] = o >= 0


#: :func:`sweep_layers` outcomes.
SWEEP_FOUND, SWEEP_FAILED, SWEEP_BUDGET = 0, 1, 2


@njit(cache=True)
def _place_action(seg, disc, a_, p, Q, frac, da, db, bx, by, l_alpha, s0, s1, n_sub):
    """Beta segments of action ``a_`` from position p at its first ``n_sub`` sub-checks
    into ``seg[a_, p]`` (x0, y0, x1, y1, reach from the base), and a disc holding them
    into ``disc[a_, p]`` (centre x, y, radius), mm."""
    x_lo = y_lo = math.inf
    x_hi = y_hi = -math.inf
    for j in range(n_sub):
        x0, y0, x1, y1 = beta_segment(bx, by, Q[p, 0] + frac[j] * da, Q[p, 1] + frac[j] * db,
                                      l_alpha, s0, s1)
        seg[a_, p, j, 0] = x0
        seg[a_, p, j, 1] = y0
        seg[a_, p, j, 2] = x1
        seg[a_, p, j, 3] = y1
        seg[a_, p, j, 4] = math.sqrt(max((x0 - bx) ** 2 + (y0 - by) ** 2,
                                         (x1 - bx) ** 2 + (y1 - by) ** 2))
        x_lo = min(x_lo, x0, x1)
        x_hi = max(x_hi, x0, x1)
        y_lo = min(y_lo, y0, y1)
        y_hi = max(y_hi, y0, y1)
    cx = 0.5 * (x_lo + x_hi)
    cy = 0.5 * (y_lo + y_hi)
    r = 0.0
    for j in range(n_sub):
        r = max(r, math.hypot(seg[a_, p, j, 0] - cx, seg[a_, p, j, 1] - cy),
                math.hypot(seg[a_, p, j, 2] - cx, seg[a_, p, j, 3] - cy))
    disc[a_, p, 0] = cx
    disc[a_, p, 1] = cy
    disc[a_, p, 2] = r * (1.0 + 1e-12) + 1e-9


@njit(cache=True)
def _near_obstacles(d, t_lo, t_hi, n_t, obs_blk, obs_th, listed):
    """Obstacles that may come within their threshold of disc ``d`` (x, y, r) at a step
    from ``t_lo`` to ``t_hi`` (rounded and clamped as the checks read the table), into
    ``listed`` in increasing order; returns how many."""
    k_lo = min(max(int(round(t_lo)), 0), n_t - 1)
    k_hi = min(max(int(round(t_hi)), 0), n_t - 1)
    n = 0
    for o in range(obs_blk.shape[1]):
        for b in range(k_lo // DISC_BLOCK, k_hi // DISC_BLOCK + 1):
            if math.hypot(d[0] - obs_blk[b, o, 0], d[1] - obs_blk[b, o, 1]) - d[2] \
                    - obs_blk[b, o, 2] <= obs_th[o] + 1e-9:
                listed[n] = o
                n += 1
                break
    return n


@njit(cache=True, nogil=True)
def sweep_layers(Q, D, frac, k_static, k_max, t0, dt, goal_after, nodes_left,
                 bx, by, l_alpha, s0, s1, obs_seg, obs_rho, obs_d, obs_th, obs_blk, hits):
    """The layer loop of :class:`rfp_twin.planners.roadmap.sweep.PathSweep` compiled, with
    the moving-obstacle test of :func:`moving_collisions` as its black box: the same
    reachable sets, trajectory and node count as the Python loop, with fewer checks.

    Q (P + 1, 2), D (P, 2) deg: positions along the path and forward steps; frac (K,)
    sub-check offsets; k_static, k_max: time indices (-1: none); t0, dt: time of layer 0
    and layer spacing (steps); goal_after: earliest time the goal may be reached;
    nodes_left: node budget (-1: none); the obstacle tables as :func:`moving_collisions`.
    Returns (outcome, k_end, came (k_end, P + 1) int8 action that reached each position
    per layer, nodes expanded, checks made).

    Actions are taken forward, stop, backward (forward only once static), as in
    :func:`rfp_twin.planners.roadmap.sweep._sweep_queries`; a position reaches the next
    layer by the first action that is clear. So an action is not checked when a
    higher-priority one already reached its position, and its sub-checks stop at the
    first blocked one: neither changes what is reached or how. ``hits`` counts, per
    obstacle, the actions it blocked first (the Python loop counts blocked sub-checks).
    """
    P = Q.shape[0] - 1
    K = frac.shape[0]
    n_t = obs_seg.shape[0]
    n_obs = obs_seg.shape[1]
    # an action's sub-checks depend on (action, position), not on the layer: their beta
    # segments and a disc holding them all are placed once, when first needed (a stop's
    # sub-checks share one segment); an obstacle whose discs over the action's steps
    # (obs_blk) stay farther than its threshold from that disc cannot block it
    seg = np.empty((3, P + 1, K, 5))
    disc = np.empty((3, P + 1, 3))
    placed = np.zeros((3, P + 1), dtype=np.bool_)
    listed = np.empty(n_obs, dtype=np.int64)
    f_lo = frac.min() if K > 0 else 0.0       # the sub-checks' steps lie between these
    f_hi = frac.max() if K > 0 else 0.0
    reach = np.zeros(P + 1, dtype=np.bool_)
    reach[0] = True
    nxt = np.zeros(P + 1, dtype=np.bool_)
    came = np.zeros((16, P + 1), dtype=np.int8)
    nodes = 0
    checks = 0
    k = 0
    while True:
        t_k = t0 + k * dt
        if reach[P] and t_k > goal_after - 1e-12:
            return SWEEP_FOUND, k, came[:k], nodes, checks
        if k_max >= 0 and k >= k_max:
            return SWEEP_FAILED, k, came[:k], nodes, checks
        nodes += int(reach.sum())
        if nodes_left >= 0 and nodes >= nodes_left:
            return SWEEP_BUDGET, k, came[:k], nodes, checks
        static = k_static >= 0 and k >= k_static
        if k == came.shape[0]:
            grown = np.zeros((2 * k, P + 1), dtype=np.int8)
            grown[:k] = came
            came = grown
        nxt[:] = False
        moved = False
        for m in ACTIONS:
            for p in range(P + 1):
                if not action_taken(reach, p, m, P, static) or nxt[p + m]:
                    continue
                p2 = p + m
                da = action_step(D, p, m, 0)
                db = action_step(D, p, m, 1)
                clear = True
                a_ = m + 1
                if not placed[a_, p]:
                    _place_action(seg, disc, a_, p, Q, frac, da, db, bx, by, l_alpha, s0, s1,
                                  1 if m == 0 else K)
                    placed[a_, p] = True
                n_listed = _near_obstacles(disc[a_, p], t_k + f_lo * dt, t_k + f_hi * dt, n_t,
                                           obs_blk, obs_th, listed)
                for j in range(K if n_listed > 0 else 0):
                    checks += 1
                    jj = 0 if m == 0 else j
                    o = listed_blocker(seg[a_, p, jj, 0], seg[a_, p, jj, 1], seg[a_, p, jj, 2],
                                       seg[a_, p, jj, 3], seg[a_, p, jj, 4], t_k + frac[j] * dt,
                                       obs_seg, obs_rho, obs_d, obs_th, listed, n_listed)
                    if o >= 0:
                        hits[o] += 1
                        clear = False
                        break
                if clear:
                    nxt[p2] = True
                    came[k, p2] = m
                    moved = True
        if not moved:
            return SWEEP_FAILED, k, came[:k], nodes, checks
        reach, nxt = nxt, reach
        k += 1


@njit(cache=True, nogil=True)
def sweep_paths(Qs, Ds, q_ptr, frac, k_static, k_maxs, t0, dt, goal_after, nodes_left,
                bx, by, l_alpha, s0, s1, obs_seg, obs_rho, obs_d, obs_th, obs_blk, hits, stop):
    """:func:`sweep_layers` on paths ``m = 0, 1, ...`` in turn, until one finds the goal
    or the node budget ends, as the sweep search calls it path after path.

    Qs (sum of P_m + 1, 2), Ds (sum of P_m, 2) deg: the positions and forward steps of
    every path, path m in rows ``q_ptr[m]:q_ptr[m + 1]`` of Qs and ``q_ptr[m] - m:
    q_ptr[m + 1] - m - 1`` of Ds; k_maxs (M,) each path's last layer (-1: none);
    nodes_left the budget of the first path (-1: none), each later path's being what
    the paths before it left; the rest as :func:`sweep_layers`, ``hits`` added to;
    ``stop`` (1,) uint8: when another thread sets it, no further path is started.
    Returns (paths swept, outcome of the last one, its k_end, its came (k_end, P + 1)
    int8, nodes (paths swept,) of each, checks made in all).
    """
    M = q_ptr.shape[0] - 1
    nodes = np.zeros(M, dtype=np.int64)
    checks = 0
    left = nodes_left
    outcome = SWEEP_FAILED
    k_end = 0
    came = np.zeros((0, 1), dtype=np.int8)
    for m in range(M):
        if stop[0] != 0:
            return m, SWEEP_FAILED, 0, came, nodes[:m], checks
        a = q_ptr[m]
        b = q_ptr[m + 1]
        outcome, k_end, came, n, c = sweep_layers(
            Qs[a:b], Ds[a - m:b - m - 1], frac, k_static, k_maxs[m], t0, dt, goal_after, left,
            bx, by, l_alpha, s0, s1, obs_seg, obs_rho, obs_d, obs_th, obs_blk, hits)
        nodes[m] = n
        checks += c
        if left >= 0:
            left = max(0, left - n)
        if outcome != SWEEP_FAILED:
            return m + 1, outcome, k_end, came, nodes[:m + 1], checks
    return M, outcome, k_end, came, nodes, checks


@njit(cache=True)
def reach_of(seg, bx, by):
    """(T,) farthest distance of each segment (T, 4) from the base (bx, by), mm."""
    out = np.empty(seg.shape[0])
    for k in range(seg.shape[0]):
        out[k] = math.sqrt(max((seg[k, 0] - bx) ** 2 + (seg[k, 1] - by) ** 2,
                               (seg[k, 2] - bx) ** 2 + (seg[k, 3] - by) ** 2))
    return out


@njit(cache=True)
def static_collisions(q, bx, by, l_alpha, s0, s1, limits, st_seg, st_th, pt_xy, pt_th, out):
    """Static test of one robot: joint limits, static segments (offline robots' beta
    segments, segment obstacles such as guide-camera edges), points (fiducials).
    q (m, 2) deg; limits (4,) deg; st_seg (a, 4) mm, st_th (a,) mm (each segment's own
    threshold); pt_xy (b, 2) mm, pt_th (b,) mm; out (m,) bool."""
    for r in range(q.shape[0]):
        a = q[r, 0]
        b = q[r, 1]
        if a < limits[0] - 1e-9 or a > limits[1] + 1e-9 or b < limits[2] - 1e-9 or b > limits[3] + 1e-9:
            out[r] = True
            continue
        x0, y0, x1, y1 = beta_segment(bx, by, a, b, l_alpha, s0, s1)
        hit = False
        for o in range(st_seg.shape[0]):
            if segments_within(x0, y0, x1, y1, st_seg[o, 0], st_seg[o, 1], st_seg[o, 2],
                               st_seg[o, 3], st_th[o]):
                hit = True
                break
        if not hit:
            for o in range(pt_xy.shape[0]):
                if point_segment_distance(pt_xy[o, 0], pt_xy[o, 1], x0, y0, x1, y1) <= pt_th[o]:
                    hit = True
                    break
        out[r] = hit


@njit(cache=True)
def static_slack(x0, y0, x1, y1, st_seg, st_th, pt_xy, pt_th):
    """Smallest clearance beyond its threshold of a beta segment (x0, y0, x1, y1) mm to
    the static segments and points of :func:`static_collisions`, mm (inf: none)."""
    slack = math.inf
    for o in range(st_seg.shape[0]):
        slack = min(slack, segment_distance(x0, y0, x1, y1, st_seg[o, 0], st_seg[o, 1],
                                            st_seg[o, 2], st_seg[o, 3]) - st_th[o])
    for o in range(pt_xy.shape[0]):
        slack = min(slack, point_segment_distance(pt_xy[o, 0], pt_xy[o, 1], x0, y0, x1, y1)
                    - pt_th[o])
    return slack


#: Clearance (mm) an edge check keeps beyond the motion bound before it skips points.
SKIP_MARGIN_MM = 1e-6


@njit(cache=True, nogil=True)
def edges_forbidden(q0s, q1s, step, bx, by, l_alpha, s0, s1, limits, st_seg, st_th, pt_xy,
                    pt_th, out, counts):
    """:func:`static_collisions` along straight edges: ``out[e]`` is True when a point
    of edge ``q0s[e] -> q1s[e]`` ((E, 2) deg each) is forbidden, the points being those
    of :func:`rfp_twin.planners.roadmap.graph.edge_samples` at most ``step`` (2,) deg
    apart per joint (ends included, as ``np.linspace`` places them); an edge stops at its
    first forbidden point. ``counts[e]``: the edge's number of points (E,) int64.

    Points are skipped where they cannot be forbidden: when both ends are within the
    joint limits (then every point between is: the box is convex), a clear point's
    clearance beyond the thresholds (:func:`static_slack`) bounds how many following
    points stay clear, as no point of the segment moves more than
    ``(l_alpha + s) |d alpha| + s |d beta|`` (rad, s the segment's farthest reach along
    beta) from one point to the next. The answer is that of checking every point."""
    q = np.empty((1, 2))
    one = np.empty(1, dtype=np.bool_)
    s_far = max(abs(s0), abs(s1))
    for e in range(q0s.shape[0]):
        mx = 0.0
        for c in range(2):
            mx = max(mx, abs(q1s[e, c] - q0s[e, c]) / step[c])
        n = max(1, int(math.ceil(mx - 1e-9)))
        counts[e] = n + 1
        inc = 1.0 / n
        inside = True
        for qq in (q0s[e], q1s[e]):
            if qq[0] < limits[0] - 1e-9 or qq[0] > limits[1] + 1e-9 or \
                    qq[1] < limits[2] - 1e-9 or qq[1] > limits[3] + 1e-9:
                inside = False
        move = ((l_alpha + s_far) * abs(q1s[e, 0] - q0s[e, 0])
                + s_far * abs(q1s[e, 1] - q0s[e, 1])) * inc * (math.pi / 180.0) * (1.0 + 1e-9)
        hit = False
        j = 0
        while j <= n:
            f = 1.0 if j == n else j * inc
            for c in range(2):
                q[0, c] = q0s[e, c] + f * (q1s[e, c] - q0s[e, c])
            static_collisions(q, bx, by, l_alpha, s0, s1, limits, st_seg, st_th, pt_xy, pt_th,
                              one)
            if one[0]:
                hit = True
                break
            skip = 0
            if inside and j < n:
                x0, y0, x1, y1 = beta_segment(bx, by, q[0, 0], q[0, 1], l_alpha, s0, s1)
                room = static_slack(x0, y0, x1, y1, st_seg, st_th, pt_xy, pt_th) - SKIP_MARGIN_MM
                if room > 0.0:
                    skip = n if move <= 0.0 or room >= move * n else int(room / move)
            j += 1 + skip
        out[e] = hit


@njit(cache=True)
def pair_conflict(seg_a, seg_b, th):
    """True when two robots' segments (T, 4) come within th mm at the same step."""
    for k in range(seg_a.shape[0]):
        if segments_within(seg_a[k, 0], seg_a[k, 1], seg_a[k, 2], seg_a[k, 3],
                           seg_b[k, 0], seg_b[k, 1], seg_b[k, 2], seg_b[k, 3], th):
            return True
    return False
