"""MIRADAS probe arms (Sabater et al. 2018): the typical scenario and many target sets.

Part ``typical``: the whole command ``rfp-twin plan --preset miradas-probe --layout
miradas-12 --algorithm roadmap`` timed in fresh processes (imports, targets, planning,
the independent 2D check, the run folder), the planning time alone, and the plan in the
form of the paper's Tables 1-2 beside its figures (Sect. 8.1: 16.14 s on a 3.2 GHz
2-core i5, 75,684 collision checks, makespan 19 steps of 6 s = 114 s against 18 for the
unconstrained optimum, at most one start-stop cycle per arm).

Part ``many``: target sets of 6-12 targets drawn in the field (final poses clear of
each other, arms without a target parked), planned from park and chained (each set
from the previous one's poses), with the paper's travel-time priorities, the same with
the arms that stay still first, random ones, travel-time with up to 8 re-plans (Sect.
2.1: the arm that failed goes first), and those followed by a search over priorities
(priority-based search, Ma et al. 2019) on what they leave: success rate, makespan, start-stop cycles, checks and planning time beside the
paper's (Sect. 8: 97 % from park, makespan median 102.55 s, range 96-114 s; 93 %
chained, median 90.6 s, max 108 s). Every plan found is passed through the independent
check (rfp_twin.validation.probe) at buffer 0.

Usage (from the repository root)::

    .venv/bin/python benchmarks/bench_miradas.py --part typical --repeat 3
    .venv/bin/python benchmarks/bench_miradas.py --part many --sets 200 --seed 1
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_common import ROOT, command_line, machine_info

#: Sabater 2018 Sect. 8.1 and Tables 1-2.
PAPER_TYPICAL = {"seconds": 16.14, "checks": 75684, "makespan_steps": 19, "optimum_steps": 18,
                 "max_start_stop": 1}


def typical(repeat: int) -> None:
    from rfp_twin.models.kinds import load_kind
    from rfp_twin.planners.roadmap.probe import plan_probe_arms, typical_scenario

    walls = []
    for k in range(repeat):
        with tempfile.TemporaryDirectory() as tmp:
            cmd = [sys.executable, "-m", "rfp_twin.twin.cli", "plan", "--preset", "miradas-probe",
                   "--layout", "miradas-12", "--algorithm", "roadmap", "--out", f"{tmp}/run"]
            t0 = time.perf_counter()
            r = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
            walls.append(time.perf_counter() - t0)
            if r.returncode != 0:
                raise SystemExit(f"command failed ({r.returncode}): {r.stdout}\n{r.stderr}")
    kind = load_kind("miradas-probe")
    start, goal = typical_scenario(kind)
    plans = [plan_probe_arms(kind, start, goal, rng=np.random.default_rng(0)) for _ in range(repeat)]
    plan = plans[-1]
    plan_s = [p.seconds for p in plans]
    print("## Typical scenario (12 arms from park)\n")
    print("command: `rfp-twin plan --preset miradas-probe --layout miradas-12 --algorithm roadmap`\n")
    print("| quantity | ours | Sabater 2018 |")
    print("|---|---|---|")
    print(f"| whole command, fresh process (s) | {min(walls):.2f} - {max(walls):.2f} "
          f"(median {np.median(walls):.2f}) | - |")
    print(f"| planning (s) | {np.median(plan_s):.3f} (median of {repeat}; first in process "
          f"{plan_s[0]:.3f}) | {PAPER_TYPICAL['seconds']} |")
    print(f"| ratio (paper / ours, planning) | {PAPER_TYPICAL['seconds'] / np.median(plan_s):.0f}x | - |")
    print(f"| collision checks | {plan.checks} | {PAPER_TYPICAL['checks']} |")
    print(f"| makespan (steps of 6 s) | {plan.makespan_steps} | {PAPER_TYPICAL['makespan_steps']} |")
    print(f"| largest optimum (steps) | {max(r.optimum_steps for r in plan.rows)} | "
          f"{PAPER_TYPICAL['optimum_steps']} |")
    print(f"| most start-stop cycles of an arm | {plan.max_start_stop} | "
          f"{PAPER_TYPICAL['max_start_stop']} |")
    print("\n```\n" + plan.tables() + "\n```\n")


#: Policies compared: name -> (priority, re-plans, search-tree nodes after them).
ROWS = {"paper": ("travel-time", 0, 0), "still": ("still-first", 0, 0),
        "random": ("random", 0, 0), "replans": ("travel-time", 8, 0),
        "search": ("travel-time", 8, 24)}


def many(n_sets: int, seed: int, check_dt: float, rows: list[str]) -> None:
    from rfp_twin.models.kinds import load_kind
    from rfp_twin.planners.roadmap.probe import ProbePlanSettings, plan_probe_arms, random_target_set
    from rfp_twin.validation.probe import check_probe_plan

    kind = load_kind("miradas-probe")
    park = kind.park()
    rng = np.random.default_rng(seed)
    from_park = [random_target_set(kind, rng, int(rng.integers(6, 13)), park)
                 for _ in range(n_sets)]
    chain, current = [], park
    for _ in range(n_sets):
        goal = random_target_set(kind, rng, int(rng.integers(6, 13)), current, rest=park)
        chain.append((current, goal))
        current = goal
    print(f"## {n_sets} target sets of 6-12 targets (seed {seed})\n")
    print("| mode | priority | solved | makespan median (s) | range (s) | most cycles | "
          "checks median | planning median / max (s) | 2D check | most passes |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for mode in ("park", "chained"):
        for name in rows:
            policy, replans, nodes = ROWS[name]
            settings = ProbePlanSettings(priority=policy, replans=replans, search_nodes=nodes)
            ok, spans, cycles, checks, secs, bad, passes = 0, [], 0, [], [], 0, 1
            pairs = [(park, g) for g in from_park] if mode == "park" else chain
            for k, (start, goal) in enumerate(pairs):
                plan = plan_probe_arms(kind, start, goal, settings, np.random.default_rng(seed + k))
                secs.append(plan.seconds)
                checks.append(plan.checks)
                if plan.success:
                    ok += 1
                    passes = max(passes, plan.passes)
                    spans.append(plan.makespan_s)
                    cycles = max(cycles, plan.max_start_stop)
                    rep = check_probe_plan(kind.spec, plan.breakpoints(), dt_s=check_dt,
                                           max_start_stop=settings.max_start_stop)
                    bad += not rep.ok
            label = policy + (f", {replans} re-plans" if replans else "") + (
                f", then search ({nodes} nodes)" if nodes else "")
            print(f"| {mode} | {label} | {ok}/{n_sets} = {100 * ok / n_sets:.1f} % | "
                  f"{np.median(spans):.1f} | {min(spans):.0f}-{max(spans):.0f} | {cycles} | "
                  f"{np.median(checks):.0f} | {np.median(secs):.3f} / {max(secs):.3f} | "
                  f"{'clear' if bad == 0 else f'{bad} FAIL'} | {passes} |")
    print("\nSabater 2018 Sect. 8: from park 97 %, makespan median 102.55 s, range 96-114 s; "
          "chained 93 %, median 90.6 s, max 108 s (travel-time priorities, one pass).\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=("typical", "many", "all"), default="all")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--sets", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--rows", nargs="+", choices=sorted(ROWS), default=list(ROWS),
                    help="policies of the many-set part")
    ap.add_argument("--check-dt", type=float, default=0.01, help="2D check sample spacing, s")
    args = ap.parse_args()
    print(f"{machine_info('numba')}\n")
    print(f"command: `{command_line()}`\n")
    if args.part in ("typical", "all"):
        typical(args.repeat)
    if args.part in ("many", "all"):
        many(args.sets, args.seed, args.check_dt, args.rows)


if __name__ == "__main__":
    main()
