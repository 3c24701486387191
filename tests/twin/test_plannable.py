"""Assignment and planning as one loop: the plan keeps every assigned target, and a target
the plan loses goes back to the assigner as a forbidden (robot, target) pair."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.catalogue import Disc, density_per_mm2, mock_catalogue
from rfp_twin.planners.assignment import AssignSettings
from rfp_twin.twin.pipeline import Reconfiguration
from rfp_twin.twin.plannable import lost_pairs, plan_catalogue
from rfp_twin.validation.checker2d import check_trajectory


def small(buffer_mm=2.0, n=19, per_patrol=1.5, seed=2):
    rc = Reconfiguration.from_names("sdss-v", f"hex:{n}", buffer_mm=buffer_mm)
    lo, hi = rc.spec.patrol_annulus_mm
    cat = mock_catalogue(np.random.default_rng(seed), Disc((0.0, 0.0), 60.0),
                         density_per_mm2(per_patrol, "patrol",
                                         patrol_area_mm2=np.pi * (hi * hi - lo * lo)))
    return rc, cat


def test_the_plan_keeps_every_assigned_target_and_passes_the_2d_check():
    rc, cat = small()
    run = plan_catalogue(rc, cat, AssignSettings(), seed=1)
    out = run.outcome
    a = run.assignment
    assert run.n_lost == 0 and len(run.rounds) == 1 and a.n_assigned > 0
    assert np.all(out.plan.status == "reached")
    assert np.allclose(out.plan.targets, a.angles)
    assert check_trajectory(out.trajectory, rc.spec, rc.layout, out.post.verify_buffer_mm).ok
    s = run.summary(cat)
    assert s["kept"] == s["assigned"] == a.n_assigned and s["n_rounds"] == 1


def test_a_target_the_plan_loses_is_forbidden_in_the_next_round(monkeypatch):
    """The first plan is made to lose one assigned target: the second round assigns
    without that (robot, target) pair, and the loop stops when nothing is lost."""
    from dataclasses import replace

    rc, cat = small()
    real_run = rc.run
    seen = []

    def run(*, seed=0, targets=None, **kw):
        out = real_run(seed=seed, targets=targets, **kw)
        seen.append(np.array(targets))
        if len(seen) == 1:
            moved = np.flatnonzero(np.abs(targets[:, 1] - rc.spec.fold_deg[1]) > 1e-9)
            status = out.plan.status.copy()
            status[moved[0]] = "replaced"
            out.plan = replace(out.plan, status=status)
        return out

    monkeypatch.setattr(rc, "run", run)
    first = plan_catalogue(rc, cat, AssignSettings(), seed=1, max_rounds=1)
    on = np.flatnonzero(first.assignment.target >= 0)
    monkeypatch.setattr(rc, "run", run)
    seen.clear()
    loop = plan_catalogue(rc, cat, AssignSettings(), seed=1)
    assert [r["lost"] for r in loop.rounds] == [1, 0]
    assert loop.rounds[1]["forbidden_before"] == 1
    k = int(np.flatnonzero(np.abs(seen[0][:, 1] - rc.spec.fold_deg[1]) > 1e-9)[0])
    lost = (int(rc.geom.robot_ids[k]), int(first.assignment.target_ids[k]))
    assert k in on
    final = set(zip(rc.geom.robot_ids.tolist(), loop.assignment.target_ids.tolist()))
    assert lost not in final


def test_lost_pairs_names_robot_and_target_ids():
    rc, cat = small(n=7, per_patrol=2.0)
    run = plan_catalogue(rc, cat, AssignSettings(), seed=1)
    a = run.assignment
    status = np.full(rc.geom.n_robots, "reached", dtype=object)
    on = np.flatnonzero(a.target >= 0)
    status[on[0]] = "deadlocked"
    off = np.flatnonzero(a.target < 0)
    if off.size:
        status[off[0]] = "replaced"          # a parked robot loses no target
    assert lost_pairs(rc, a, status) == {(int(rc.geom.robot_ids[on[0]]), int(a.target_ids[on[0]]))}
