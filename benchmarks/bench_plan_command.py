#!/usr/bin/env python
"""The whole ``rfp-twin plan`` command, as a user waits for it (issue #13).

Run from the repository root::

    .venv/bin/python benchmarks/bench_plan_command.py [--seeds 1 2 3] [--buffers 2.0 2.5]
                                                      [--repeat 3] [--preset sdss-v]
                                                      [--command ".venv/bin/rfp-twin" ...]
                                                      [--md-out FILE]

For each buffer and seed: ``COMMAND plan --preset PRESET --buffer B --seed S --out DIR
--force`` in a fresh process, ``--repeat`` times after one warm-up run of the first seed
(the warm-up fills the numba cache, so the figures are warm: kernels loaded from the
on-disk cache, never compiled). ``--command`` may be given several times (e.g. the code
before and after a change): the commands then run in turn, case by case, so that they
share the machine's load. Per case it reports the median wall seconds (process start to
exit, measured here), the median CPU seconds (user + system of the child: less sensitive
to other processes' load than the wall), the peak RSS (the child's ``ru_maxrss``) and the
median stage split read from the run folder's ``summary.json``:

- ``imports``: the pipeline's imports inside the command (numpy, numba, scipy.spatial, ...)
- ``setup``: spec, layout, the array's geometry
- ``targets``, ``plan`` (stepwise planner + deadlock search), ``deliver`` (post-processing
  with its 2D checks): ``Reconfiguration.run``; the first kernel calls of each stage load
  the numba kernels from the cache
- ``search``, ``post``, ``verify``: parts of ``plan`` and ``deliver`` (``metrics.search_s``,
  ``postprocess.stage_seconds.total`` / ``.verify``)
- ``outside``: wall - ``wall_time_s`` (the command's own clock, spec to summary):
  interpreter start-up, the command line's imports (typer, rich), option parsing, the
  pipeline's imports (``imports``, also shown alone), writing the run folder, the table,
  exit. Older code without ``stage_wall_s`` shows NaN for those stages only.

Prints a markdown table to paste into benchmarks/RESULTS.md by hand; ``--md-out`` also
writes it to a file. Nothing else is written outside a temporary folder.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_common import ROOT, load_average, machine_info, md_table, write_block

#: Stage columns: (column, path in summary.json).
STAGES = (("imports", ("stage_wall_s", "imports")), ("setup", ("stage_wall_s", "setup")),
          ("targets", ("stage_wall_s", "targets")), ("plan", ("stage_wall_s", "plan")),
          ("search", ("metrics", "search_s")), ("deliver", ("stage_wall_s", "deliver")),
          ("post", ("postprocess", "stage_seconds", "total")),
          ("verify", ("postprocess", "stage_seconds", "verify")))


#: ``--algorithm`` of the runs (set by main).
ALGORITHM = ["greedy"]


def run_once(command: list[str], preset: str, buffer_mm: float, seed: int,
             out: Path) -> tuple[float, float, int, dict]:
    """One run in a fresh process: (wall s, CPU s, peak RSS MiB, summary.json as a dict)."""
    args = [*command, "plan", "--preset", preset, "--buffer", f"{buffer_mm:g}", "--seed",
            str(seed), "--algorithm", ALGORITHM[0], "--out", str(out), "--force"]
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            err.seek(0)
            raise SystemExit(f"{' '.join(args)} exited {proc.returncode}: "
                             f"{err.read().decode(errors='replace').strip()[-400:]}")
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss // 1024, summary


def field(summary: dict, path: tuple[str, ...]) -> float:
    """A number deep in ``summary`` (NaN when a level is missing: older code, raw runs)."""
    v = summary
    for k in path:
        if not isinstance(v, dict) or k not in v:
            return float("nan")
        v = v[k]
    return float(v)


def measure(commands: list[list[str]], preset: str, buffer_mm: float, seed: int, repeat: int,
            out: Path) -> list[dict]:
    """Per command: median wall and CPU, max peak RSS, median stages and the mean load of
    ``repeat`` runs (the commands run in turn)."""
    runs = [{"walls": [], "cpus": [], "rss": [], "outside": [], "loads": [],
             "stages": {name: [] for name, _ in STAGES}} for _ in commands]
    for _ in range(repeat):
        for command, r in zip(commands, runs):
            r["loads"].append(os.getloadavg()[0])
            wall, cpu, peak, s = run_once(command, preset, buffer_mm, seed, out)
            r["walls"].append(wall)
            r["cpus"].append(cpu)
            r["rss"].append(peak)
            r["outside"].append(wall - field(s, ("wall_time_s",)))
            for name, path in STAGES:
                r["stages"][name].append(field(s, path))
    return [{"wall": statistics.median(r["walls"]), "walls": r["walls"],
             "cpu": statistics.median(r["cpus"]), "rss": max(r["rss"]),
             "outside": statistics.median(r["outside"]), "load": statistics.mean(r["loads"]),
             "stages": {k: statistics.median(v) for k, v in r["stages"].items()}} for r in runs]


def row(buffer_mm: float, seed: int, r: dict) -> list[str]:
    return [f"{buffer_mm:.1f}", str(seed), f"{r['wall']:.2f}",
            " / ".join(f"{w:.2f}" for w in r["walls"]), f"{r['cpu']:.2f}", f"{r['rss']}",
            f"{r['outside']:.2f}", *(f"{r['stages'][name]:.2f}" for name, _ in STAGES),
            f"{r['load']:.2f}"]


HEADER = ["buffer mm", "seed", "wall s (median)", "walls s", "CPU s", "peak RSS MiB", "outside",
          *(name for name, _ in STAGES), "load (1 min)"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--buffers", type=float, nargs="+", default=[2.0, 2.5])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--preset", default="sdss-v")
    ap.add_argument("--algorithm", default="greedy", choices=["greedy", "markov"])
    ap.add_argument("--command", action="append", default=None,
                    help="The command to time (split on spaces), from the repository root "
                         "[default: .venv/bin/rfp-twin]; repeat to compare commands.")
    ap.add_argument("--md-out", default=None)
    a = ap.parse_args()
    ALGORITHM[0] = a.algorithm
    commands = [c.split() for c in (a.command or [".venv/bin/rfp-twin"])]
    print(machine_info("numba", "scipy"), file=sys.stderr)
    rows: list[list[list[str]]] = [[] for _ in commands]
    walls: list[list[float]] = [[] for _ in commands]
    with tempfile.TemporaryDirectory(prefix="bench_plan_command.") as tmp:
        out = Path(tmp) / "run"
        for command in commands:   # warm-up: fills the numba cache
            run_once(command, a.preset, a.buffers[0], a.seeds[0], out)
        for b in a.buffers:
            for seed in a.seeds:
                for k, r in enumerate(measure(commands, a.preset, b, seed, a.repeat, out)):
                    rows[k].append(row(b, seed, r))
                    walls[k].append(r["wall"])
                    print(f"[{' '.join(commands[k])}] " + " | ".join(rows[k][-1]), file=sys.stderr)
    blocks = [f"### `rfp-twin plan --preset {a.preset} --algorithm {a.algorithm}` (whole command, "
              "warm numba cache)\n\n"
              f"{machine_info('numba', 'scipy')}\n\n{a.repeat} runs per case after one warm-up"
              + (", the commands in turn" if len(commands) > 1 else "")
              + "; stages: medians from summary.json (s)."]
    for command, rs, ws in zip(commands, rows, walls):
        blocks.append(f"`{' '.join(command)} plan --preset {a.preset} --algorithm {a.algorithm} "
                      "--buffer B --seed S --out "
                      f"DIR --force`\n\n" + md_table(HEADER, rs)
                      + f"\n\nMedian over the cases: {statistics.median(ws):.2f} s (issue #13: "
                      "<= 2 s a buffer of 1.5-2.5 mm, <= 5 s at 3.0-3.5 mm, median of 5 seeds "
                      "per buffer).")
    blocks.append(f"Load at the end: {load_average()}.")
    write_block("\n\n".join(blocks), a.md_out)


if __name__ == "__main__":
    main()
