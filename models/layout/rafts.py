"""Raft tilings: triangular modules of robots on a circular focal plane (Spec-S5 style).

Units: millimetres. A *raft* is a triangular module of ``robots_per_raft`` robots on a
patch of a hex lattice of pitch ``pitch_mm`` (rows along +x, as
:func:`rfp_twin.models.layout.grids.hex_xy`), inside an equilateral triangle of side
``side_mm``. Spec-S5 (LBNL) numbers, the defaults: 63 robots per raft at 6.2 mm pitch,
74 mm triangle side, 2 mm gaps between rafts, 204 rafts = 12,852 robots per telescope;
earlier drafts had 72 and 75 robots per raft.

The robots of one raft (rule used here)
    Take the smallest triangular number of lattice rows ``k`` with ``k (k + 1) / 2 >=
    N``: a triangle of lattice sites with ``k`` sites on each edge, centred on the raft
    triangle's centroid. Keep the ``N`` sites nearest the centroid, i.e. trim the
    ``k (k + 1) / 2 - N`` sites farthest from it (the corners first); ties are broken
    by the angle about the centroid modulo 120 deg, so trimming a multiple of 3 sites
    keeps the raft's three-fold symmetry. For 63 robots: 11 rows (66 sites) minus the 3
    corners. These 63 sites split exactly into 21 triangles of three mutually adjacent
    robots, which is how we read "21 trillium units of 3 robots" (the tests check that
    such a split exists; units are not modelled further). 75 = 12 rows minus 3 corners,
    72 = 12 rows minus 6.
    A raft *fits* its triangle when every robot body (a disk of diameter
    ``body_diameter_mm``) is inside it: the ``k``-row triangle of centres is inset by at
    least the body radius, ``side_mm >= (k - 1) pitch + 2 sqrt(3) body_radius``. With the
    defaults the inset is (74 - 62) / (2 sqrt 3) = 3.46 mm >= 3.0 mm.

The tiling
    Rafts alternate up (apex at +y) and down triangles, as the triangles of a regular
    triangular tiling of side ``side_mm + sqrt(3) gap_mm``, each shrunk about its
    centroid to ``side_mm``: parallel edges of neighbouring rafts are then ``gap_mm``
    apart. A vertex of the tiling sits at the focal-plane centre (0, 0). A down raft is
    the up raft turned by 180 deg about its centroid. Rafts are numbered by the distance
    of their centroid from the centre (ties by angle); robots are numbered raft by raft,
    ids ``0..n-1``. With ``radius_mm`` every raft whose whole triangle lies inside the
    circle of that radius is kept (robots are then inside it too); with ``n_rafts`` the
    ``n_rafts`` rafts nearest the centre (of those inside the circle, when both are
    given).

Layout columns (``Layout.extra``, strings as CSV columns are): ``raft`` (the raft index
of each position, ``0..n_rafts-1``) and ``raft_side_mm`` (the triangle side, so that the
raft's area is known to consumers such as :mod:`rfp_twin.models.coverage`).

Bad input raises :class:`rfp_twin.models.errors.LayoutError`, one line naming the field
and the allowed range.
"""
from __future__ import annotations

import math

import numpy as np

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.layout.checks import check_positive, check_size
from rfp_twin.models.layout.core import Layout

#: Spec-S5 (LBNL) raft defaults: robots per raft, pitch, triangle side, gap (mm), rafts.
SPEC_S5_ROBOTS_PER_RAFT = 63
SPEC_S5_PITCH_MM = 6.2
SPEC_S5_SIDE_MM = 74.0
SPEC_S5_GAP_MM = 2.0
SPEC_S5_RAFTS = 204
#: Diameter of a raft robot's fixed body, mm (estimate: no published figure; it must fit
#: the 6.2 mm pitch). Pitch below it, or a raft edge closer than its radius, is an error.
RAFT_BODY_DIAMETER_MM = 6.0
#: Extra columns a raft layout carries.
RAFT_COLUMN = "raft"
RAFT_SIDE_COLUMN = "raft_side_mm"

_SQRT3 = math.sqrt(3.0)
_WHERE = "raft_layout"


def raft_rows(robots_per_raft: int) -> int:
    """Lattice rows ``k`` of a raft: the smallest ``k`` with ``k (k + 1) / 2 >= N``."""
    k = int(math.ceil((math.sqrt(8.0 * robots_per_raft + 1.0) - 1.0) / 2.0))
    while k * (k + 1) // 2 < robots_per_raft:
        k += 1
    while k > 1 and (k - 1) * k // 2 >= robots_per_raft:
        k -= 1
    return k


def min_side_mm(robots_per_raft: int, pitch_mm: float,
                body_diameter_mm: float = RAFT_BODY_DIAMETER_MM) -> float:
    """Smallest triangle side, mm, that holds a raft of ``robots_per_raft`` robots at
    ``pitch_mm`` with every robot body inside: ``(k - 1) pitch + sqrt(3) body_diameter``."""
    return (raft_rows(robots_per_raft) - 1) * pitch_mm + _SQRT3 * body_diameter_mm


def raft_template(robots_per_raft: int, pitch_mm: float) -> np.ndarray:
    """Robot positions of one *up* raft relative to its centroid, ``(N, 2)`` float64 mm.

    Rows along +x from the bottom edge, ``pitch_mm`` apart within a row; ordered by row
    (y) then x. See the module docstring for which sites are kept.
    """
    k = raft_rows(robots_per_raft)
    r, q = np.divmod(np.arange(k * k), k)
    keep = q + r <= k - 1
    q, r = q[keep].astype(np.float64), r[keep].astype(np.float64)
    h = _SQRT3 / 2.0 * pitch_mm
    xy = np.column_stack([(q + 0.5 * r - (k - 1) / 2.0) * pitch_mm, r * h])
    xy[:, 1] -= (k - 1) * h / 3.0                    # centroid of the k-row triangle at 0
    n_trim = len(xy) - robots_per_raft
    if n_trim:
        dist = np.round(np.hypot(xy[:, 0], xy[:, 1]) / pitch_mm, 9)
        ang = np.arctan2(xy[:, 1], xy[:, 0])
        sector = np.round(np.mod(ang - math.pi / 2, 2 * math.pi / 3), 9)
        order = np.lexsort((ang, sector, -dist))     # farthest first, then by sector angle
        xy = np.delete(xy, order[:n_trim], axis=0)
    return xy[np.lexsort((xy[:, 0], np.round(xy[:, 1], 9)))]


def _tiling_candidates(cell: float, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Centroids ``(m, 2)`` mm and up flags ``(m,)`` bool of the triangles of a tiling of
    side ``cell`` (a vertex at the origin) whose centroid lies within ``reach`` mm."""
    height = cell * _SQRT3 / 2.0
    span = int(math.ceil(reach / height)) + 2        # rhombus of lattice cells holding the disk
    a, b = np.meshgrid(np.arange(-span, span + 1), np.arange(-span, span + 1), indexing="ij")
    a, b = a.ravel().astype(np.float64), b.ravel().astype(np.float64)
    vx, vy = a * cell + b * cell / 2.0, b * height   # lower-left vertex of each rhombus
    up = np.column_stack([vx + cell / 2.0, vy + height / 3.0])
    down = np.column_stack([vx + cell, vy + 2.0 * height / 3.0])
    centroids = np.vstack([up, down])
    is_up = np.concatenate([np.ones(len(up), bool), np.zeros(len(down), bool)])
    near = np.hypot(centroids[:, 0], centroids[:, 1]) <= reach
    return centroids[near], is_up[near]


def _order(centroids: np.ndarray) -> np.ndarray:
    """Indices sorting centroids ``(m, 2)`` by distance from the origin, then by angle."""
    dist = np.round(np.hypot(centroids[:, 0], centroids[:, 1]), 6)
    ang = np.round(np.mod(np.arctan2(centroids[:, 1], centroids[:, 0]), 2 * math.pi), 9)
    return np.lexsort((ang, dist))


def _outer_radius(centroids: np.ndarray, is_up: np.ndarray, side: float) -> np.ndarray:
    """(m,) largest distance of each raft triangle's vertices from the origin, mm."""
    rho = side / _SQRT3                               # centroid to vertex
    angles = np.radians([90.0, 210.0, 330.0])
    sign = np.where(is_up, 1.0, -1.0)[:, None]
    vx = centroids[:, :1] + sign * rho * np.cos(angles)[None, :]
    vy = centroids[:, 1:] + sign * rho * np.sin(angles)[None, :]
    return np.hypot(vx, vy).max(axis=1)


def _count(name: str, value, lo: int = 1) -> int:
    """An integer >= ``lo``, else LayoutError naming the field."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
        raise LayoutError(f"{_WHERE}: field '{name}' = {value!r}; allowed: an integer >= {lo}")
    return int(value)


def _select(n_rafts: int | None, radius: float | None, side: float,
            cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Centroids ``(r, 2)`` and up flags ``(r,)`` of the chosen rafts, in raft order."""
    area = cell * cell * _SQRT3 / 4.0                  # tiling area per raft
    if radius is not None:
        cents, up = _tiling_candidates(cell, radius)
        inside = _outer_radius(cents, up, side) <= radius * (1.0 + 1e-12)
        if not inside.any():
            near, near_up = _tiling_candidates(cell, 2.0 * cell)
            need = float(_outer_radius(near, near_up, side).min())
            raise LayoutError(f"{_WHERE}: field 'radius_mm' = {radius!r} holds no raft of side "
                              f"{side:g} mm; allowed: >= {need:.3f} mm")
        cents, up = cents[inside], up[inside]
        order = _order(cents)
        if n_rafts is not None:
            if n_rafts > len(order):
                raise LayoutError(f"{_WHERE}: field 'n_rafts' = {n_rafts} rafts do not fit inside "
                                  f"radius_mm = {radius:g}; allowed: 1..{len(order)}")
            order = order[:n_rafts]
        return cents[order], up[order]
    reach = math.sqrt(n_rafts * area / math.pi) * 1.1 + 2.0 * cell
    while True:
        cents, up = _tiling_candidates(cell, reach)
        if len(cents) >= n_rafts:
            order = _order(cents)[:n_rafts]
            return cents[order], up[order]
        reach *= 1.5


def raft_layout(robots_per_raft: int = SPEC_S5_ROBOTS_PER_RAFT,
                pitch_mm: float = SPEC_S5_PITCH_MM, side_mm: float = SPEC_S5_SIDE_MM,
                gap_mm: float = SPEC_S5_GAP_MM, n_rafts: int | None = None,
                radius_mm: float | None = None,
                body_diameter_mm: float = RAFT_BODY_DIAMETER_MM,
                name: str | None = None) -> Layout:
    """A focal plane tiled with triangular rafts of robots (see the module docstring).

    Parameters
    ----------
    robots_per_raft : int >= 1
        Robots in each raft (Spec-S5: 63).
    pitch_mm : float >= body_diameter_mm
        Base-to-base distance of neighbours inside a raft, mm (Spec-S5: 6.2).
    side_mm : float > 0
        Side of each raft's triangle, mm (Spec-S5: 74); must hold the robots
        (:func:`min_side_mm`).
    gap_mm : float >= 0
        Distance between parallel edges of neighbouring rafts, mm (Spec-S5: 2).
    n_rafts : int >= 1, optional
        Keep the ``n_rafts`` rafts nearest the centre. Default: 204 when ``radius_mm``
        is not given either.
    radius_mm : float > 0, optional
        Keep every raft whose triangle lies inside this focal-plane radius, mm.
    body_diameter_mm : float > 0
        Diameter of a robot's fixed body, mm (estimate 6.0).
    name : str, optional
        Default ``"raft-<rafts>x<robots>"``.

    Returns
    -------
    Layout
        ``n_rafts * robots_per_raft`` robots, ids ``0..n-1``; extra columns ``raft``
        and ``raft_side_mm`` ``(n,)`` str.

    Raises
    ------
    LayoutError
        A non-positive or non-finite length, a negative gap (rafts would overlap), a pitch
        below the robot body, robots that do not fit the triangle, a radius that holds no
        raft, or more rafts than fit in the radius; names the field and allowed range.
    """
    n_robots = _count("robots_per_raft", robots_per_raft)
    body = check_positive("body_diameter_mm", body_diameter_mm, _WHERE)
    pitch = check_positive("pitch_mm", pitch_mm, _WHERE)
    side = check_positive("side_mm", side_mm, _WHERE)
    try:
        gap = float(gap_mm)
    except (TypeError, ValueError):
        gap = math.nan
    if not (math.isfinite(gap) and gap >= 0.0):
        raise LayoutError(f"{_WHERE}: field 'gap_mm' = {gap_mm!r}; allowed: a finite number "
                          ">= 0 mm (a negative gap overlaps neighbouring rafts)")
    if pitch < body:
        raise LayoutError(f"{_WHERE}: field 'pitch_mm' = {pitch_mm!r} is smaller than the robot "
                          f"body ({body:g} mm); allowed: >= {body:g} mm (body_diameter_mm)")
    need = min_side_mm(n_robots, pitch, body)
    if side < need - 1e-9:
        k = raft_rows(n_robots)
        fit = max((j for j in range(1, k) if (j - 1) * pitch + _SQRT3 * body <= side),
                  default=0)
        fewer = f"1..{fit * (fit + 1) // 2} robots, or " if fit else ""
        raise LayoutError(f"{_WHERE}: field 'robots_per_raft' = {n_robots} ({k} rows) does not "
                          f"fit a {side:g} mm triangle at pitch {pitch:g} mm; allowed: {fewer}"
                          f"side_mm >= {need:.3f}")
    if n_rafts is not None:
        n_rafts = _count("n_rafts", n_rafts)
        check_size(n_rafts * n_robots, f"{_WHERE}: {n_rafts} rafts of {n_robots} robots")
    radius = None if radius_mm is None else check_positive("radius_mm", radius_mm, _WHERE)
    if n_rafts is None and radius is None:
        n_rafts = SPEC_S5_RAFTS
    if radius is not None:
        # rafts of this side (plus gaps) cover the disc at most once: an upper bound
        pitch_area = _SQRT3 / 4.0 * (side + _SQRT3 * gap) ** 2
        check_size(math.pi * radius ** 2 / pitch_area * n_robots,
                   f"{_WHERE}: rafts inside {radius:g} mm")
    cents, up = _select(n_rafts, radius, side, side + _SQRT3 * gap)
    template = raft_template(n_robots, pitch)
    sign = np.where(up, 1.0, -1.0)[:, None, None]
    xy = (cents[:, None, :] + sign * template[None, :, :]).reshape(-1, 2)
    n_r, n = len(cents), len(cents) * n_robots
    extra = {RAFT_COLUMN: np.repeat(np.arange(n_r).astype(str), n_robots),
             RAFT_SIDE_COLUMN: np.full(n, repr(side))}
    layout = Layout(np.arange(n, dtype=np.int64), xy, np.full(n, "robot", dtype=object),
                    name or f"raft-{n_r}x{n_robots}", extra)
    return layout.validate(body * (1.0 - 1e-9))


#: Keys of a ``raft:`` layout name -> raft_layout parameter.
NAME_KEYS = {"n": "n_rafts", "R": "radius_mm", "robots": "robots_per_raft", "side": "side_mm",
             "gap": "gap_mm", "pitch": "pitch_mm"}
_INT_PARAMS = ("n_rafts", "robots_per_raft")


def raft_from_name(name: str, pitch_mm: float = SPEC_S5_PITCH_MM) -> Layout:
    """The raft layout a name describes (:func:`rfp_twin.models.layout.layout_by_name`).

    ``raft:N`` is N rafts of the Spec-S5 defaults (``raft:204`` = 12,852 robots,
    ``raft:476`` = 29,988 robots); ``raft:R=600`` every raft inside a 600 mm radius;
    more comma-separated ``key=value`` items set ``n``, ``R`` (mm), ``robots`` (per raft),
    ``side``, ``gap`` and ``pitch`` (mm), e.g. ``raft:204,robots=75,side=80``. The pitch
    defaults to ``pitch_mm`` (the robot spec's), like every generated grid. ``raft`` alone
    is ``raft:204``.

    Raises
    ------
    LayoutError
        An item that is not ``N`` or ``key=value`` with a known key and a number, or a
        bad value (see :func:`raft_layout`).
    """
    kwargs: dict = {"pitch_mm": pitch_mm}
    body = name[len("raft:"):] if name.startswith("raft:") else ""
    for item in filter(None, (s.strip() for s in body.split(","))):
        key, eq, text = item.partition("=")
        key = key.strip() if eq else "n"
        param = NAME_KEYS.get(key)
        text = (text if eq else item).strip()
        try:
            if param is None:
                raise ValueError
            value = float(text)
            if param in _INT_PARAMS:
                if not value.is_integer():
                    raise ValueError
                value = int(value)
        except ValueError:
            raise LayoutError(f"layout {name!r}: item {item!r}; allowed: N (rafts) or key=value "
                              f"with key in {', '.join(NAME_KEYS)} and a number") from None
        kwargs[param] = value
    return raft_layout(**kwargs)
