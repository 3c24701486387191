"""Replay of an instrument's trajectory file through `rfp-twin validate` (2D + 3D), timed whole.

Plans one fold on the calibrated APO instrument (``rfp-twin plan --preset sdss-v-production
--layout sdss-v-apo``), takes the run's ``trajectories_encoder.json`` (what the robots'
firmware is sent: the form of a jaeger trajectory file) and times, as a user runs it,

    /usr/bin/time -v rfp-twin validate FILE --layout sdss-v-apo [--geometry G]

for each geometry asked (default: the preset's estimate arm, and the P1 prototype arm), after
one warm-up run (numba caches). Prints one markdown row per geometry: wall and CPU seconds
(each repeat), peak memory, the 2D clearance, the kept buffer, the 3D minimum, collisions, and the
3D check's own split (broadphase, FCL calls).

Targets (issue 29): <= 3 s with the default geometry, <= 30 s with ``--geometry sdss-v-p1``.

Usage (from the repository root)::

    .venv/bin/python benchmarks/bench_replay.py [--seed 1] [--repeat 3] [--run DIR]
        [--geometries default sdss-v-p1]
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_common import ROOT, load_average, now

RFP = [sys.executable, "-m", "rfp_twin.twin.cli"]


def timed(args: list[str]) -> tuple[float, float, float, int]:
    """Run ``rfp-twin ARGS`` under ``/usr/bin/time -v``: (wall s, CPU s = user + system,
    peak MB, exit code). On a shared machine the CPU seconds move less than the wall."""
    proc = subprocess.run(["/usr/bin/time", "-v", *RFP, *args], capture_output=True, text=True,
                          cwd=ROOT)
    wall = re.search(r"Elapsed \(wall clock\) time.*: (?:(\d+):)?(\d+):([\d.]+)", proc.stderr)
    h, m, s = (float(g) if g else 0.0 for g in wall.groups())
    cpu = sum(float(re.search(rf"{k} time \(seconds\): ([\d.]+)", proc.stderr).group(1))
              for k in ("User", "System"))
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr)
    return 3600 * h + 60 * m + s, cpu, int(rss.group(1)) / 1024, proc.returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--run", type=Path, help="an existing APO run folder (skip planning)")
    ap.add_argument("--geometries", nargs="+", default=["default", "sdss-v-p1"])
    opt = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="bench_replay."))
    run = opt.run
    if run is None:
        run = work / "apo"
        subprocess.run([*RFP, "plan", "--preset", "sdss-v-production", "--layout", "sdss-v-apo",
                        "--seed", str(opt.seed), "--out", str(run)], check=True, cwd=ROOT,
                       capture_output=True)
    traj = run / "trajectories_encoder.json"
    n_robots = len(json.loads(traj.read_text()))
    print(f"# replay of a {n_robots}-robot trajectory file, {now()}, load {load_average()}\n")
    print("| geometry | wall s (each run) | CPU s (each run) | peak MB | 2D min clearance mm | kept buffer mm | "
          "3D min mm | 3D collisions | broadphase / exact s | FCL calls | command |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for geom in opt.geometries:
        report = work / f"{geom}.json"
        args = ["validate", str(traj), "--layout", "sdss-v-apo", "--out", str(report)]
        if geom != "default":
            args += ["--geometry", geom]
        timed(args)                                        # warm-up: numba caches
        walls, cpus, peak, code = [], [], 0.0, 0
        for _ in range(opt.repeat):
            w, cpu, mb, code = timed(args)
            walls.append(w)
            cpus.append(cpu)
            peak = max(peak, mb)
        d = json.loads(report.read_text())
        print(f"| {geom} | {' / '.join(f'{w:.2f}' for w in walls)} | "
              f"{' / '.join(f'{c:.2f}' for c in cpus)} | {peak:.0f} | "
              f"{d['check2d']['min_clearance_mm']:.4f} | {d['kept_buffer']['buffer_mm']:.4f} | "
              f"{d['min_distance_mm']:.4f} | {d['n_collisions']} (exit {code}) | "
              f"{d['seconds_broadphase']:.2f} / {d['seconds_exact']:.2f} | {d['n_fcl_calls']} | "
              f"`/usr/bin/time -v rfp-twin {' '.join(a if a != str(traj) else 'FILE' for a in args if a != str(report) and a != '--out')}` |")


if __name__ == "__main__":
    main()
