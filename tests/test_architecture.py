"""The structure rules of docs/DESIGN.md, checked on every test run.

- Dependencies point one way: models <- (planners | validation) <- twin, the checkers
  do not share the planner's distance code, and the deadlock strategies do not import
  each other (import-linter contracts in pyproject.toml, run with the maintained tool
  itself, not a hand-written walker).
- No source module is longer than a person holds in mind (``MAX_LINES``).
"""
from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: The four folders, installed as rfp_twin.models, rfp_twin.planners, ...
PACKAGES = ("models", "planners", "validation", "twin")
MAX_LINES = 500


def test_import_contracts_hold():
    from importlinter.cli import lint_imports

    assert lint_imports(config_filename=str(ROOT / "pyproject.toml"), no_cache=True) == 0


def test_contracts_cover_every_package():
    """A broken layer list would let a new package slip past the contracts."""
    import tomllib

    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    packages = {f"rfp_twin.{p}" for p in PACKAGES}
    assert set(cfg["root_packages"]) == packages
    layers = next(c for c in cfg["contracts"] if c["type"] == "layers")["layers"]
    named = {p.strip() for layer in layers for p in layer.split("|")}
    assert named == packages


@pytest.mark.parametrize("package", PACKAGES)
def test_modules_stay_small(package):
    long = {p.relative_to(ROOT).as_posix(): n for p in sorted((ROOT / package).rglob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert long == {}, f"modules over {MAX_LINES} lines: split them along their seams"


def test_every_package_folder_is_installed():
    """pyproject lists packages one by one: a new subpackage must be in the list, or a
    wheel (a non-editable install) would leave it out."""
    import tomllib

    tool = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    mapping = tool.get("package-dir", {})

    def folder(name: str) -> Path:
        for prefix, path in sorted(mapping.items(), key=lambda kv: -len(kv[0])):
            if name == prefix or name.startswith(prefix + "."):
                return ROOT / path / Path(*name[len(prefix):].strip(".").split(".") if name != prefix else ())
        return ROOT / Path(*name.split("."))

    listed = {folder(name).resolve() for name in tool["packages"]}
    present = {p.parent.resolve() for pk in PACKAGES for p in (ROOT / pk).rglob("__init__.py")}
    assert present - listed == set(), "add these packages to [tool.setuptools] packages"
    assert all(p.is_dir() for p in listed)


def test_code_imports_the_installed_names_only():
    """Code imports ``rfp_twin.models`` etc., never the folders as top-level packages (a
    checkout on sys.path would make both work, and load every module twice)."""
    import re

    bare = re.compile(r"^\s*(from|import)\s+(" + "|".join(PACKAGES) + r")(\.|\s|$)", re.M)
    offenders = [str(p.relative_to(ROOT)) for folder in (*PACKAGES, "tests", "benchmarks")
                 for p in (ROOT / folder).rglob("*.py") if bare.search(p.read_text(encoding="utf-8"))]
    assert offenders == []


def test_no_private_name_is_imported_across_modules():
    """What two modules share has a public name where it belongs: no ``from x import _y``
    in the code, its tests or the benchmarks."""
    import ast

    offenders = []
    for folder in (*PACKAGES, "tests", "benchmarks"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.ImportFrom) and node.module:
                    offenders += [f"{path.relative_to(ROOT)}: {node.module}.{a.name}"
                                  for a in node.names
                                  if a.name.startswith("_") and not a.name.startswith("__")]
    assert offenders == []


def test_the_planners_folder_reads_as_the_stages_and_the_driver_stays_short():
    """planners/ holds at most 8 entries (the stages' packages), and the plan driver,
    :func:`rfp_twin.planners.plan.reconfigure.plan_reconfiguration`, fits in 60 lines."""
    import ast
    import subprocess

    tracked = subprocess.run(["git", "ls-files", "planners"], cwd=ROOT, capture_output=True,
                             text=True).stdout.split()
    entries = {p.split("/")[1] for p in tracked} if tracked else \
        {p.name for p in (ROOT / "planners").iterdir() if p.name != "__pycache__"}
    assert len(entries) <= 8, sorted(entries)
    tree = ast.parse((ROOT / "planners" / "plan" / "reconfigure.py").read_text(encoding="utf-8"))
    driver = next(n for n in tree.body
                  if isinstance(n, ast.FunctionDef) and n.name == "plan_reconfiguration")
    assert driver.end_lineno - driver.lineno + 1 <= 60
