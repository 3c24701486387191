"""The structure rules of docs/DESIGN.md, checked on every test run.

- Dependencies point one way: models <- (planners | validation) <- twin, and the
  checkers do not share the planner's distance code (import-linter contracts in
  pyproject.toml, run with the maintained tool itself, not a hand-written walker).
- No source module is longer than a person holds in mind (``MAX_LINES``), except the
  modules that hold one numba kernel each (listed, with their size limit).
"""
from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("models", "planners", "validation", "twin")
MAX_LINES = 500


def test_import_contracts_hold():
    from importlinter.cli import lint_imports

    assert lint_imports(config_filename=str(ROOT / "pyproject.toml"), no_cache=True) == 0


def test_contracts_cover_every_package():
    """A broken layer list would let a new package slip past the contracts."""
    import tomllib

    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    assert sorted(cfg["root_packages"]) == sorted(PACKAGES)
    layers = next(c for c in cfg["contracts"] if c["type"] == "layers")["layers"]
    named = {p.strip() for layer in layers for p in layer.split("|")}
    assert named == set(PACKAGES)


@pytest.mark.parametrize("package", PACKAGES)
def test_modules_stay_small(package):
    long = {str(p.relative_to(ROOT)): n for p in sorted((ROOT / package).rglob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert long == {}, f"modules over {MAX_LINES} lines: split them along their seams"
