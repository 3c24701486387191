"""Golden-master regression: fixed-seed plans must not change unnoticed."""
from __future__ import annotations

import json

import pytest

from tests.planners.golden_scenarios import GOLDEN, SCENARIOS, fingerprint


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_plan_matches_golden_master(name):
    stored = json.loads(GOLDEN.read_text())[name]
    assert fingerprint(name) == stored
