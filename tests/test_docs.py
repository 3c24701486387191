"""The house rules for the written record, checked on every test run.

- ``benchmarks/RESULTS.md`` holds the current figure of every benchmark: at most
  ``RESULTS_MAX_LINES`` lines, one row per benchmark in its "At a glance" table (figure,
  command, date, anchor), no cell longer than ``CELL_MAX_CHARS`` (a paragraph of past
  figures belongs in ``benchmarks/HISTORY.md``).
- ``docs/DESIGN.md``'s "Where to find" table (behaviour -> module) names only paths that
  exist.
- No session labels ("S16", "this session") in code comments, docstrings and strings, in
  the README, the docs or RESULTS.md: say what the code does and why, and date a figure.

Plain text scans: cheap and deterministic.
"""
from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path

import pytest

THIS_FILE = Path(__file__).resolve()
ROOT = THIS_FILE.parent.parent
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
RESULTS_MAX_LINES = 400
CELL_MAX_CHARS = 200
GLANCE_HEADER = ["benchmark", "figure", "command", "measured", "anchor"]
DESIGN = ROOT / "docs" / "DESIGN.md"

#: Python files whose comments and strings are scanned (this file names the labels it bans).
CODE_FOLDERS = ("models", "planners", "validation", "twin", "benchmarks", "tests")
#: Markdown files scanned whole.
TEXT_FILES = ("README.md", "benchmarks/RESULTS.md")
TEXT_FOLDERS = ("docs",)

#: "S1".."S19" standing alone ("Spec-S5" and identifiers such as ``S10`` are not labels).
SESSION_TAG = re.compile(r"(?<![\w-])S1?\d(?![\w-])")
SESSION_WORDS = re.compile(r"\b(?:this|that|last|next|previous|same|each) session\b"
                           r"|\bsessions? \d+\b", re.IGNORECASE)


def session_labels(text: str) -> list[str]:
    """The session labels in ``text``: each as the line it stands on."""
    found = []
    for line in text.splitlines():
        if SESSION_TAG.search(line) or SESSION_WORDS.search(line):
            found.append(line.strip())
    return found


def prose_of(path: Path) -> str:
    """The comments and string literals of a Python file, one per line (names, such as a
    constant ``S1``, are code, not prose)."""
    tokens = tokenize.generate_tokens(io.StringIO(path.read_text(encoding="utf-8")).readline)
    kinds = {tokenize.COMMENT, tokenize.STRING}
    fstring = getattr(tokenize, "FSTRING_MIDDLE", None)
    if fstring is not None:
        kinds.add(fstring)
    return "\n".join(tok.string for tok in tokens if tok.type in kinds)


def table_rows(path: Path, heading: str) -> list[list[str]]:
    """The table rows of the ``## heading`` section of a markdown file, as lists of
    stripped cells (header first, separator rows dropped)."""
    text = path.read_text(encoding="utf-8")
    marker = f"\n## {heading}\n"
    assert marker in text, f"{path.name} must have a '## {heading}' section"
    section = text.split(marker, 1)[1].split("\n## ", 1)[0]
    return [[c.strip() for c in line.strip()[1:-1].split(" | ")]
            for line in section.splitlines()
            if line.startswith("|") and not re.fullmatch(r"\|(?:\s*-+\s*\|)+", line)]


def glance_rows() -> list[list[str]]:
    """The rows of RESULTS.md's "At a glance" table (header first)."""
    return table_rows(RESULTS, "At a glance")


def test_session_label_scan_finds_labels_and_passes_the_rest():
    assert session_labels("the S16 code, 2.0 mm (S9: 1.1 s)") == ["the S16 code, 2.0 mm (S9: 1.1 s)"]
    assert session_labels("as measured this session") != []
    assert session_labels("204 Spec-S5 rafts; frontier tags s1, r1; a Python session kept "
                          "open") == []


def test_results_is_short():
    n = len(RESULTS.read_text(encoding="utf-8").splitlines())
    assert n <= RESULTS_MAX_LINES, (f"benchmarks/RESULTS.md has {n} lines (at most "
                                    f"{RESULTS_MAX_LINES}): move older figures to HISTORY.md")


def test_results_at_a_glance_has_one_short_row_per_benchmark():
    header, *rows = glance_rows()
    assert header == GLANCE_HEADER
    assert len(rows) >= 10
    names = [r[0] for r in rows]
    assert len(set(names)) == len(names), "one row per benchmark"
    for row in rows:
        assert len(row) == len(GLANCE_HEADER), row[0]
        long = [c for c in row if len(c) > CELL_MAX_CHARS]
        assert long == [], f"{row[0]}: a cell over {CELL_MAX_CHARS} characters (history goes to HISTORY.md)"
        assert re.match(r"\d{4}-\d{2}-\d{2}", row[3]), f"{row[0]}: date {row[3]!r} (YYYY-MM-DD)"
        assert "`" in row[2], f"{row[0]}: no command"


@pytest.mark.parametrize("folder", CODE_FOLDERS)
def test_no_session_labels_in_code(folder):
    hits = {p.relative_to(ROOT).as_posix(): labels
            for p in sorted((ROOT / folder).rglob("*.py"))
            if p != THIS_FILE and (labels := session_labels(prose_of(p)))}
    assert hits == {}, "session labels in comments or strings: say what and why, date figures"


def test_no_session_labels_in_readme_and_docs():
    files = [ROOT / f for f in TEXT_FILES]
    files += [p for d in TEXT_FOLDERS for p in sorted((ROOT / d).rglob("*.md"))]
    hits = {p.relative_to(ROOT).as_posix(): labels for p in files
            if (labels := session_labels(p.read_text(encoding="utf-8")))}
    assert hits == {}


def test_design_where_to_find_names_existing_modules():
    header, *rows = table_rows(DESIGN, "Where to find")
    assert header == ["behaviour", "module"]
    assert len(rows) >= 20
    missing = {}
    for behaviour, modules in rows:
        paths = re.findall(r"`([^`]+)`", modules)
        assert paths, f"{behaviour}: no module path"
        gone = [p for p in paths if not (ROOT / p.rstrip("/")).exists()]
        if gone:
            missing[behaviour] = gone
    assert missing == {}, "docs/DESIGN.md 'Where to find' names paths that do not exist"
