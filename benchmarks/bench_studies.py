"""Throughput of design studies on Dask: trials per minute with 1 and 2 workers.

Runs a shipped study (default ``sim1-small``: Sayres 2021 Simulation 1, 547 robots, 9
buffers x GC/MC x 6 trials, 2D check on) from scratch on a LocalCluster of N worker
processes, once per N, each into a fresh folder, and reports trials per minute, the
speed-up, and whether every trial came out the same whatever the worker count. The last
run's report (``rfp-twin study report``) gives the efficiency trend beside the paper's
Fig. 10 numbers.

    .venv/bin/python benchmarks/bench_studies.py                      # sim1-small, 1 and 2 workers
    .venv/bin/python benchmarks/bench_studies.py --workers 2 --keep out/bench-sim1
    .venv/bin/python benchmarks/bench_studies.py --study sim3-small --trials 2

Rates exclude the cluster start-up (reported apart): ``seconds`` runs from the first
submitted task to the last written row, and includes each worker's one-off numba cache
load (a few seconds).
"""
from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_common import command_line, load_average, machine_info
from rfp_twin.twin.studies import load_study, read_results, run_study
from rfp_twin.twin.studies.report import write_report

DETERMINISTIC = ("status", "efficiency", "convergence", "fold_time_s", "n_replaced",
                 "n_deadlocked", "rounds", "n_steps", "collisions")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--study", default="sim1-small", help="shipped study name or TOML path")
    ap.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    ap.add_argument("--trials", type=int, default=None, help="trials per point (default: the study's)")
    ap.add_argument("--keep", type=Path, default=None,
                    help="keep the study folders under this folder (default: a temporary one)")
    ap.add_argument("--md-out", type=Path, default=None, help="also write the markdown block here")
    args = ap.parse_args(argv)

    study = load_study(args.study)
    counts = [int(x) for x in args.workers.split(",") if x.strip()]
    info = machine_info("numba", "dask", "distributed", "pyarrow")
    root = args.keep or Path(tempfile.mkdtemp(prefix="bench-studies-"))
    root.mkdir(parents=True, exist_ok=True)
    n_total = (args.trials or study.trials) * len(study.points)
    print(f"command: {command_line()}")
    print(f"machine: {info}")
    print(f"study {study.name}: {len(study.points)} points x {args.trials or study.trials} "
          f"trials = {n_total} trials, 2D check {'on' if study.check else 'off'}")

    runs = []
    tables = {}
    for w in counts:
        out = root / f"{study.name}-w{w}"
        if out.exists():
            shutil.rmtree(out)
        load_start = load_average()
        t0 = time.perf_counter()
        s = run_study(study, out, workers=w, processes=True, trials=args.trials, progress=True)
        wall = time.perf_counter() - t0
        table = read_results(out)
        tables[w] = table
        busy = float(np.nansum(np.array(table.column("wall_s").to_pylist(), dtype=float)))
        cpu = float(np.nansum(np.array(table.column("cpu_s").to_pylist(), dtype=float)))
        runs.append(dict(workers=w, n=s.n_run, setup=s.setup_s, seconds=s.seconds, wall=wall,
                         rate=s.rate_per_min, busy=busy, cpu=cpu, load_start=load_start,
                         load_end=load_average(), errors=s.n_errors, collisions=s.n_collisions))
        print(f"workers {w}: {s.n_run} trials in {s.seconds:.1f} s (+ {s.setup_s:.1f} s start-up)"
              f" = {s.rate_per_min:.1f} trials/min; worker busy {busy:.0f} s "
              f"({busy / max(s.seconds, 1e-9) / w:.0%} of {w} worker(s)); CPU in trials {cpu:.0f} s"
              f" = {cpu / max(s.seconds, 1e-9):.2f} cores obtained; load {load_average()}")

    # the same trials whatever the worker count
    same = "n/a (one run)"
    if len(tables) > 1:
        ref = {r["key"]: r for r in next(iter(tables.values())).to_pylist()}
        diffs = 0
        for t in list(tables.values())[1:]:
            for r in t.to_pylist():
                a = ref.get(r["key"])
                if a is None or any(a[c] != r[c] for c in DETERMINISTIC):
                    diffs += 1
        same = "yes, every trial identical" if diffs == 0 else f"NO: {diffs} trials differ"
    rep = write_report(root / f"{study.name}-w{counts[-1]}")
    base = runs[0]["rate"] if runs else 0.0

    md = [f"Command: `{command_line()}`", "",
          f"Machine (at start): {info}.", "",
          f"Study `{study.name}`: {len(study.points)} grid points x {args.trials or study.trials} "
          f"trials = {n_total} trials (547 robots, 2D check {'on' if study.check else 'off'}); "
          "LocalCluster of N single-threaded worker processes, fresh folder per run.", "",
          "| workers | trials | start-up s | run s | trials/min | speed-up | worker busy | "
          "cores obtained | trials per CPU-min | load avg start | load avg end |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in runs:
        md.append(f"| {r['workers']} | {r['n']} | {r['setup']:.1f} | {r['seconds']:.1f} | "
                  f"{r['rate']:.1f} | {r['rate'] / base if base else float('nan'):.2f}x | "
                  f"{r['busy'] / max(r['seconds'], 1e-9) / r['workers']:.0%} | "
                  f"{r['cpu'] / max(r['seconds'], 1e-9):.2f} | "
                  f"{60.0 * r['n'] / max(r['cpu'], 1e-9):.1f} | "
                  f"{r['load_start']} | {r['load_end']} |")
    md += ["", f"Same results with every worker count: {same}.", "",
           "`worker busy` = time inside trials / (run time x workers). `cores obtained` = CPU "
           "time of the worker threads inside trials / run time: what the workers actually got "
           "of the machine (other jobs share its 2 cores). `trials per CPU-min` = trials / CPU "
           "minutes in trials (load-independent cost). `trials/min` counts from the first task "
           "to the last row written, including each worker's numba cache load.",
           "", f"Report of the {counts[-1]}-worker run"
           + (f": `{rep.markdown}`" if args.keep else "") + "; trend checks: "
           + ", ".join(f"{k}: {'yes' if v else 'NO'}" for k, v in rep.trends.items()) + "."]
    text = "\n".join(md)
    print()
    print(text)
    sim1 = rep.markdown.read_text().split("## Beside Sayres 2021 Simulation 1")
    if len(sim1) > 1:
        print("\n## Beside Sayres 2021 Simulation 1" + sim1[1].split("\n## ")[0])
    trends = rep.markdown.read_text().split("## Trends vs buffer")
    if len(trends) > 1:
        print("\n## Trends vs buffer" + trends[1].split("\n## ")[0])
    if args.md_out:
        args.md_out.write_text(text + "\n", encoding="utf-8")
    if args.keep is None:
        shutil.rmtree(root, ignore_errors=True)   # pass --keep DIR to keep folders and report
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
