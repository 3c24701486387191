"""The ``planners`` package's public API (planners/__init__.py)."""
from __future__ import annotations

import subprocess
import sys

import pytest

from rfp_twin import planners


def test_every_exported_name_resolves():
    for name in planners.__all__:
        assert getattr(planners, name) is not None, name


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        planners.nope  # noqa: B018


def test_importing_planners_compiles_nothing():
    code = "import sys; from rfp_twin import planners; print([m for m in ('numba', 'scipy', 'toppra') if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
