"""models/lazy.py: a package's public names load their module on first use."""
from __future__ import annotations

import sys
import types

import pytest

from rfp_twin.models.lazy import lazy_exports


def test_names_load_on_first_use_and_stay(monkeypatch):
    pkg = types.ModuleType("fakepkg")
    monkeypatch.setitem(sys.modules, "fakepkg", pkg)
    pkg.__getattr__, pkg.__dir__ = lazy_exports("fakepkg", {"sqrt": "math", "dumps": "json"})
    assert "sqrt" not in vars(pkg)
    import math

    assert pkg.sqrt is math.sqrt and vars(pkg)["sqrt"] is math.sqrt
    assert {"sqrt", "dumps"} <= set(pkg.__dir__())
    with pytest.raises(AttributeError, match="module 'fakepkg' has no attribute 'nope'"):
        pkg.__getattr__("nope")
