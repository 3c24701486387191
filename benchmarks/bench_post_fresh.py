#!/usr/bin/env python
"""What a fresh process adds to the post-processing (issue #13: <= 0.5 s).

Run from the repository root::

    .venv/bin/python benchmarks/bench_post_fresh.py [--seeds 1 2 3] [--buffers 2.0 2.5]
                                                     [--algorithms greedy markov] [--md-out FILE]

For each algorithm, buffer and seed, the plan of ``rfp-twin plan --preset sdss-v --buffer B
--seed S --algorithm A`` (default search resolution) is made here and handed to a fresh
Python process that imports the pipeline, then post-processes the plan twice with the
pipeline's delivery step (``Reconfiguration.deliver``: smooth, time, simplify, re-verify
with the independent 2D checker): the first call loads the post-processing's numba kernels
from the on-disk cache (a warm-up run fills it beforehand, so nothing is compiled), the
second is warm. "fresh adds" is the first minus the second. The child's import time is
reported apart (the command pays it whatever it runs). Prints a markdown table; nothing is
written outside a temporary folder (and ``--md-out``).
"""
from __future__ import annotations

import argparse
import json
import pickle
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_common import ROOT, machine_info, md_table, write_block

CHILD = """
import pickle, sys, time, json
t0 = time.perf_counter()
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
imports = time.perf_counter() - t0
algorithm, buffer_mm, plan = pickle.load(open(sys.argv[1], "rb"))
rc = Reconfiguration.from_names("sdss-v", buffer_mm=buffer_mm,
                                options=PlanOptions(algorithm=algorithm))
out = {"imports": imports}
for key in ("fresh", "warm"):
    t = time.perf_counter()
    traj, post, check = rc.deliver(plan)
    out[key] = time.perf_counter() - t
    out[key + "_ok"] = bool(check.ok)
print("RESULT " + json.dumps(out))
"""


def child(path: Path) -> dict:
    r = subprocess.run([sys.executable, "-c", CHILD, str(path)], cwd=ROOT, capture_output=True,
                       text=True)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
    if r.returncode != 0 or not lines:
        raise SystemExit(f"child failed: {(r.stderr or r.stdout).strip()[-400:]}")
    return json.loads(lines[-1][len("RESULT "):])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--buffers", type=float, nargs="+", default=[2.0, 2.5])
    ap.add_argument("--algorithms", nargs="+", default=["greedy", "markov"])
    ap.add_argument("--md-out", default=None)
    args = ap.parse_args()
    import numpy as np

    from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration

    rows, adds = [], []
    with tempfile.TemporaryDirectory() as tmp:
        first = True
        for alg in args.algorithms:
            for b in args.buffers:
                rc = Reconfiguration.from_names("sdss-v", buffer_mm=b,
                                                options=PlanOptions(algorithm=alg))
                for s in args.seeds:
                    rng = np.random.default_rng(s)
                    plan, _ = rc.plan(rc.random_targets(rng), rng)
                    path = Path(tmp) / f"{alg}_{b}_{s}.pkl"
                    path.write_bytes(pickle.dumps((alg, b, plan)))
                    if first:
                        child(path)            # fills the numba cache: nothing compiles below
                        first = False
                    r = child(path)
                    add = r["fresh"] - r["warm"]
                    adds.append(add)
                    rows.append([alg, f"{b:g}", str(s), f"{r['imports']:.2f}", f"{r['fresh']:.2f}",
                                 f"{r['warm']:.2f}", f"{add:.2f}",
                                 "yes" if r["fresh_ok"] and r["warm_ok"] else "NO"])
                    print(" | ".join(rows[-1]), flush=True)
    text = "\n".join([
        f"`.venv/bin/python benchmarks/bench_post_fresh.py` ({' '.join(sys.argv[1:]) or 'defaults'}): "
        f"{machine_info()}", "",
        md_table(["algorithm", "buffer mm", "seed", "child imports s", "post-processing fresh s",
                  "warm s", "fresh adds s", "2D check clear"], rows), "",
        f"fresh adds: median {statistics.median(adds):.2f} s, max {max(adds):.2f} s "
        "(target <= 0.5 s)."])
    write_block(text, args.md_out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
