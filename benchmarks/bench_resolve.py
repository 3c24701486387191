#!/usr/bin/env python
"""Deadlock resolution benchmark: state-time search (targets kept) vs target replacement.

Run from the repository root::

    .venv/bin/python benchmarks/bench_resolve.py [--trials N] [--buffers 1.5 ... 3.5]
        [--algorithms greedy markov] [--seed S] [--workers W] [--raw FILE]
        [--md-out FILE] [--no-check] [--report-only]

On the paper's 547 all-robot grid (preset ``sdss-v``, Sayres 2021 Table 3), for each
buffer and algorithm, N trials: seeded random targets (``Reconfiguration.random_targets``
of :mod:`rfp_twin.twin.pipeline`: margin = the step rule's MD, as ``rfp-twin plan`` draws them),
then the same targets planned twice by the pipeline's planning step
(``Reconfiguration.plan``) with the same generator seed, reverse planning:

* ``replace``: one target per deadlocked group replaced, everything re-planned (Sayres
  2021 Sect. 5.2; ``PlannerSettings(resolve="replace")``);
* ``search``: each deadlocked group re-planned by the prioritized state-time search of
  ``planners/deadlocks/search.py`` (Sabater 2018), targets kept; a target is replaced
  only where the search fails (``PlannerSettings(resolve="search")``).

Both start from the same first stepwise run. Step: 0.25 deg below 3 mm, 0.1 deg from
3 mm (``--steps`` overrides). Reported per cell: efficiency (Eq. 11) of both, robots
replaced per trial, groups the first run left, groups resolved by search, search
failures, search time, the wall time of the whole planning step (what a user waits
for), and (unless ``--no-check``) the collisions the independent 2D checker finds in
every search plan at the planning buffer (must be 0; the pipeline's raw delivery,
``Reconfiguration.deliver``).

Every trial is appended to a JSON-lines file (``--raw``, default
``out/bench_resolve.jsonl``) as it finishes, so an interrupted run keeps what it
did and resumes where it stopped; ``--report-only`` rebuilds the tables from that file.
Prints rich tables, then a markdown block for benchmarks/RESULTS.md.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from bench_common import (command_line, load_average, machine_info, md_table, source_fingerprint,
                          wide_console, write_block)

console = wide_console()
err = Console(stderr=True)
ALG_LABEL = {"greedy": "GC", "markov": "MC"}


def default_step(buffer_mm: float) -> float:
    return 0.25 if buffer_mm < 3.0 else 0.1


def run_trial(alg: str, buffer_mm: float, step: float, trial: int, seed: int,
              greed: float, phobia: float, check: bool) -> dict:
    """Plan one set of targets with both resolvers. Returns one JSON-able row."""
    from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration

    key = [seed, int(round(buffer_mm * 100)), trial]
    targets = None
    row = {"alg": alg, "buffer": buffer_mm, "step": step, "trial": trial, "seed": seed}
    for resolver in ("replace", "search"):
        options = PlanOptions(algorithm=alg, step_deg=step, greed=greed, phobia=phobia,
                              resolve=resolver, raw=True)
        rc = Reconfiguration.from_names("sdss-v", "sdss-v-547", buffer_mm=buffer_mm, options=options)
        if targets is None:                      # the same targets for both resolvers
            targets = rc.random_targets(np.random.default_rng(key))
        t0 = time.perf_counter()
        plan, _ = rc.plan(targets, np.random.default_rng(key + [1]))
        wall = time.perf_counter() - t0
        m = plan.metrics
        out = {k: (float(v) if isinstance(v, (float, np.floating)) else int(v))
               for k, v in m.items() if isinstance(v, (int, float, np.integer, np.floating))}
        out["wall_s"] = wall
        out["complete"] = bool(plan.complete)
        if resolver == "search":
            out["targets_kept"] = int(np.sum(np.all(plan.targets == targets, axis=1)))
            if check:       # the raw paths, at the planning buffer
                t1 = time.perf_counter()
                _, _, rep = rc.deliver(plan)
                out["collisions"] = len(rep.collisions)
                out["min_clearance_mm"] = float(rep.min_clearance_mm)
                out["check_s"] = time.perf_counter() - t1
        row[resolver] = out
    return row


def load_rows(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    rows = []
    for line in path.read_text(encoding="utf-8").splitlines():
        line = line.strip()
        if line:
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError:
                continue          # a line cut by an interruption
    return rows


def fmt(x, nd=4):
    return "-" if x is None or not np.isfinite(x) else f"{x:.{nd}f}"


def report(rows: list[dict], cells: list[tuple[str, float, float]]) -> str:
    header = ["alg", "sigma mm", "d deg", "trials", "deadlocked robots 1st run / trial", "eff. replace",
              "eff. search", "eff. search min", "replaced / trial (replace)",
              "replaced / trial (search)", "trials with a replacement (search)",
              "groups kept by search / trial", "search failures / trial",
              "search s mean", "search s median [max]", "wall s search / replace (mean)",
              "collisions (checker)"]
    t = Table(title="Deadlock resolution on the 547-robot grid (sdss-v): search (targets kept) "
                    "vs replacement, same targets")
    for c in header:
        t.add_column(c, justify="right")
    md = []
    for alg, b, step in cells:
        rs = [r for r in rows if r["alg"] == alg and r["buffer"] == b and r["step"] == step]
        if not rs:
            continue
        rep = [r["replace"] for r in rs]
        sea = [r["search"] for r in rs]
        stuck_first = [round((1.0 - x["convergence"]) * x["n_movable"]) for x in sea]
        eff_r = np.mean([x["efficiency"] for x in rep])
        eff_s = np.array([x["efficiency"] for x in sea])
        sr = np.array([x["search_s"] for x in sea])
        coll = [x.get("collisions") for x in sea]
        n_coll = "-" if any(c is None for c in coll) else str(int(sum(coll)))
        row = [ALG_LABEL.get(alg, alg), f"{b}", f"{step}", f"{len(rs)}",
               fmt(float(np.mean(stuck_first)), 1),
               fmt(float(eff_r)), fmt(float(eff_s.mean())), fmt(float(eff_s.min())),
               fmt(float(np.mean([x["n_replaced"] for x in rep])), 2),
               fmt(float(np.mean([x["n_replaced"] for x in sea])), 2),
               f"{int(np.sum([x['n_replaced'] > 0 for x in sea]))}",
               fmt(float(np.mean([x["n_search_groups"] for x in sea])), 2),
               fmt(float(np.mean([x["n_search_failed_groups"] for x in sea])), 2),
               fmt(float(sr.mean()), 1), f"{fmt(float(np.median(sr)), 1)} [{fmt(float(sr.max()), 1)}]",
               f"{fmt(float(np.mean([x['wall_s'] for x in sea])), 1)} / "
               f"{fmt(float(np.mean([x['wall_s'] for x in rep])), 2)}",
               n_coll]
        t.add_row(*row)
        md.append(row)
    console.print(t)
    return md_table(header, md)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=100, help="trials per cell (default 100)")
    ap.add_argument("--buffers", type=float, nargs="+", default=[1.5, 2.0, 2.5, 3.0, 3.5])
    ap.add_argument("--steps", type=float, nargs="+", default=None,
                    help="step per buffer (default 0.25 deg below 3 mm, 0.1 deg from 3 mm)")
    ap.add_argument("--algorithms", nargs="+", default=["greedy"], choices=list(ALG_LABEL))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--greed", type=float, default=0.9)
    ap.add_argument("--phobia", type=float, default=0.3)
    ap.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    ap.add_argument("--raw", default="out/bench_resolve.jsonl",
                    help="JSON-lines file of finished trials (appended; resumed)")
    ap.add_argument("--md-out", default=None, help="also write the markdown block here")
    ap.add_argument("--no-check", action="store_true", help="skip the 2D checker")
    ap.add_argument("--report-only", action="store_true", help="tables from --raw only")
    ap.add_argument("--any-sources", action="store_true",
                    help="with --report-only: use trials made with other sources too")
    args = ap.parse_args(argv)
    steps = args.steps or [default_step(b) for b in args.buffers]
    if len(steps) != len(args.buffers):
        ap.error("--steps needs one value per buffer")
    cells = [(alg, b, s) for alg in args.algorithms for b, s in zip(args.buffers, steps)]
    raw = Path(args.raw)
    cmd = command_line()
    fp = source_fingerprint()[0]
    machine = machine_info()
    console.rule("rfp-twin deadlock resolution benchmark")
    console.print(f"command: {cmd}")
    console.print(f"machine (at start): {machine}")
    console.print(f"sources: models/ + planners/ sha256 {fp}")
    t_all = time.perf_counter()
    done = {(r["alg"], r["buffer"], r["step"], r["trial"]) for r in load_rows(raw)
            if r.get("seed") == args.seed and r.get("sources") == fp}
    if not args.report_only:
        todo = [(alg, b, s, t) for alg, b, s in cells for t in range(args.trials)
                if (alg, b, s, t) not in done]
        err.print(f"{len(todo)} trials to run ({len(done)} already in {raw})")
        raw.parent.mkdir(parents=True, exist_ok=True)

        def save(row: dict) -> None:
            row["sources"] = fp
            with raw.open("a", encoding="utf-8") as fh:
                fh.write(json.dumps(row) + "\n")
            s = row["search"]
            err.print(f"{ALG_LABEL[row['alg']]} {row['buffer']} mm trial {row['trial']}: eff "
                      f"search {s['efficiency']:.4f} replace {row['replace']['efficiency']:.4f}, "
                      f"search {s['search_s']:.1f} s, collisions {s.get('collisions', '-')}")

        jobs = [(alg, b, s, t, args.seed, args.greed, args.phobia, not args.no_check)
                for alg, b, s, t in todo]
        if args.workers <= 1:
            for j in jobs:
                save(run_trial(*j))
        else:
            with ProcessPoolExecutor(max_workers=args.workers) as ex:
                futs = [ex.submit(run_trial, *j) for j in jobs]
                for f in as_completed(futs):
                    save(f.result())
    rows = [r for r in load_rows(raw) if r.get("seed") == args.seed
            and (r.get("sources") == fp or (args.report_only and args.any_sources))]
    used = sorted({r.get("sources") for r in rows})
    if used != [fp]:
        console.print(f"[yellow]trials made with sources {', '.join(map(str, used))}[/]")
    table = report(rows, cells)
    md = ["<!-- bench:begin -->", f"Command: `{cmd}`", "",
          f"Machine (at start): {machine}; load average at end {load_average()}.", "",
          f"Sources: models/ + planners/ sha256 `{', '.join(map(str, used)) or fp}`. "
          f"Trials file: `{raw}`.", "", table, "",
          f"Wall time of this invocation {time.perf_counter() - t_all:.0f} s.", "<!-- bench:end -->"]
    console.rule("markdown for benchmarks/RESULTS.md")
    write_block("\n".join(md), args.md_out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
