"""Reading a target catalogue from CSV or Parquet, with errors naming file, row and field.

Columns (header names, case as written):

``id`` (required)
    integer, unique
position, one of
    ``x_mm, y_mm``: the layout's planning frame;
    ``x_wok_mm, y_wok_mm``: the wok frame of a calibrated SDSS-V instrument (turned into
    the planning frame by :func:`rfp_twin.models.instrument.wok_to_plane`);
    ``ra_deg, dec_deg``: sky positions, projected about a field centre with a plate scale
    (:mod:`rfp_twin.models.catalogue.sky`); the focal-plane frame of that projection is
    the wok frame on a calibrated instrument and the planning frame otherwise.
``priority`` (optional, default 1)
    a finite weight >= 0 (larger: more valuable)
``kind`` (optional, default ``science``)
    ``science``, ``sky`` or ``standard``
``fiber`` (optional, default ``any``)
    ``boss``, ``apogee`` or ``any``
``exposures`` (optional, default 1)
    an integer >= 1: exposures the target needs (passes of one field,
    ``rfp-twin plan --passes``)

Rows are named as in the file: CSV by line (the header is line 1), Parquet by row (the
first data row is row 1).
"""
from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from rfp_twin.models.catalogue.catalogue import (KINDS, MAX_EXPOSURES, TARGET_FIBERS,
                                                  Catalogue, bad_exposures, code_of)
from rfp_twin.models.catalogue.sky import check_field_centre, sky_to_focal
from rfp_twin.models.errors import CatalogueError

POSITION_COLUMNS = (("x_mm", "y_mm"), ("x_wok_mm", "y_wok_mm"), ("ra_deg", "dec_deg"))


def _read_columns(path: Path) -> tuple[dict[str, list], str, int]:
    """({column: values}, row word, number of the first data row) of a CSV or Parquet file."""
    if not path.is_file():
        raise CatalogueError(f"{path}: catalogue file not found; allowed: a CSV or Parquet file")
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        try:
            table = pq.read_table(path)
        except Exception as exc:        # pyarrow raises several types for a bad file
            raise CatalogueError(f"{path}: not a readable Parquet file ({exc}); allowed: a "
                                 "Parquet table with the catalogue columns") from None
        return {c: table.column(c).to_pylist() for c in table.column_names}, "row", 1
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        header = [h.strip() for h in (reader.fieldnames or [])]
        rows = [{(k or "").strip(): v for k, v in row.items()} for row in reader]
    return {c: [r.get(c) for r in rows] for c in header}, "line", 2


def read_catalogue(path: str | Path, *, field_centre: tuple[float, float] | None = None,
                   plate_scale_mm_per_deg: float | None = None,
                   wok_frame: bool = False) -> Catalogue:
    """A catalogue from a CSV or Parquet file (module docstring), positions in the
    planning frame.

    Parameters
    ----------
    path : the file (``.parquet`` / ``.pq``: Parquet, anything else: CSV)
    field_centre : (ra, dec) deg, needed for ``ra_deg, dec_deg`` positions
    plate_scale_mm_per_deg : needed for ``ra_deg, dec_deg`` positions
    wok_frame : True on a calibrated SDSS-V instrument (its planning frame is the wok frame
        turned +90 deg); ``x_wok_mm`` positions need it

    Raises
    ------
    CatalogueError
        Missing file or columns, a non-number or NaN position, a non-integer or repeated
        id, an unknown kind or fiber, a negative priority: one line with the file, the
        row and the field and the allowed values.
    """
    path = Path(path)
    cols, word, first = _read_columns(path)
    n = len(next(iter(cols.values()), []))
    if n == 0:
        raise CatalogueError(f"{path}: no target rows; allowed: one row per target")
    pos = next((p for p in POSITION_COLUMNS if set(p) <= set(cols)), None)
    if "id" not in cols or pos is None:
        raise CatalogueError(f"{path}: columns {sorted(cols)}; allowed: id with x_mm,y_mm or "
                             "x_wok_mm,y_wok_mm or ra_deg,dec_deg (optional priority, kind, fiber, "
                             "exposures)")

    def where(r: int) -> str:
        return f"{path}:{r + first}" if word == "line" else f"{path}: row {r + first}"

    def numbers(name: str, default: float | None = None) -> np.ndarray:
        raw = cols.get(name)
        out = np.empty(n)
        for r in range(n):
            v = None if raw is None else raw[r]
            blank = v is None or (isinstance(v, str) and v.strip() == "")
            if blank and default is not None:
                out[r] = default
                continue
            try:
                x = float(v)
            except (TypeError, ValueError):
                x = math.nan
            if not math.isfinite(x):
                raise CatalogueError(f"{where(r)}: field {name!r} = {v!r}; allowed: a finite "
                                     "number" + (" (blank: missing)" if blank else ""))
            out[r] = x
        return out

    ids = numbers("id")
    bad = np.flatnonzero(ids != np.round(ids))
    if bad.size:
        r = int(bad[0])
        raise CatalogueError(f"{where(r)}: field 'id' = {cols['id'][r]!r}; allowed: an integer")
    ids = ids.astype(np.int64)
    seen: dict[int, int] = {}
    for r, v in enumerate(ids.tolist()):
        if v in seen:
            raise CatalogueError(f"{where(r)}: field 'id' = {v} repeats {word} "
                                 f"{seen[v] + first}; allowed: unique ids")
        seen[v] = r
    a, b = numbers(pos[0]), numbers(pos[1])
    if pos == ("ra_deg", "dec_deg"):
        xy = _project(path, a, b, field_centre, plate_scale_mm_per_deg, where)
        if wok_frame:
            xy = _wok_to_plane(xy)
    elif pos == ("x_wok_mm", "y_wok_mm"):
        if not wok_frame:
            raise CatalogueError(f"{path}: columns x_wok_mm,y_wok_mm on a layout without a wok "
                                 "frame; allowed: x_mm,y_mm or ra_deg,dec_deg, or wok positions "
                                 "on a calibrated instrument (sdss-v-apo, sdss-v-lco, ...)")
        xy = _wok_to_plane(np.column_stack([a, b]))
    else:
        xy = np.column_stack([a, b])
    priority = numbers("priority", 1.0)
    neg = np.flatnonzero(priority < 0.0)
    if neg.size:
        r = int(neg[0])
        raise CatalogueError(f"{where(r)}: field 'priority' = {cols['priority'][r]!r}; allowed: "
                             "a finite number >= 0 (larger: more valuable)")
    kind = _codes(cols.get("kind"), n, "kind", KINDS, "science", where)
    fiber = _codes(cols.get("fiber"), n, "fiber", TARGET_FIBERS, "any", where)
    exposures = numbers("exposures", 1.0)
    bad = bad_exposures(exposures)
    if bad.size:
        r = int(bad[0])
        raise CatalogueError(f"{where(r)}: field 'exposures' = {cols['exposures'][r]!r}; "
                             f"allowed: an integer in [1, {MAX_EXPOSURES}]")
    return Catalogue(ids, xy, priority, kind, fiber, source=str(path),
                     exposures=exposures.astype(np.int64))


def _codes(raw, n: int, name: str, names: tuple[str, ...], default: str, where) -> np.ndarray:
    """Column ``raw`` of names as (n,) int8 codes into ``names``; blank -> ``default``."""
    out = np.full(n, names.index(default), dtype=np.int8)
    if raw is None:
        return out
    for r, v in enumerate(raw):
        if v is None or str(v).strip() == "":
            continue
        c = code_of(v, names)
        if c < 0:
            raise CatalogueError(f"{where(r)}: field {name!r} = {v!r}; allowed: "
                                 f"{', '.join(names)}")
        out[r] = c
    return out


def _project(path: Path, ra: np.ndarray, dec: np.ndarray, centre, scale, where) -> np.ndarray:
    """(t, 2) focal-plane mm of sky positions; errors name the file and row."""
    if centre is None or scale is None:
        raise CatalogueError(f"{path}: ra_deg,dec_deg positions need a field centre and a plate "
                             "scale; allowed: --field-centre RA,DEC with a telescope (apo, lco) "
                             "or --plate-scale")
    check_field_centre(float(centre[0]), float(centre[1]))
    if not (np.isfinite(scale) and scale > 0.0):
        raise CatalogueError(f"plate scale {scale!r} mm/deg; allowed: a finite number > 0")
    for name, v, lo, hi in (("ra_deg", ra, 0.0, 360.0), ("dec_deg", dec, -90.0, 90.0)):
        bad = np.flatnonzero((v < lo) | (v > hi))
        if bad.size:
            r = int(bad[0])
            raise CatalogueError(f"{where(r)}: field {name!r} = {float(v[r])!r}; allowed: "
                                 f"[{lo:g}, {hi:g}] deg")
    x, y = sky_to_focal(ra, dec, float(centre[0]), float(centre[1]), float(scale))
    far = np.flatnonzero(~np.isfinite(x))
    if far.size:
        r = int(far[0])
        raise CatalogueError(f"{where(r)}: target at ra {float(ra[r])!r}, dec {float(dec[r])!r} is "
                             f"90 deg or more from the field centre {tuple(centre)}; allowed: a "
                             "target on the field's side of the sky")
    return np.column_stack([x, y])


def _wok_to_plane(xy: np.ndarray) -> np.ndarray:
    from rfp_twin.models.instrument import wok_to_plane

    return wok_to_plane(xy)
