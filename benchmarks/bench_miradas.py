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
2.1: the arm that failed goes first), those followed by a search over priorities
(priority-based search, Ma et al. 2019) on what they leave, or by make-way windows with
retreat vertices (ours, ``RECOVERING``, what ``rfp-twin plan`` uses): success rate, makespan, start-stop cycles, checks and planning time beside the
paper's (Sect. 8: 97 % from park, makespan median 102.55 s, range 96-114 s; 93 %
chained, median 90.6 s, max 108 s). Every plan found is passed through the independent
2D check (rfp_twin.validation.probe, every 0.01 s) and the FCL 3D check (every 0.1 s) at
buffer 0. The typical part also runs the plan in MuJoCo (contacts, motor tracking).

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
    from rfp_twin.twin.sim.probe import simulate_probe_plan
    from rfp_twin.validation.probe import check_probe_plan, check_probe_plan_3d

    c2 = check_probe_plan(kind.spec, plan.breakpoints(), dt_s=0.01, max_start_stop=1)
    c3 = check_probe_plan_3d(kind.spec, plan.breakpoints(), dt_s=0.1)
    sim = simulate_probe_plan(plan)
    print(f"| 2D check (every 0.01 s, bodies) | {'clear' if c2.ok else 'FAIL'}, min gap "
          f"{c2.min_gap_mm:.2f} mm | - |")
    print(f"| 3D check (FCL, every 0.1 s) | {'clear' if c3.ok else 'FAIL'}, min distance "
          f"{c3.min_distance_mm:.2f} mm, {len(c3.contacts)} contacts | - |")
    print(f"| MuJoCo run ({sim.duration_s:.0f} s, {sim.steps} steps) | {sim.n_contact_steps} "
          f"contact steps, tracking <= {sim.max_tracking_deg:.3f} deg, loop gap <= "
          f"{sim.max_loop_gap_mm:.4f} mm, {sim.wall_s:.0f} s wall | - |")
    print("\n```\n" + plan.tables() + "\n```\n")


#: Policies compared: name -> ProbePlanSettings fields. "windows": after the re-plans,
#: passes with make-way windows (the arms that failed before, while not yet planned,
#: stand at their start for the first 12 / 24 / 36 s, so earlier arms wait for them to
#: leave); retreat / stop-over vertices in every pass after the first; "search": the
#: re-plans, then priority-based search (Ma et al. 2019) on what they leave.
ROWS = {"paper": dict(priority="travel-time"), "still": dict(priority="still-first"),
        "random": dict(priority="random"), "replans": dict(priority="travel-time", replans=8),
        "search": dict(priority="travel-time", replans=8, search_nodes=24),
        "windows": dict(priority="travel-time", replans=8, windows_s=(12.0, 24.0, 36.0),
                        retreat_deg=(15.0, 30.0, 45.0))}   # = RECOVERING (rfp-twin plan)


def policy_label(kw: dict) -> str:
    """One line naming a policy's settings."""
    out = kw["priority"]
    if kw.get("replans"):
        out += f", {kw['replans']} re-plans"
    if kw.get("windows_s"):
        out += f", windows {'/'.join(f'{w:g}' for w in kw['windows_s'])} s + retreats"
    if kw.get("search_nodes"):
        out += f", then search ({kw['search_nodes']} nodes)"
    return out


def many(n_sets: int, seed: int, check_dt: float, rows: list[str], check_3d: bool) -> None:
    from rfp_twin.models.kinds import load_kind
    from rfp_twin.planners.roadmap.probe import ProbePlanSettings, plan_probe_arms, random_target_set
    from rfp_twin.validation.probe import check_probe_plan, check_probe_plan_3d

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
          "checks median | planning median / max (s) | 2D check | 3D check (min mm) | most passes "
          "| unsolved sets |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for mode in ("park", "chained"):
        for name in rows:
            settings = ProbePlanSettings(**ROWS[name])
            ok, spans, cycles, checks, secs, bad, passes = 0, [], 0, [], [], 0, 1
            bad3, min3, unsolved = 0, np.inf, []
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
                    if check_3d:
                        rep3 = check_probe_plan_3d(kind.spec, plan.breakpoints(), dt_s=0.1)
                        bad3 += not rep3.ok
                        min3 = min(min3, rep3.min_distance_mm)
                else:
                    unsolved.append(k)
            label = policy_label(ROWS[name])
            print(f"| {mode} | {label} | {ok}/{n_sets} = {100 * ok / n_sets:.1f} % | "
                  f"{np.median(spans):.1f} | {min(spans):.0f}-{max(spans):.0f} | {cycles} | "
                  f"{np.median(checks):.0f} | {np.median(secs):.3f} / {max(secs):.3f} | "
                  f"{'clear' if bad == 0 else f'{bad} FAIL'} | "
                  f"{('clear' if bad3 == 0 else f'{bad3} FAIL') + f' ({min3:.2f})' if check_3d else '-'}"
                  f" | {passes} | {' '.join(map(str, unsolved)) or '-'} |", flush=True)
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
    ap.add_argument("--no-3d", action="store_true", help="skip the FCL 3D check (0.1 s spacing)")
    args = ap.parse_args()
    print(f"{machine_info('numba')}\n")
    print(f"command: `{command_line()}`\n")
    if args.part in ("typical", "all"):
        typical(args.repeat)
    if args.part in ("many", "all"):
        many(args.sets, args.seed, args.check_dt, args.rows, not args.no_3d)


if __name__ == "__main__":
    main()
