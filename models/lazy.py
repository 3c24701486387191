"""Lazy public names for a package's ``__init__``: each loads its module on first use.

``import planners`` (or models, validation, twin) then stays cheap, and numba, mujoco
or fcl load only when a name that needs them is used::

    __getattr__, __dir__ = lazy_exports(__name__, {"plan_reconfiguration": "rfp_twin.planners.plan"})
"""
from __future__ import annotations

import importlib
import sys
from typing import Callable


def lazy_exports(package: str, exports: dict[str, str]) -> tuple[Callable, Callable]:
    """Module-level ``__getattr__`` and ``__dir__`` for ``package``: ``exports`` maps each
    public name to the module that defines it; a loaded name is kept in the package."""
    def __getattr__(name: str):
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(exports[name]), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return __getattr__, __dir__
