"""Layout CSV files: ``id,x_mm,y_mm,kind`` plus any extra columns, read and written.

Units: millimetres. One row per position: integer ``id``, base centre ``x_mm``,
``y_mm`` and ``kind`` (``robot`` or ``fiducial``); other columns are kept verbatim as
``(n,)`` str arrays. Coordinates are written with ``repr`` so they read back
bit-identical; a file is replaced atomically (:mod:`rfp_twin.models.files`). A bad file raises
:class:`rfp_twin.models.errors.LayoutError` naming the file, line and field.
"""
from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.files import atomic_write_text
from rfp_twin.models.layout.checks import KINDS, closest_violation

if TYPE_CHECKING:
    from rfp_twin.models.layout.core import Layout

#: Columns every layout CSV must have, in the order :meth:`Layout.to_csv` writes them.
REQUIRED_COLUMNS = ("id", "x_mm", "y_mm", "kind")


class LayoutCsv:
    """CSV reading and writing of :class:`rfp_twin.models.layout.Layout` (a mixin: uses its
    ``ids``, ``xy``, ``kinds`` and ``extra``)."""

    ids: np.ndarray
    xy: np.ndarray
    kinds: np.ndarray
    extra: dict[str, np.ndarray]

    @classmethod
    def from_csv(cls, path: str | os.PathLike, min_separation_mm: float = 1.0,
                 name: str | None = None) -> Layout:
        """Read a layout CSV with columns ``id,x_mm,y_mm,kind`` (+ any extra columns).

        Extra columns are kept verbatim as ``(n,)`` str arrays in :attr:`extra`.

        Parameters
        ----------
        path : path-like
        min_separation_mm : float
            Smallest allowed base-to-base distance, mm.
        name : str, optional
            Default: the file name without suffix.

        Raises
        ------
        LayoutError
            Missing file or column, bad/duplicate id, non-finite coordinate, unknown
            kind, overlapping bases, empty layout; names the file, line and field.
        """
        path = Path(path)
        rows, columns = _read_rows(path)
        ids, xy, kinds, lines = _parse_rows(rows, path)
        extra = {c: np.array([r[c] for r, _ in rows], dtype=str)
                 for c in columns if c not in REQUIRED_COLUMNS}
        hit = closest_violation(xy, float(min_separation_mm))
        if hit is not None:
            i, j, d = hit
            raise LayoutError(f"{path}:{lines[i]},{lines[j]}: bases of ids {ids[i]} and "
                              f"{ids[j]} overlap ({d:.4f} mm apart); allowed: >= "
                              f"{min_separation_mm} mm (min_separation_mm)")
        return cls(ids, xy, kinds, name or path.stem, extra).validate(0.0)

    def to_csv(self, path: str | os.PathLike) -> None:
        """Write ``id,x_mm,y_mm,kind`` + extra columns; atomic (temp file + rename).

        Coordinates are written with ``repr`` so they read back bit-identical. On any
        failure the target is left untouched and no temp file is left behind.
        """
        path = Path(path)
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow([*REQUIRED_COLUMNS, *self.extra])
        for k in range(len(self.ids)):
            writer.writerow(self._csv_row(k))
        try:
            atomic_write_text(path, buf.getvalue())
        except OSError as exc:
            raise LayoutError(f"{path}: cannot write ({exc.strerror}); "
                              f"allowed: a path in an existing, writable directory") from exc

    def _csv_row(self, k: int) -> list[str]:
        """Row ``k`` as CSV strings, in :meth:`to_csv` column order."""
        x, y = self.xy[k]
        return [str(int(self.ids[k])), repr(float(x)), repr(float(y)), str(self.kinds[k]),
                *(str(v[k]) for v in self.extra.values())]


def _read_rows(path: Path) -> tuple[list[tuple[dict, int]], list[str]]:
    """Data rows ``(row dict, line number)`` and the column names of a layout CSV."""
    if not path.is_file():
        raise LayoutError(f"{path}: file not found; allowed: path to an existing layout CSV")
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh, skipinitialspace=True)
        columns = [c.strip() for c in (reader.fieldnames or [])]
        reader.fieldnames = columns
        missing = [c for c in REQUIRED_COLUMNS if c not in columns]
        if missing:
            raise LayoutError(f"{path}:1: missing column(s) {', '.join(missing)}; "
                              f"required: {','.join(REQUIRED_COLUMNS)}")
        rows = [(row, reader.line_num) for row in reader]
    for row, line in rows:
        if None in row or any(v is None for v in row.values()):
            raise LayoutError(f"{path}:{line}: wrong number of fields; "
                              f"allowed: {len(columns)} ({','.join(columns)})")
    if not rows:
        raise LayoutError(f"{path}: empty layout (no data rows); allowed: at least one row")
    return rows, columns


def _parse_rows(rows, path: Path):
    """Validated ``ids (n,), xy (n, 2), kinds (n,), lines`` of the data rows."""
    ids, xy, kinds, lines, first_line = [], [], [], [], {}
    for row, line in rows:
        where = f"{path}:{line}"
        rid = _parse_id(row["id"], where)
        if rid in first_line:
            raise LayoutError(f"{where}: field 'id' = {rid} is a duplicate id (first on line "
                              f"{first_line[rid]}); allowed: unique integer ids")
        first_line[rid] = line
        kind = row["kind"].strip()
        if kind not in KINDS:
            raise LayoutError(f"{where}: field 'kind' = {kind!r} is an unknown kind; "
                              f"allowed: {', '.join(KINDS)}")
        ids.append(rid)
        xy.append((_parse_mm(row, "x_mm", where), _parse_mm(row, "y_mm", where)))
        kinds.append(kind)
        lines.append(line)
    return (np.array(ids, dtype=np.int64), np.array(xy, dtype=np.float64).reshape(-1, 2),
            kinds, lines)


def _parse_id(text: str, where: str) -> int:
    try:
        return int(text.strip())
    except ValueError:
        raise LayoutError(f"{where}: field 'id' = {text!r} is not an integer; "
                          f"allowed: unique integer ids") from None


def _parse_mm(row: dict, column: str, where: str) -> float:
    text = row[column]
    try:
        value = float(text)
    except ValueError:
        value = None
    if value is None or not math.isfinite(value):
        raise LayoutError(f"{where}: field '{column}' = {text!r}; allowed: a finite number "
                          f"in mm (not NaN/inf)")
    return value
