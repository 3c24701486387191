"""The production question, with kaiju itself: SDSS-V's trajectories against ours, same targets.

For each instrument and seed, the targets of ``bench_vs_kaiju.py`` (the random targets of
``rfp-twin plan --preset sdss-v-production --layout <instrument> --seed S``; robots that
kaiju's fiducialWatch rule forbids there drawn again) go through

* **kaiju** (``kaiju_side.py production`` in the side environment, kaiju 1.4.1, one
  process per configuration): jaeger's flow on kaiju's own grid built from the same
  calibration files: decollision robot by robot, ``pathGenMDP2(0.7, 0.6, False, 5)``,
  up to 5 retries moving a random deadlocked robot, ``getPathPair(speed=2,
  smoothPoints=21, collisionShrink=0.08, pathDelay=1)`` with epsilon 0.2 deg. Its
  ``fromDestination`` (lattice (10, 170) encoder -> targets) is what jaeger sends to
  unfold; it is read back with :func:`rfp_twin.twin.trajectory_file.read_trajectory_file`;
* **ours**: ``rfp-twin plan``'s default pipeline (greedy, deadlock resolution, firmware
  post-processing verified at buffer - budget) on the same targets.

Both trajectories are then checked the same way: the independent 2D checker under
production's rule (every robot with SDSS-V's production collision segment,
:func:`rfp_twin.models.layout.columns.production_body_layout`) at 2.0 mm and at 2.0 - 0.08
mm (jaeger's collision shrink), the buffer each kept (:mod:`rfp_twin.twin.kept_buffer`),
and the 3D distance with the estimate geometry (``sdss-v``) and, on every ``--p1-every``-th
seed, the P1 arm (``sdss-v-p1``). Reported: targets kept, the unfold's duration (kaiju's
without its 1 s path delay), smallest clearances, runs breaking the buffer, the 3D minima,
and CPU seconds of each side (kaiju: path generation + getPathPair; ours: plan + delivery).

Stages (each resumable: a configuration already done is skipped) write into ``--work``:

    python benchmarks/kaiju/bench_production_kaiju.py kaiju --instrument apo --seeds 1-50
    python benchmarks/kaiju/bench_production_kaiju.py ours  --instrument apo --seeds 1-50
    python benchmarks/kaiju/bench_production_kaiju.py report --instruments apo,lco \
        --figure benchmarks/figures/production_vs_kaiju.png

``kaiju`` needs only the side environment (KAIJU_PYTHON, default ``.venv-kaiju``) and can
run beside ``ours``; ``ours`` checks the kaiju trajectories already written too.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))
from bench_common import seed_range  # noqa: E402
from bench_vs_kaiju import targets_for  # noqa: E402
from crosscheck import INSTRUMENTS, ROOT, run_side  # noqa: E402

from rfp_twin.models.array import ArrayGeometry  # noqa: E402
from rfp_twin.models.files import atomic_write_text  # noqa: E402
from rfp_twin.models.instrument.layout import calibration_folder, instrument_layout  # noqa: E402
from rfp_twin.models.robot import load_spec  # noqa: E402
from rfp_twin.planners.stepwise.mdp2_run import encoder_offsets  # noqa: E402

BUFFER_MM = 2.0
SHRINK_MM = 0.08
PATH_DELAY_S = 1.0
#: jaeger's lattice position, encoder deg.
LATTICE = (10.0, 170.0)


def _geom(inst: str) -> ArrayGeometry:
    spec = load_spec("sdss-v-production")
    return ArrayGeometry(spec, instrument_layout(INSTRUMENTS[inst]), BUFFER_MM)


def _write_json(path: Path, data) -> None:
    atomic_write_text(path, json.dumps(data, indent=1))


def stage_kaiju(args) -> None:
    """kaiju's production flow per seed: ``WORK/<inst>-<seed>/kaiju.json`` + ``kaiju_traj.json``."""
    geom = _geom(args.instrument)
    calib = calibration_folder(INSTRUMENTS[args.instrument])
    off = encoder_offsets(geom)
    for seed in seed_range(args.seeds):
        folder = args.work / f"{args.instrument}-{seed}"
        folder.mkdir(parents=True, exist_ok=True)
        if (folder / "kaiju.json").is_file():
            continue
        enc = targets_for(geom, seed) - off
        poses = folder / "poses_encoder.csv"
        poses.write_text("\n".join(["robot_id,alpha,beta"] + [
            f"{int(r)},{float(a)!r},{float(b)!r}" for r, (a, b) in zip(geom.robot_ids, enc)]) + "\n")
        t0 = time.perf_counter()
        try:
            run_side(["production", "--calib", str(calib), "--poses", str(poses),
                      "--out", str(folder / "kaiju.json"), "--traj-out",
                      str(folder / "kaiju_traj.json"), "--seed", str(seed),
                      "--buffer", str(BUFFER_MM)])
        except RuntimeError as exc:
            _write_json(folder / "kaiju.json", {"seed": seed, "failed": str(exc)[-500:]})
        k = json.loads((folder / "kaiju.json").read_text())
        print(f"{args.instrument} seed {seed:>3}: kaiju attempts {k.get('attempts')} "
              f"decollided {len(k.get('decollided', []))} unlocked {len(k.get('unlocked', []))} "
              f"MDP2 {k.get('pathgen_s', float('nan')):.1f} s getPathPair "
              f"{k.get('pathpair_s', float('nan')):.1f} s (process {time.perf_counter() - t0:.1f} s)"
              f"{' FAILED ' + k['failed'] if k.get('failed') else ''}", flush=True)


def read_kaiju_paths(path: Path, geom: ArrayGeometry) -> tuple:
    """kaiju's ``fromDestination`` (``{id: {"alpha": [[deg, s], ...], "beta": ...}}``, encoder
    deg, times with the path delay) as a Trajectory in model angles from t = 0, and its
    excursions outside the robots' travel ranges: ``(Trajectory, n_robots_outside, largest
    excursion deg)``. :func:`rfp_twin.twin.trajectory_file.read_trajectory_file` refuses
    such a file (it names the first point outside); here the excursions are a result: the
    Savitzky-Golay smoothing overshoots a path that runs along a hard stop."""
    from rfp_twin.models.layout.columns import robot_joint_limits
    from rfp_twin.models.trajectory import Trajectory

    data = json.loads(path.read_text())
    ids = np.array(sorted(int(k) for k in data), dtype=np.int64)
    rows = geom.layout.robot_indices(ids)
    lay_off = encoder_offsets(geom)                      # geometry order = layout robot order
    limits = robot_joint_limits(geom.spec, geom.layout)
    times, angles = ([], []), ([], [])
    outside, worst = 0, 0.0
    for rid, r in zip(ids, rows):
        bad = 0.0
        for ax, name in enumerate(("alpha", "beta")):
            pts = np.asarray(data[str(rid)][name], dtype=np.float64).reshape(-1, 2)
            model = pts[:, 0] + lay_off[r, ax]
            times[ax].append(pts[:, 1] - PATH_DELAY_S)
            angles[ax].append(model)
            lo, hi = limits[r, 2 * ax], limits[r, 2 * ax + 1]
            bad = max(bad, float(np.max(np.maximum(lo - model, model - hi))))
        if bad > 0.0:
            outside += 1
            worst = max(worst, bad)
    traj = Trajectory.from_breakpoints(ids, times[0], angles[0], times[1], angles[1])
    return traj, outside, worst


def measure(traj, geom: ArrayGeometry, production, links: dict, with_p1: bool) -> dict:
    """The checks every trajectory gets (module docstring)."""
    from rfp_twin.twin.kept_buffer import kept_buffer
    from rfp_twin.validation.checker2d import check_trajectory
    from rfp_twin.validation.mesh3d import validate_trajectory

    spec = geom.spec
    out = {}
    t0 = time.process_time()
    at_b = check_trajectory(traj, spec, production, BUFFER_MM)
    at_s = check_trajectory(traj, spec, production, BUFFER_MM - SHRINK_MM)
    kept = kept_buffer(traj, spec, production, at_b)
    out.update(clearance_mm=float(at_b.min_clearance_mm),
               clearance_shrunk_mm=float(at_s.min_clearance_mm),
               breaks_buffer=not at_b.ok, breaks_shrunk=not at_s.ok,
               n_pairs_inside_buffer=len(at_b.collisions),
               n_pairs_inside_shrunk=len(at_s.collisions),
               kept_buffer_mm=float(kept.buffer_mm), kept_robot_mm=float(kept.robot_mm),
               kept_obstacle_mm=float(kept.obstacle_mm),
               kept_pair=list(kept.robot_pair or ()), check2d_cpu_s=time.process_time() - t0)
    for name, model in links.items():
        if name == "sdss-v-p1" and not with_p1:
            continue
        t0 = time.process_time()
        rep = validate_trajectory(traj, spec, geom.layout, model)
        out[f"min_3d_mm[{name}]"] = float(rep.min_distance_mm)
        out[f"n_3d_collisions[{name}]"] = len(rep.collisions)
        kinds = {}
        for pd in rep.pairs:
            kinds[pd.kind] = min(kinds.get(pd.kind, np.inf), pd.min_distance_mm)
        out[f"min_3d_by_pair_kind_mm[{name}]"] = {k: float(v) for k, v in kinds.items()}
        out[f"min_3d_by_link_kind_mm[{name}]"] = {k: float(v) for k, v in
                                                  rep.link_kind_min_mm.items()
                                                  if np.isfinite(v)}
        out[f"check3d_cpu_s[{name}]"] = time.process_time() - t0
    return out


def stage_ours(args) -> None:
    """Our pipeline on the same targets, and the checks of both sides' trajectories:
    ``WORK/<inst>-<seed>/ours.json`` and ``kaiju_check.json``."""
    from rfp_twin.models.geometry import load_geometry
    from rfp_twin.models.layout.columns import production_body_layout
    from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
    from rfp_twin.validation.mesh3d import LinkModels

    geom = _geom(args.instrument)
    spec = geom.spec
    production = production_body_layout(geom.layout)
    links = {"sdss-v": LinkModels.from_geometry(load_geometry("sdss-v", spec)),
             "sdss-v-p1": LinkModels.from_geometry(load_geometry("sdss-v-p1", spec))}
    rc = Reconfiguration(geom, PlanOptions())
    rc.run(seed=0, targets=targets_for(geom, 0))          # compile, untimed
    for seed in seed_range(args.seeds):
        folder = args.work / f"{args.instrument}-{seed}"
        folder.mkdir(parents=True, exist_ok=True)
        with_p1 = (seed - 1) % args.p1_every == 0
        if args.with_kaiju_only and not (folder / "kaiju.json").is_file():
            continue
        if not (folder / "ours.json").is_file():
            targets = targets_for(geom, seed)
            c0, t0 = time.process_time(), time.perf_counter()
            outcome = rc.run(seed=seed, targets=targets)
            cpu, wall = time.process_time() - c0, time.perf_counter() - t0
            traj = outcome.trajectory
            # the plan runs fold -> targets: a target is kept when the robot ends on it
            on_target = np.all(np.abs(outcome.plan.end() - targets) < 1e-6, axis=1)
            r = {"seed": seed, "kept": int(on_target.sum()),
                 "statuses": {str(k): int(v) for k, v in
                              zip(*np.unique(outcome.plan.status, return_counts=True))},
                 "duration_s": float(traj.duration), "cpu_s": cpu, "wall_s": wall,
                 "seconds": {k: float(v) for k, v in outcome.seconds.items()},
                 "verified_ok": bool(outcome.check.ok)}
            r.update(measure(traj, geom, production, links, with_p1))
            _write_json(folder / "ours.json", r)
        kj = folder / "kaiju.json"
        if kj.is_file() and not (folder / "kaiju_check.json").is_file():
            k = json.loads(kj.read_text())
            if k.get("traj"):
                # kaiju's times include the path delay: the motion is measured from t = 0
                shifted, n_out, worst = read_kaiju_paths(folder / "kaiju_traj.json", geom)
                moved = set(k["decollided"]) | set(k["unlocked"])
                r = {"seed": seed, "kept": geom.n_robots - len(moved), "n_moved_off": len(moved),
                     "duration_s": float(shifted.duration), "attempts": k["attempts"],
                     "cpu_s": k["pathgen_cpu_s"] + k["pathpair_cpu_s"],
                     "pathgen_cpu_s": k["pathgen_cpu_s"], "pathpair_cpu_s": k["pathpair_cpu_s"],
                     "steps": k["steps"], "tries": k["tries"],
                     "n_robots_outside_range": n_out, "largest_range_excursion_deg": worst}
                r.update(measure(shifted, geom, production, links, with_p1))
            else:
                r = {"seed": seed, "failed": k.get("failed"), "kept": 0}
            _write_json(folder / "kaiju_check.json", r)
        o = json.loads((folder / "ours.json").read_text())
        line = (f"{args.instrument} seed {seed:>3}: ours kept {o['kept']} clear "
                f"{o['clearance_mm']:.3f} mm kept-buffer {o['kept_buffer_mm']:.3f} "
                f"3D {o['min_3d_mm[sdss-v]']:.3f} mm {o['duration_s']:.1f} s")
        if (folder / "kaiju_check.json").is_file():
            k = json.loads((folder / "kaiju_check.json").read_text())
            if "clearance_mm" in k:
                line += (f" | kaiju kept {k['kept']} clear {k['clearance_mm']:.3f} kept-buffer "
                         f"{k['kept_buffer_mm']:.3f} 3D {k['min_3d_mm[sdss-v]']:.3f} "
                         f"{k['duration_s']:.1f} s")
        print(line, flush=True)


def _load(work: Path, inst: str) -> list[tuple[dict, dict]]:
    """(ours, kaiju) result pairs of an instrument, seeds where both exist."""
    rows = []
    for folder in sorted(work.glob(f"{inst}-*"), key=lambda p: int(p.name.rsplit("-", 1)[1])):
        o, k = folder / "ours.json", folder / "kaiju_check.json"
        if o.is_file() and k.is_file():
            rows.append((json.loads(o.read_text()), json.loads(k.read_text())))
    return rows


def _q(values, fmt: str = "{:.2f}") -> str:
    v = np.asarray([x for x in values if x is not None and np.isfinite(x)], dtype=float)
    if v.size == 0:
        return "-"
    return f"{fmt.format(np.median(v))} ({fmt.format(v.min())}-{fmt.format(v.max())})"


def beta_beta(r: dict, geometry: str) -> float:
    """Smallest 3D beta-beta distance of a result, mm (the alpha-beta minimum, 0.5 mm, is
    the geometry's static vertical gap of a ferrule over a neighbour's alpha arm)."""
    return r.get(f"min_3d_by_link_kind_mm[{geometry}]", {}).get("beta-beta", float("nan"))


def stage_report(args) -> None:
    """Markdown table per instrument and side, and the figure."""
    from bench_common import md_table

    table, data = [], {}
    for inst in args.instruments.split(","):
        pairs = _load(args.work, inst)
        if not pairs:
            continue
        data[inst] = pairs
        for side, rs in (("ours", [p[0] for p in pairs]), ("kaiju", [p[1] for p in pairs])):
            ok = [r for r in rs if "clearance_mm" in r]
            p1 = [r["n_3d_collisions[sdss-v-p1]"] for r in ok if "n_3d_collisions[sdss-v-p1]" in r]
            table.append([
                inst, side, str(len(rs)), str(len(rs) - len(ok)),
                _q([r["kept"] for r in rs], "{:.0f}"),
                _q([r["duration_s"] for r in ok], "{:.1f}"),
                _q([r["clearance_mm"] for r in ok], "{:.3f}"),
                f"{sum(r['breaks_buffer'] for r in ok)} / "
                f"{sum(r['kept_buffer_mm'] < BUFFER_MM - 0.03 for r in ok)} / "
                f"{sum(r['breaks_shrunk'] for r in ok)}",
                _q([r["kept_buffer_mm"] for r in ok], "{:.3f}"),
                _q([beta_beta(r, "sdss-v") for r in ok], "{:.3f}"),
                f"{_q(p1, '{:.0f}')} [{len(p1)}]" if p1 else "-",
                str(sum(r.get("n_robots_outside_range", 0) > 0 for r in ok)) if side == "kaiju"
                else "0",
                _q([r["cpu_s"] for r in ok], "{:.1f}")])
        k_cpu = np.median([p[1]["cpu_s"] for p in pairs if "cpu_s" in p[1]])
        o_cpu = np.median([p[0]["cpu_s"] for p in pairs])
        table.append([inst, "kaiju / ours CPU", "", "", "", "", "", "", "", "", "", "",
                      f"{k_cpu / o_cpu:.1f}x"])
    header = ["instrument", "side", "seeds", "failed", "targets kept", "unfold s",
              "min 2D clearance, production rule, mm",
              "runs inside 2.0 / 1.97 / 1.92 mm", "buffer kept mm",
              "min 3D beta-beta mm (sdss-v)", "3D contacts (P1) [runs]",
              "runs leaving the travel range",
              "CPU s (kaiju: MDP2 + getPathPair; ours: plan + delivery)"]
    print(md_table(header, table))
    if args.figure:
        figure(data, Path(args.figure))


def figure(data: dict, path: Path) -> None:
    """Per instrument: CDFs over the configurations of the smallest distance between two
    robots' beta segments under the production rule (mm; keep-out 4.0 mm, shrunk 3.84 mm)
    and of the smallest 3D beta-beta distance (estimate geometry), ours vs kaiju."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    insts = list(data)
    fig, axes = plt.subplots(2, len(insts), figsize=(6.2 * len(insts), 8.0), squeeze=False)
    names = {"apo": "APO (sloanFlatCMM)", "lco": "LCO (duPontFlatCMM)"}
    for col, inst in enumerate(insts):
        pairs = data[inst]
        for row, (key, label, lines) in enumerate((
                ("robot", "smallest distance between two robots' beta segments,\n"
                 "production rule, after smoothing (mm)",
                 ((2 * BUFFER_MM, "keep-out 2 x 2.0 mm = 4.0 mm", "k", "-"),
                  (2 * (BUFFER_MM - 0.03), "ours verified at 2 x 1.97 = 3.94 mm", "tab:blue", "--"),
                  (2 * (BUFFER_MM - SHRINK_MM), "jaeger's shrunk keep-out 2 x 1.92 = 3.84 mm",
                   "0.4", ":"))),
                ("beta-beta", "smallest 3D distance between two beta arms,\n"
                 "estimate geometry sdss-v (mm)", ()))):
            ax = axes[row, col]
            for side, idx, colour in (("ours (rfp-twin plan)", 0, "tab:blue"),
                                      ("kaiju MDP2 + getPathPair", 1, "tab:red")):
                # robot pairs: 2 x the kept buffer is their smallest segment distance
                v = np.sort([2.0 * p[idx]["kept_robot_mm"] if row == 0 else
                             beta_beta(p[idx], "sdss-v") for p in pairs if "clearance_mm" in p[idx]])
                if v.size:
                    ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", color=colour,
                            label=f"{side}, {v.size} seeds")
            for x, lab, c, ls in lines:
                ax.axvline(x, color=c, ls=ls, lw=1.2, label=lab)
            ax.set_xlabel(label)
            ax.set_ylabel("fraction of configurations")
            ax.set_title(f"{names.get(inst, inst)}, buffer 2.0 mm")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(dir=path.parent, suffix=".png", delete=False) as fh:
        fig.savefig(fh.name, dpi=110)
    Path(fh.name).replace(path)
    print(f"wrote {path}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("stage", choices=("kaiju", "ours", "report"))
    ap.add_argument("--instrument", default="apo", choices=sorted(INSTRUMENTS))
    ap.add_argument("--instruments", default="apo,lco")
    ap.add_argument("--seeds", default="1-50")
    ap.add_argument("--p1-every", type=int, default=5, help="the P1 3D check on seeds 1, 1 + "
                    "k, 1 + 2k, ...")
    ap.add_argument("--with-kaiju-only", action="store_true",
                    help="ours: only the seeds whose kaiju run is already written")
    ap.add_argument("--work", type=Path, default=ROOT / "out" / "production-kaiju")
    ap.add_argument("--figure", default=None)
    args = ap.parse_args(argv)
    {"kaiju": stage_kaiju, "ours": stage_ours, "report": stage_report}[args.stage](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
