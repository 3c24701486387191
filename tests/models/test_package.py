"""Tests of models/__init__.py: the public API of the instrument, loaded lazily."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from rfp_twin import models


def test_import_models_loads_no_heavy_dependency():
    code = ("import sys\nfrom rfp_twin import models\n"
            "print(sorted(m for m in ('numba', 'scipy', 'trimesh', 'mujoco', 'manifold3d')"
            " if m in sys.modules))")
    root = Path(models.__file__).resolve().parent.parent           # this checkout's models
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_every_public_name_resolves_to_its_module_object():
    from rfp_twin.models.array import ArrayGeometry
    from rfp_twin.models.kinematics import forward
    from rfp_twin.models.layout import Layout, layout_by_name
    from rfp_twin.models.mjcf import build_model
    assert models.Layout is Layout and models.layout_by_name is layout_by_name
    assert models.ArrayGeometry is ArrayGeometry and models.forward is forward
    assert models.build_model is build_model
    for name in models.__all__:
        assert getattr(models, name) is not None, name
    assert set(models.__all__) <= set(dir(models))


def test_unknown_names_raise_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'Nope'"):
        models.Nope  # noqa: B018
    assert issubclass(models.SpecError, models.RfpError)
