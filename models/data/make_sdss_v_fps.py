"""Build ``sdss-v-fps.csv`` from the SDSS-V FPS "Design Reference Layout" text file.

Usage::

    python models/data/make_sdss_v_fps.py REFERENCE.txt [-o OUT.csv]

The reference file has one position per line, ``Row Col X(mm) Y(mm) Assignment``,
optionally followed by a ``# comment`` (``BA # BOSS`` means assignment ``BA``), and
``#`` comment lines. Row -99 is the outer ring of fiducials.

Output columns: ``id,x_mm,y_mm,kind,row,col,assignment``. ``id`` is 0..N-1 in file
order over the kept positions; ``x_mm``, ``y_mm``, ``row``, ``col`` and ``assignment``
are copied verbatim. ``BA`` and ``BOSS`` become kind ``robot``; ``Fiducial`` and
``GFA-Fiducial`` (outer-ring fiducials next to the guide cameras) become ``fiducial``;
``Aux`` and ``Open`` positions are skipped but counted. Any other assignment is an
error. The counts are compared with the header's "Totals" block and any mismatch is
printed as a warning.
"""
from __future__ import annotations

import argparse
import csv
import re
import sys
from collections import Counter
from pathlib import Path

KIND_OF_ASSIGNMENT = {"BA": "robot", "BOSS": "robot",
                      "Fiducial": "fiducial", "GFA-Fiducial": "fiducial"}
SKIPPED_ASSIGNMENTS = ("Aux", "Open")
OUTER_RING_ROW = "-99"
COLUMNS = ("id", "x_mm", "y_mm", "kind", "row", "col", "assignment")
HEADER_TOTALS = {"robots": r"#\s*(\d+)\s+robots",
                 "intra_fiducials": r"#\s*(\d+)\s+Intra-Array Fiducials",
                 "outer_fiducials": r"#\s*(\d+)\s+Outer Ring Fiducials"}


def parse_line(text: str, line_no: int, source: str) -> tuple[str, str, str, str, str] | None:
    """One reference line -> ``(row, col, x, y, assignment)`` strings, or None if blank."""
    body = text.split("#", 1)[0].strip()
    if not body:
        return None
    tokens = body.split()
    if len(tokens) != 5:
        sys.exit(f"{source}:{line_no}: expected 5 fields 'Row Col X Y Assignment', "
                 f"got {len(tokens)}: {body!r}")
    row, col, x, y, assignment = tokens
    for field, value in (("Row", row), ("Col", col)):
        try:
            int(value)
        except ValueError:
            sys.exit(f"{source}:{line_no}: field '{field}' = {value!r}; allowed: an integer")
    for field, value in (("X", x), ("Y", y)):
        try:
            float(value)
        except ValueError:
            sys.exit(f"{source}:{line_no}: field '{field}' = {value!r}; allowed: a number in mm")
    allowed = (*KIND_OF_ASSIGNMENT, *SKIPPED_ASSIGNMENTS)
    if assignment not in allowed:
        sys.exit(f"{source}:{line_no}: field 'Assignment' = {assignment!r}; "
                 f"allowed: {', '.join(allowed)}")
    return row, col, x, y, assignment


def read_reference(path: Path) -> tuple[list[tuple[str, ...]], str]:
    """All positions of the reference file, in file order, and its full text."""
    text = path.read_text(encoding="ascii")
    positions = []
    for line_no, line in enumerate(text.splitlines(), start=1):
        parsed = parse_line(line, line_no, str(path))
        if parsed is not None:
            positions.append(parsed)
    return positions, text


def header_totals(text: str) -> dict[str, int]:
    """The counts the header's "Totals" block claims (only those it states)."""
    found = {}
    for key, pattern in HEADER_TOTALS.items():
        match = re.search(pattern, text)
        if match:
            found[key] = int(match.group(1))
    return found


def to_rows(positions: list[tuple[str, ...]]) -> list[tuple[str, ...]]:
    """Kept positions as CSV rows ``(id, x_mm, y_mm, kind, row, col, assignment)``."""
    rows = []
    for row, col, x, y, assignment in positions:
        kind = KIND_OF_ASSIGNMENT.get(assignment)
        if kind is not None:
            rows.append((str(len(rows)), x, y, kind, row, col, assignment))
    return rows


def count(positions: list[tuple[str, ...]]) -> dict[str, int]:
    """Robots, intra-array and outer-ring fiducials, and skipped positions."""
    counts = Counter()
    for row, _col, _x, _y, assignment in positions:
        kind = KIND_OF_ASSIGNMENT.get(assignment)
        if kind == "robot":
            counts["robots"] += 1
        elif kind == "fiducial":
            counts["outer_fiducials" if row == OUTER_RING_ROW else "intra_fiducials"] += 1
        else:
            counts[f"skipped_{assignment}"] += 1
    return dict(counts)


def write_csv(rows: list[tuple[str, ...]], out: Path) -> None:
    """Write the rows with the :data:`COLUMNS` header."""
    with out.open("w", newline="", encoding="ascii") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(COLUMNS)
        writer.writerows(rows)


def report(counts: dict[str, int], claimed: dict[str, int], out: Path) -> None:
    """Print the counts, and a warning for each disagreement with the header."""
    n_fid = counts.get("intra_fiducials", 0) + counts.get("outer_fiducials", 0)
    print(f"wrote {out}: {counts.get('robots', 0) + n_fid} positions")
    for key in sorted(counts):
        print(f"  {key:18s} {counts[key]}")
    print(f"  {'fiducials (total)':18s} {n_fid}")
    for key, value in claimed.items():
        if counts.get(key, 0) != value:
            print(f"WARNING: header says {value} {key}, file has {counts.get(key, 0)}",
                  file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reference", type=Path, help="design reference layout text file")
    parser.add_argument("-o", "--output", type=Path,
                        default=Path(__file__).with_name("sdss-v-fps.csv"))
    args = parser.parse_args(argv)
    if not args.reference.is_file():
        sys.exit(f"{args.reference}: file not found")
    positions, text = read_reference(args.reference)
    write_csv(to_rows(positions), args.output)
    report(count(positions), header_totals(text), args.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
