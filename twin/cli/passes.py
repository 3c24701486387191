"""``rfp-twin plan --catalogue ... --passes K``: run the passes, write their folder, print a table.

The work is :func:`rfp_twin.twin.passes.observe_passes`; this module follows it with a
progress line, refuses to write a motion the 2D check did not pass, writes the folder
(:mod:`rfp_twin.twin.passes_files`) and prints one row per pass.
"""
from __future__ import annotations

import time
from pathlib import Path

from rich.table import Table

from rfp_twin.twin.cli.console import (EXIT_COLLISION, EXIT_INCOMPLETE, console, fail,
                                       progress_bar)


def run_passes_cli(rc, cat, settings, passes: int, *, seed: int, max_rounds: int, out: Path,
                   force: bool, layout: str | None, direct_stuck: float) -> None:
    """Observe ``cat`` in ``passes`` passes on ``rc``'s array and write ``out``."""
    from rfp_twin.twin.passes import observe_passes, passes_summary, within_reach
    from rfp_twin.twin.passes_files import write_passes

    t0 = time.perf_counter()
    n = rc.geom.n_robots
    with progress_bar("passes", "{task.completed}/{task.total}") as progress:
        task = progress.add_task(f"{n} robots: pass 1", total=passes)

        def on_pass(k: int, text: str) -> None:
            progress.update(task, completed=k - 1, description=f"{n} robots: {text}")

        done = observe_passes(rc, cat, settings, passes, seed=seed, max_rounds=max_rounds,
                              direct_stuck=direct_stuck, on_pass=on_pass)
        progress.update(task, completed=passes)
    bad = [p for p in done if not (p.motion.check.ok and p.run.outcome.check.ok)]
    if bad:
        c = bad[0].motion.check if not bad[0].motion.check.ok else bad[0].run.outcome.check
        raise fail(f"pass {bad[0].index}: the plan fails the 2D check: {len(c.collisions)} "
                   f"collision(s), min clearance {c.min_clearance_mm:.4f} mm; nothing written",
                   EXIT_COLLISION)
    summary = passes_summary(cat, done, within_reach(rc, cat, settings))
    summary["wall_time_s"] = time.perf_counter() - t0
    summary["direct_stuck"] = direct_stuck
    summary["motion_modes"] = ("direct: the stepwise planner from the previous poses to the "
                               "targets (deadlock search when its first run leaves at most "
                               "direct_stuck of the robots stuck), used when it keeps every "
                               "target and is no slower than via the fold; via "
                               "fold: the fold of the previous poses (the last pass's unfold "
                               "played backwards) then the unfold of the targets, checked "
                               "again as one motion")
    write_passes(out, cat, done, summary, layout=layout or rc.layout.name, overwrite=force)
    print_passes(summary, out)
    lost = sum(p.run.n_lost for p in done)
    if lost:
        raise fail(f"{lost} assigned target(s) not kept by the plans; see {out}/summary.json",
                   EXIT_INCOMPLETE)


def _pct(v) -> str:
    return "-" if v is None else f"{100 * v:.1f}"


def print_passes(summary: dict, out: Path) -> None:
    """One row per pass: science targets left, assigned, kept, rounds, completeness of the
    pass and cumulative, how the motion was made and its firmware-ready time; then the
    cumulative completeness by priority."""
    c = summary["counts"]
    t = Table(title=f"rfp-twin plan --passes {summary['n_passes']} -> {out}", show_header=True)
    for name in ("pass", "left", "assigned", "kept", "rounds", "pass %", "cum. %",
                 "in reach %", "motion", "motion s", "fold+unfold s", "2D"):
        t.add_column(name, justify="left" if name == "motion" else "right")
    for r in summary["passes"]:
        t.add_row(str(r["pass"]), str(r["available_science"]), str(r["assigned"]),
                  str(r["kept"]), str(r["rounds"]), _pct(r["completeness"]),
                  _pct(r["cumulative"]), _pct(r.get("cumulative_within_reach")), r["motion"],
                  f"{r['reconfiguration_s']:.2f}",
                  "-" if r["via_fold_s"] is None else f"{r['via_fold_s']:.2f}",
                  "clear" if r["check2d_ok"] else "COLLISION")
    console.print(t)
    done = summary["completeness"]
    prio = ", ".join(f"{p}: {_pct(v['completeness'])} %" for p, v in done["by_priority"].items())
    console.print(f"{summary['n_targets']} targets: {c['science']} science, {c['sky']} sky, "
                  f"{c['standard']} standard; wall {summary['wall_time_s']:.1f} s")
    console.print(f"science completeness after {summary['n_passes']} pass(es): "
                  f"{_pct(done['science'])} % ({done['n_observed']} of {done['n_science']}); "
                  f"of those within reach {_pct(done.get('within_reach'))} % "
                  f"({done.get('n_within_reach', '-')})")
    console.print(f"by priority: {prio}")
