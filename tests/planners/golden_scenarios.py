"""Golden-master scenarios: fixed seeds whose plan fingerprints are stored in golden/.

Regenerate after an intended behaviour change with
``python -m tests.planners.golden_scenarios`` and say why in the commit message.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tests.planners.conftest import make_geom, plan_random

GOLDEN = Path(__file__).parent / "golden" / "plans.json"

#: name -> (positions, buffer mm, seed, settings)
SCENARIOS = {
    "gc-91-2.0-s3": (91, 2.0, 3, {"step_deg": 0.1}),
    "gc-169-3.0-s1": (169, 3.0, 1, {"step_deg": 0.25}),
    "gc-547-2.5-s0": (547, 2.5, 0, {"step_deg": 0.25}),
    "mc-37-2.5-s2": (37, 2.5, 2, {"step_deg": 0.5, "algorithm": "markov"}),
}


def fingerprint(name: str) -> dict:
    """What a scenario's plan looks like: sizes, metrics and a checksum of its paths."""
    n, buffer_mm, seed, settings = SCENARIOS[name]
    _, plan = plan_random(make_geom(n, buffer_mm), seed, **settings)
    m = plan.metrics
    return {
        "n_steps": int(plan.n_steps),
        "n_breakpoints": int(plan.path_step.size),
        "n_replaced": int(m["n_replaced"]),
        "rounds": int(m["rounds"]),
        "efficiency": round(float(m["efficiency"]), 6),
        "convergence": round(float(m["convergence"]), 6),
        "angle_sum_deg": round(float(np.sum(plan.path_angles)), 3),
    }


if __name__ == "__main__":
    GOLDEN.write_text(json.dumps({k: fingerprint(k) for k in SCENARIOS}, indent=2) + "\n")
    print(f"wrote {GOLDEN}")
