"""Shared builders for planner tests: small arrays built inline."""
from __future__ import annotations

import numpy as np
import pytest

from models.array import ArrayGeometry
from models.layout import Layout
from models.robot import load_spec
from planners.solver import PlannerSettings, plan_reconfiguration
from planners.stepwise import max_displacement
from planners.targets import random_targets


def make_geom(n_positions: int = 37, buffer_mm: float = 2.0, preset: str = "sdss-v",
              fold=None) -> ArrayGeometry:
    spec = load_spec(preset)
    if fold is not None:
        spec = spec.with_overrides(fold_deg=tuple(fold))
    return ArrayGeometry(spec, Layout.hex_grid_positions(n_positions, spec.pitch_mm), buffer_mm)


def plan_random(geom: ArrayGeometry, seed: int, resolve: bool = True, resolver: str = "replace",
                **settings):
    """Seeded random targets (clear by the planner's MD) and a plan; returns (targets, plan).

    ``resolver`` is PlannerSettings.resolve: these tests (and the golden masters) were
    written for target replacement, so that stays their default here.
    """
    s = PlannerSettings(resolve=resolver, **settings)
    rng = np.random.default_rng(seed)
    md = max_displacement(geom.spec.alpha_length_mm, geom.spec.beta_length_mm,
                          float(geom.seg_end.max()), s.step_deg)
    targets = random_targets(geom, rng, margin_mm=md)
    return targets, plan_reconfiguration(geom, targets, s, rng, resolve=resolve)


@pytest.fixture(scope="session")
def sdss_547():
    return Layout.sdss_v_grid()
