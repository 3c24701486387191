"""The typical MIRADAS plan simulated in MuJoCo: no contact, tracking within 0.5 deg."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.kinds import load_kind
from rfp_twin.planners.roadmap.probe import plan_probe_arms, typical_scenario
from rfp_twin.twin.sim.probe import simulate_probe_plan


def test_typical_plan_in_mujoco_first_quarter():
    kind = load_kind("miradas-probe")
    start, goal = typical_scenario(kind)
    plan = plan_probe_arms(kind, start, goal, rng=np.random.default_rng(0))
    rep = simulate_probe_plan(plan, duration_s=24.0)       # the whole plan: benchmarks
    assert rep.ok and rep.n_contact_steps == 0, rep.contacts
    assert rep.max_tracking_deg < 0.5 and rep.max_loop_gap_mm < 0.05
    assert rep.steps == 12000


def test_video_of_a_plan(tmp_path):
    import imageio.v3 as iio

    from rfp_twin.twin.render.probe import render_probe_plan

    kind = load_kind("miradas-probe")
    start, goal = typical_scenario(kind)
    plan = plan_probe_arms(kind, start, goal, rng=np.random.default_rng(0))
    path = render_probe_plan(plan, tmp_path / "bench.mp4", fps=2, speedup=30.0, width=96,
                             height=96)
    frames = iio.imread(path, index=None)
    assert frames.shape == (int(plan.makespan_s / 30.0 * 2) + 1, 96, 96, 3)
    assert frames[0].std() > 5 and not (frames[0] == frames[-1]).all()   # arms moved
