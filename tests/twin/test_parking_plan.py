"""A robot parked off the fold (``parking="clear"``) is a target the planner reaches: the
plan keeps the target the folded neighbour blocked and passes the independent 2D check."""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.assignment import AssignSettings
from rfp_twin.twin.pipeline import Reconfiguration
from rfp_twin.twin.plannable import plan_catalogue
from rfp_twin.validation.checker2d import check_trajectory

from tests.planners.assignment.test_parking import blocked_case


def test_the_plan_keeps_the_target_and_passes_the_2d_check():
    geom, _, cat, _ = blocked_case()
    rc = Reconfiguration(geom)
    run = plan_catalogue(rc, cat, AssignSettings(parking="clear"), seed=1)
    out = run.outcome
    assert run.n_lost == 0 and run.assignment.n_assigned == 1
    assert np.all(out.plan.status == "reached")
    assert np.allclose(out.plan.targets, run.assignment.angles)
    assert check_trajectory(out.trajectory, rc.spec, rc.layout, out.post.verify_buffer_mm).ok


def test_the_cli_option_declares_the_assigners_parking_modes():
    from rfp_twin.models.options import option_info
    from rfp_twin.planners.assignment.candidates import DEFAULT_PARKING, PARKING_MODES
    from rfp_twin.twin.cli.shared_options import CatalogueOptions

    assert option_info(CatalogueOptions, "parking").choices == PARKING_MODES
    assert CatalogueOptions().parking == DEFAULT_PARKING
    assert CatalogueOptions(parking="clear").settings().parking == "clear"
