"""Fixtures shared by the twin tests."""
from __future__ import annotations

import pytest

from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.robot import load_spec


@pytest.fixture(scope="module")
def twin7():
    """The MuJoCo twin of a 7-robot SDSS-V hex grid."""
    spec = load_spec("sdss-v")
    return build_model(spec, Layout.hex_grid(1, spec.pitch_mm))
