"""Reading the CSV tables of a calibration folder, with errors that name file, row and field.

A table is read into a dict of columns (each a list of str, one per data row). Rows are
numbered as in the file (the header is line 1). Every failure raises
:class:`CalibrationError` with one line: ``<file>:<line>: field 'x' = v; allowed: ...``.
"""
from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from rfp_twin.models.errors import LayoutError


class CalibrationError(LayoutError):
    """A calibration folder is missing a file or holds a bad value (names file, row, field)."""


class Table:
    """One CSV file of a calibration folder: columns by name, each a list of str (r,).

    Attributes
    ----------
    path : Path
    columns : dict[str, list[str]]
    n_rows : int
    """

    def __init__(self, path: Path, required: tuple[str, ...]):
        self.path = path
        if not path.is_file():
            raise CalibrationError(f"{path}: file not found; allowed: a calibration folder with "
                                   f"{path.name}")
        with path.open(newline="") as fh:
            reader = csv.DictReader(fh)
            header = [h.strip() for h in (reader.fieldnames or [])]
            missing = [c for c in required if c not in header]
            if missing:
                raise CalibrationError(f"{path}:1: field {missing[0]!r} is missing; allowed: a "
                                       f"header with {', '.join(required)}")
            rows = [{(k or "").strip(): (v or "").strip() for k, v in row.items()}
                    for row in reader]
        if not rows:
            raise CalibrationError(f"{path}: no data rows; allowed: one row per hole/robot")
        self.columns = {c: [r.get(c, "") for r in rows] for c in header}
        self.n_rows = len(rows)

    def where(self, row: int) -> str:
        """``file:line`` of data row ``row`` (0-based)."""
        return f"{self.path}:{row + 2}"

    def text(self, name: str) -> list[str]:
        """Column ``name`` as str, one per row; a blank cell is an error."""
        col = self.columns[name]
        for r, v in enumerate(col):
            if v == "":
                raise CalibrationError(f"{self.where(r)}: field {name!r} is blank; allowed: a value")
        return col

    def numbers(self, name: str, lo: float = -math.inf, hi: float = math.inf) -> np.ndarray:
        """Column ``name`` as (r,) float64; NaN, text or a value outside [lo, hi] is an error."""
        col = self.columns[name]
        out = np.empty(len(col))
        for r, v in enumerate(col):
            try:
                x = float(v)
            except ValueError:
                x = math.nan
            if not (math.isfinite(x) and lo <= x <= hi):
                raise CalibrationError(f"{self.where(r)}: field {name!r} = {v!r}; allowed: a "
                                       f"finite number in [{lo:g}, {hi:g}]")
            out[r] = x
        return out

    def integers(self, name: str) -> np.ndarray:
        """Column ``name`` as (r,) int64; anything but an integer is an error."""
        vals = self.numbers(name)
        bad = np.flatnonzero(vals != np.round(vals))
        if bad.size:
            r = int(bad[0])
            raise CalibrationError(f"{self.where(r)}: field {name!r} = {self.columns[name][r]!r}; "
                                   "allowed: an integer")
        return vals.astype(np.int64)

    def unique(self, name: str, values) -> None:
        """Error at the first row whose ``values[row]`` repeats an earlier row's."""
        seen: dict = {}
        for r, v in enumerate(values):
            v = v.item() if hasattr(v, "item") else v
            if v in seen:
                raise CalibrationError(f"{self.where(r)}: field {name!r} = {v!r} repeats line "
                                       f"{seen[v] + 2}; allowed: unique values")
            seen[v] = r

    def frames(self, tol: float = 1e-6) -> np.ndarray:
        """(r, 3, 3) float64 unit vectors ``i, j, k`` (rows) of each row; error when one is
        not unit or two are not orthogonal within ``tol``."""
        out = np.empty((self.n_rows, 3, 3))
        for a, axis in enumerate("ijk"):
            for c, comp in enumerate("xyz"):
                out[:, a, c] = self.numbers(f"{axis}{comp}", -1.0 - tol, 1.0 + tol)
        norm = np.linalg.norm(out, axis=2)
        dots = np.stack([np.einsum("rc,rc->r", out[:, a], out[:, b])
                         for a, b in ((0, 1), (0, 2), (1, 2))], axis=1)
        bad_n = np.argwhere(np.abs(norm - 1.0) > tol)
        if bad_n.size:
            r, a = (int(v) for v in bad_n[0])
            axis = "ijk"[a]
            raise CalibrationError(f"{self.where(r)}: field '{axis}x, {axis}y, {axis}z' has length "
                                   f"{norm[r, a]:.6g}; allowed: a unit vector (within {tol:g})")
        bad_o = np.argwhere(np.abs(dots) > tol)
        if bad_o.size:
            r, p = (int(v) for v in bad_o[0])
            pair = ("i, j", "i, k", "j, k")[p]
            raise CalibrationError(f"{self.where(r)}: fields '{pair}' have dot product "
                                   f"{dots[r, p]:.6g}; allowed: orthogonal unit vectors "
                                   f"(within {tol:g})")
        return out
