"""Our stepwise planners against kaiju's on the same calibrated grid and targets, in one run.

For each instrument and seed: the random targets ``rfp-twin plan --preset sdss-v-production
--layout <instrument> --seed S`` draws (robots that kaiju's fiducialWatch rule forbids
there get a new target, since kaiju refuses a collided start), then the fold (10, 170)
as the destination. Path generation only, reverse (targets -> fold), step 0.1 deg, buffer
2.0 mm:

* ours: :func:`rfp_twin.planners.stepwise.mdp2_run.run_mdp2` (MDP2, greed 0.7, phobia 0.6,
  5 tries) and the greedy kernel :func:`rfp_twin.planners.stepwise.run_array` (kernel
  seconds, compiled beforehand);
* kaiju 1.4.1 (``kaiju_side.py plan`` in the side environment, one process per run, grid
  built from the same calibration CSV files, robots given the encoder angles of the
  same poses): ``pathGenMDP2(0.7, 0.6, False, 5)`` and ``pathGenGreedy`` (seconds of the
  call alone).

Reported per algorithm: seconds (median, quartiles; ratio of medians and median per-seed
ratio), fraction of robots home, steps (kaiju's count: the no-op step 0 included) and
tries, and two-sample tests of ours against kaiju's distributions (Mann-Whitney U and
Kolmogorov-Smirnov on steps and on tries, Fisher's exact test on "every robot home").

    python benchmarks/kaiju/bench_vs_kaiju.py --instruments apo --seeds 1-5 --algorithms mdp2,greedy
    python benchmarks/kaiju/bench_vs_kaiju.py --instruments apo,lco --seeds 1-50 --algorithms mdp2
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from bench_common import seed_range  # noqa: E402
from crosscheck import INSTRUMENTS, run_side  # noqa: E402

from rfp_twin.models.array import ArrayGeometry  # noqa: E402
from rfp_twin.models.files import atomic_write_text  # noqa: E402
from rfp_twin.models.instrument.layout import calibration_folder, instrument_layout  # noqa: E402
from rfp_twin.models.robot import load_spec  # noqa: E402
from rfp_twin.planners.stepwise import array_max_displacement, run_array  # noqa: E402
from rfp_twin.planners.stepwise.mdp2 import FW_C0, FW_C1, GREED, PHOBIA, TRIES  # noqa: E402
from rfp_twin.planners.stepwise.mdp2_run import (encoder_offsets, run_mdp2,  # noqa: E402
                                                 watched_robots)
from rfp_twin.planners.plan.targets import random_targets  # noqa: E402
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration  # noqa: E402

STEP_DEG = 0.1
BUFFER_MM = 2.0
FOLD = (10.0, 170.0)
#: kaiju's step limit is ceil(1000 / step) steps counting the no-op step 0.
KAIJU_STEPS = int(np.ceil(1000.0 / STEP_DEG))


def targets_for(geom: ArrayGeometry, seed: int) -> np.ndarray:
    """The pipeline's random targets for ``seed``; watched robots in kaiju's forbidden zone
    are drawn again (same generator) until they leave it."""
    rng = np.random.default_rng(seed)
    tg = Reconfiguration(geom, PlanOptions()).random_targets(rng)
    watch = watched_robots(geom)
    off = encoder_offsets(geom)
    for _ in range(100):
        bad = np.flatnonzero(watch & (tg[:, 1] - off[:, 1] < FW_C0 + FW_C1 * (tg[:, 0] - off[:, 0])))
        if bad.size == 0:
            return tg
        tg = random_targets(geom, rng, fixed=np.ones(geom.n_robots, bool), initial=tg,
                            robots=bad, margin_mm=array_max_displacement(geom, STEP_DEG))
    raise RuntimeError(f"seed {seed}: no target outside the fiducialWatch zone")


def kaiju_plan(calib: Path, geom: ArrayGeometry, targets: np.ndarray, fold: np.ndarray,
               algorithm: str, seed: int) -> dict:
    """kaiju's path generation from ``targets`` to ``fold`` (model deg) in the side env."""
    off = encoder_offsets(geom)
    enc, dest = targets - off, fold - off
    with tempfile.TemporaryDirectory() as tmp:
        poses = Path(tmp) / "poses.csv"
        rows = ["robot_id,alpha,beta,dest_alpha,dest_beta"] + [
            f"{int(r)},{float(a)!r},{float(b)!r},{float(da)!r},{float(db)!r}"
            for r, (a, b), (da, db) in zip(geom.robot_ids, enc, dest)]
        poses.write_text("\n".join(rows) + "\n")
        out = Path(tmp) / "kaiju.json"
        run_side(["plan", "--calib", str(calib), "--poses", str(poses), "--out", str(out),
                  "--algorithm", algorithm, "--seed", str(seed), "--buffer", str(BUFFER_MM),
                  "--step", str(STEP_DEG), "--greed", str(GREED), "--phobia", str(PHOBIA),
                  "--tries", str(TRIES)])
        return json.loads(out.read_text())


def ours_plan(geom: ArrayGeometry, targets: np.ndarray, fold: np.ndarray, algorithm: str,
              seed: int) -> dict:
    """Our kernel from ``targets`` to ``fold``: seconds, home, steps (kaiju's count), tries."""
    md = array_max_displacement(geom, STEP_DEG)
    movable = np.ones(geom.n_robots, dtype=bool)
    c0 = time.process_time()
    if algorithm == "mdp2":
        run = run_mdp2(geom, targets, fold, movable, step_deg=STEP_DEG,
                       max_steps=KAIJU_STEPS - 1, md=md, seed=seed)
        tries = run.tries
    else:
        run = run_array(geom, targets, fold, movable, step_deg=STEP_DEG,
                        max_steps=KAIJU_STEPS - 1, md=md, greed=1.0, phobia=0.0, seed=seed)
        tries = 1
    cpu = time.process_time() - c0
    home = np.all(run.final == fold, axis=1)
    return {"seconds": run.seconds, "cpu_s": cpu, "n_steps": int(run.n_steps) + 1,
            "tries": int(tries), "fraction_home": float(home.mean()),
            "not_home": [int(r) for r in geom.robot_ids[~home]]}


def summarize(rows: list[dict]) -> dict:
    """Medians, ratios and two-sample tests of ours against kaiju over ``rows``."""
    k_s = np.array([r["kaiju"]["seconds"] for r in rows])
    o_s = np.array([r["ours"]["seconds"] for r in rows])
    out = {"n": len(rows),
           "kaiju_s": np.percentile(k_s, [25, 50, 75]).tolist(),
           "ours_s": np.percentile(o_s, [25, 50, 75]).tolist(),
           "ratio_of_medians": float(np.median(k_s) / np.median(o_s)),
           "median_ratio": float(np.median(k_s / o_s))}
    for key in ("n_steps", "tries", "fraction_home"):
        k = np.array([r["kaiju"][key] for r in rows], dtype=float)
        o = np.array([r["ours"][key] for r in rows], dtype=float)
        entry = {"kaiju_median": float(np.median(k)), "ours_median": float(np.median(o)),
                 "kaiju_mean": float(k.mean()), "ours_mean": float(o.mean())}
        if np.ptp(np.concatenate([k, o])) > 0:
            entry["mannwhitneyu_p"] = float(stats.mannwhitneyu(o, k).pvalue)
            entry["ks_2samp_p"] = float(stats.ks_2samp(o, k).pvalue)
        out[key] = entry
    k_all = sum(r["kaiju"]["fraction_home"] == 1.0 for r in rows)
    o_all = sum(r["ours"]["fraction_home"] == 1.0 for r in rows)
    out["all_home"] = {"kaiju": int(k_all), "ours": int(o_all), "fisher_p": float(
        stats.fisher_exact([[k_all, len(rows) - k_all], [o_all, len(rows) - o_all]]).pvalue)}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--instruments", default="apo")
    ap.add_argument("--seeds", default="1-5")
    ap.add_argument("--algorithms", default="mdp2,greedy")
    ap.add_argument("--out", type=Path, default=None, help="JSON of every run and the summary")
    ap.add_argument("--summarize", type=Path, nargs="+", default=None,
                    help="only summarise the runs of earlier --out files (their seeds and "
                         "instruments pooled per instrument and algorithm)")
    args = ap.parse_args(argv)
    if args.summarize:
        runs = [r for f in args.summarize for r in json.loads(f.read_text())["runs"]]
        report({"runs": runs, "summary": {}}, sorted({r["instrument"] for r in runs}),
               sorted({r["algorithm"] for r in runs}))
        return 0
    spec = load_spec("sdss-v-production")
    result = {"command": "python benchmarks/kaiju/bench_vs_kaiju.py " + " ".join(argv or sys.argv[1:]),
              "runs": [], "summary": {}}
    for inst in args.instruments.split(","):
        name = INSTRUMENTS[inst]
        geom = ArrayGeometry(spec, instrument_layout(name), BUFFER_MM)
        calib = calibration_folder(name)
        fold = np.tile(np.asarray(FOLD, dtype=np.float64), (geom.n_robots, 1))
        warm = targets_for(geom, 0)                       # compile our kernels, untimed
        for alg in args.algorithms.split(","):
            ours_plan(geom, warm, fold, alg, 0)
        for seed in seed_range(args.seeds):
            targets = targets_for(geom, seed)
            for alg in args.algorithms.split(","):
                k = kaiju_plan(calib, geom, targets, fold, alg, seed)
                o = ours_plan(geom, targets, fold, alg, seed)
                row = {"instrument": inst, "algorithm": alg, "seed": seed, "kaiju": k, "ours": o}
                for side in ("kaiju", "ours"):
                    row[side].pop("not_home", None) if len(row[side].get("not_home", [])) > 50 else None
                result["runs"].append(row)
                print(f"{inst} {alg:>6} seed {seed:>3}: kaiju {k['seconds']:.3f} s home "
                      f"{k['fraction_home']:.3f} steps {k['n_steps']} tries {k['tries']} | ours "
                      f"{o['seconds']:.3f} s home {o['fraction_home']:.3f} steps {o['n_steps']} "
                      f"tries {o['tries']} | ratio {k['seconds'] / o['seconds']:.1f}", flush=True)
                if args.out:
                    atomic_write_text(args.out, json.dumps(result, indent=1))
    report(result, args.instruments.split(","), args.algorithms.split(","))
    if args.out:
        atomic_write_text(args.out, json.dumps(result, indent=1))
    return 0


def report(result: dict, instruments: list[str], algorithms: list[str]) -> None:
    """Summaries per instrument and algorithm into ``result["summary"]``, printed."""
    for inst in instruments:
        for alg in algorithms:
            rows = [r for r in result["runs"] if r["instrument"] == inst and r["algorithm"] == alg]
            if not rows:
                continue
            s = summarize(rows)
            result["summary"][f"{inst}-{alg}"] = s
            print(f"{inst} {alg}: {s['n']} seeds; kaiju median {s['kaiju_s'][1]:.3f} s, ours "
                  f"{s['ours_s'][1]:.4f} s: ratio of medians {s['ratio_of_medians']:.1f}x (median "
                  f"per-seed ratio {s['median_ratio']:.1f}x); all home kaiju {s['all_home']['kaiju']}"
                  f" / ours {s['all_home']['ours']} (Fisher p {s['all_home']['fisher_p']:.2f}); "
                  + "; ".join(f"{key} kaiju {s[key]['kaiju_median']:g} / ours {s[key]['ours_median']:g}"
                              + (f" (MWU p {s[key]['mannwhitneyu_p']:.2f}, KS p "
                                 f"{s[key]['ks_2samp_p']:.2f})" if "mannwhitneyu_p" in s[key] else "")
                              for key in ("n_steps", "tries")))
            cpu_k = np.median([r["kaiju"]["cpu_s"] for r in rows])
            cpu_o = np.median([r["ours"]["cpu_s"] for r in rows])
            s["cpu_ratio_of_medians"] = float(cpu_k / cpu_o)
            print(f"    CPU seconds: kaiju median {cpu_k:.3f}, ours {cpu_o:.4f}: {cpu_k / cpu_o:.1f}x")


if __name__ == "__main__":
    sys.exit(main())
