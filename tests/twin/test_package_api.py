"""The ``twin`` package's public API (twin/__init__.py): every exported name resolves,
and importing the package alone loads none of the heavy libraries."""
from __future__ import annotations

import subprocess
import sys

from rfp_twin import twin


def test_every_exported_name_resolves():
    for name in twin.__all__:
        assert getattr(twin, name) is not None, name


def test_importing_twin_stays_light():
    code = ("import sys; from rfp_twin import twin; heavy = [m for m in ('mujoco', 'numba', 'fcl', 'toppra', 'dask') "
            "if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
