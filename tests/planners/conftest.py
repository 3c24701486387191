"""Shared builders for planner tests: small arrays built inline, plans through the pipeline."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.stepwise import max_displacement
from rfp_twin.twin.pipeline import PlanOptions
from rfp_twin.twin.pipeline import plan_random as _pipeline_plan_random


def make_geom(n_positions: int = 37, buffer_mm: float = 2.0, preset: str = "sdss-v",
              fold=None) -> ArrayGeometry:
    spec = load_spec(preset)
    if fold is not None:
        spec = spec.with_overrides(fold_deg=tuple(fold))
    return ArrayGeometry(spec, Layout.hex_grid_positions(n_positions, spec.pitch_mm), buffer_mm)


def hex7_folded(step: float = 0.5):
    """The 7-robot hex at 2.0 mm: (geometry, step deg, MD mm, every robot's fold (n, 2),
    the centre robot's index)."""
    geom = make_geom(7, 2.0)
    spec = geom.spec
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()),
                          step)
    fold = np.tile(np.asarray(spec.fold_deg, float), (geom.n_robots, 1))
    return geom, step, md, fold, int(np.argmin(np.hypot(*geom.base_xy.T)))


def plan_random(geom: ArrayGeometry, seed: int, resolve: bool = True, resolver: str = "replace",
                **options):
    """Seeded random targets (clear by the planner's MD) and a plan; returns (targets, plan).

    The pipeline's own sequence (:func:`rfp_twin.twin.pipeline.plan_random`). ``resolver`` is the
    deadlock resolution: these tests (and the golden masters) were written for target
    replacement, so that stays their default here; ``resolve=False`` stops after the
    first run.
    """
    opts = PlanOptions(resolve=resolver if resolve else "none", **options)
    targets, plan, _ = _pipeline_plan_random(geom, seed, opts)
    return targets, plan


@pytest.fixture(scope="session")
def sdss_547():
    return Layout.sdss_v_grid()
