"""Small studies and hand-made rows shared by the study tests."""
from __future__ import annotations

from pathlib import Path

from rfp_twin.twin.studies import Study, Trial, load_study, parse_study

#: 2 buffers x 2 algorithms x 2 trials on a 19-robot grid (8 trials, ~1 s of planning).
TINY = """
[study]
name = "tiny"
trials = 2
seed = 11
[grid]
n_robots = 19
buffer_mm = [1.5, 3.0]
step_deg = 0.5
algorithm = ["GC", "MC"]
"""

#: Results that must not depend on where or when a trial ran.
DETERMINISTIC = ("key", "point_id", "trial", "seed", "status", "efficiency", "convergence",
                 "fold_time_s", "n_replaced", "n_deadlocked", "rounds", "n_steps", "collisions")


def study_file(text: str, folder: Path, name: str = "study.toml") -> Study:
    """Write ``text`` to ``folder/name`` and load it as a user's study file."""
    path = folder / name
    path.write_text(text)
    return load_study(path)


def tiny_results_folder(folder: Path) -> tuple[Study, Path, list[Trial]]:
    """The TINY study, its empty results folder ``folder/out/results`` (made here) and its
    8 trials, for tests that write rows by hand."""
    study = parse_study(TINY)
    results = folder / "out" / "results"
    results.mkdir(parents=True)
    return study, results, study.trial_list()


def rows_by_key(table) -> dict:
    return {r["key"]: r for r in table.to_pylist()}


def made_row(study: Study, t: Trial, **metrics) -> dict:
    """A row for trial ``t`` of ``study`` with given metrics (the rest plausible): rows of
    a shape no short run produces (547 robots, paper conditions) without running it."""
    p = t.point
    row = dict(p.to_dict(), key=t.key, study=study.name, point_id=p.point_id, trial=t.index,
               base_seed=study.seed, seed=t.seed, n_fiducials=0, reach_mm=p.reach_mm,
               pitch_over_reach=p.pitch_mm / p.reach_mm, status="ok", efficiency=1.0,
               convergence=1.0, fold_time_s=12.0, tau_pg_s=0.1, tau_sr_s=0.2, n_replaced=0,
               n_deadlocked=0, rounds=1, n_steps=1000, checked=True, collisions=0,
               min_clearance_mm=0.1, check_s=0.1, wall_s=0.5, worker="host:1", error=None)
    row.update(metrics)
    return row
