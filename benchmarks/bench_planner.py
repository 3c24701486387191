#!/usr/bin/env python
"""Planner benchmarks: Sayres 2021 Table 3, and the kaiju anchor (SDSS-V production).

Run from the repository root (``make bench`` runs the defaults)::

    .venv/bin/python benchmarks/bench_planner.py [--trials N] [--only table3|kaiju|all]
                                                 [--seed S] [--kaiju-trials M]
                                                 [--buffers 2.0 ...] [--md-out FILE]

Sections
--------
1. ``table3``: the six rows of Sayres 2021 Table 3 (GC / MC at (1.5 mm, 1.0 deg),
   (2.5 mm, 0.25 deg), (3.5 mm, 0.10 deg)) on the paper's 547 all-robot grid with preset
   ``sdss-v`` (beta collision segment 0-15 mm), reverse planning with deadlock
   resolution, MC greed 0.9 / phobia 0.3. Means over N trials of tau_pg, tau_sr, fold
   time and efficiency (Eq. 11), next to the paper's row. The paper's times are kaiju
   0.5.0 on one thread of a 2.9 GHz i9.
2. ``kaiju``: the real 500-robot SDSS-V layout (60 fiducials as obstacles), preset
   ``sdss-v-production`` (segment end by the production rule at each buffer), step
   0.1 deg, buffers 1.5-3.5 mm, greedy and markov, FIRST run only (no target
   replacement, as kaiju's "all 500 home"), next to the SDSS-V kaiju 1.4.1 anchor
   figures, measured on this machine kind (benchmarks/RESULTS.md). We have no MDP2: our
   markov is compared with kaiju's MDP and MDP2 rows, labelled as such. Then the
   issue's speed targets: path generation at 2.0 mm <= 0.1 s (greedy) and <= 0.3 s
   (markov), median over trials after one warm-up call (numba compilation / cache load
   excluded).
3. kaiju itself, if importable, on the same targets; otherwise one line says the anchor's
   measured figures are used.

Plans come from the pipeline's planning step, :meth:`rfp_twin.twin.pipeline.Reconfiguration.plan`
(targets drawn by ``Reconfiguration.random_targets`` with the planner's margin, the step
rule's MD). Timings: ``tau_pg`` is the planner kernel's own time
(Plan.metrics["tau_pg_s"]); ``call`` is the wall time of the whole planning step with
``resolve="none"`` (target checks, kernel, path building, reversal): what a user waits
for, and the fairer match for kaiju's ``pathGen*`` calls (they also record paths).
Ratios kaiju / ours use ``call``.

Prints rich tables, then a markdown block (between ``<!-- bench:begin -->`` and
``<!-- bench:end -->``) to paste into benchmarks/RESULTS.md.
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from rfp_twin.twin.studies.paper import PAPER_TABLE3
from bench_common import (command_line, load_average, machine_info, md_table, source_fingerprint,
                          wide_console, write_block)
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration

console = wide_console()
err = Console(stderr=True)

# --- reference figures ------------------------------------------------------------
#: Sayres 2021 Table 3 (547 robots, kaiju 0.5.0, one thread of a 2.9 GHz i9):
#: (alg, sigma mm, step deg) -> (tau_pg s, tau_sr s, fold time s, efficiency)
TABLE3_ROWS = [("greedy", 1.5, 1.00), ("greedy", 2.5, 0.25), ("greedy", 3.5, 0.10),
               ("markov", 1.5, 1.00), ("markov", 2.5, 0.25), ("markov", 3.5, 0.10)]

#: SDSS-V kaiju 1.4.1 anchor figures, measured on this machine kind (benchmarks/RESULTS.md):
#: 500-robot SDSS-V grid, step 0.1 deg, reverse to (10, 170);
#: buffer -> (all 500 home "k/n", median fraction home, median path generation s)
KAIJU_GREEDY = {1.5: ("2/5", 0.996, 15.8), 2.0: ("1/5", 0.992, 14.9), 2.5: ("2/5", 0.988, 15.7),
                3.0: ("0/5", 0.984, 18.0), 3.5: ("0/5", 0.956, 18.4)}
KAIJU_MDP2 = {1.5: ("3/3", 1.000, 8.1), 2.0: ("3/3", 1.000, 8.9), 2.5: ("3/3", 1.000, 9.4),
              3.0: ("2/3", 1.000, 10.5), 3.5: ("0/3", 0.882, 141.8)}
KAIJU_MDP = {2.5: ("1/2", 0.999, 45.4)}  # greed 0.8, phobia 0.2

#: Speed targets of the planner issue, path generation at 2.0 mm on the 500-robot grid.
SPEED_TARGET_S = {"greedy": 0.1, "markov": 0.3}
ALG_LABEL = {"greedy": "GC", "markov": "MC"}


# --- helpers ------------------------------------------------------------------------
def warm_up(algorithms) -> None:
    """Load / compile the numba kernels once, on a tiny grid, so no timing includes it."""
    spec = load_spec("sdss-v")
    rng = np.random.default_rng(0)
    targets = None
    for alg in algorithms:
        rc = Reconfiguration.from_names(spec, Layout.hex_grid(2, spec.pitch_mm),
                                        options=PlanOptions(algorithm=alg, step_deg=1.0,
                                                            max_steps=200))
        targets = rc.random_targets(rng) if targets is None else targets
        rc.plan(targets, rng)


def fmt(x: float, nd: int = 2) -> str:
    return "-" if x is None or not np.isfinite(x) else f"{x:.{nd}f}"


def fmt_t(x: float) -> str:
    """A time in s with sensible precision."""
    if x is None or not np.isfinite(x):
        return "-"
    return f"{x:.3f}" if x < 10 else f"{x:.1f}"


def med_range(v) -> str:
    v = np.asarray(v, dtype=float)
    if v.size == 0:
        return "-"
    if v.size == 1:
        return fmt_t(v[0])
    return f"{fmt_t(np.median(v))} [{fmt_t(v.min())}-{fmt_t(v.max())}]"


def progress_bar() -> Progress:
    return Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), console=err, transient=True)


# --- section 1: Table 3 ---------------------------------------------------------------
@dataclass
class Table3Row:
    alg: str
    sigma: float
    step: float
    tau_pg: list = field(default_factory=list)
    tau_sr: list = field(default_factory=list)
    fold: list = field(default_factory=list)
    eff: list = field(default_factory=list)
    conv: list = field(default_factory=list)
    rounds: list = field(default_factory=list)
    unresolved: int = 0
    failed: int = 0

    @property
    def n(self) -> int:
        return len(self.eff)


def run_table3(trials: int, seed: int, greed: float, phobia: float) -> list[Table3Row]:
    spec = load_spec("sdss-v")
    layout = Layout.sdss_v_grid(pitch_mm=spec.pitch_mm)
    rows = []
    with progress_bar() as prog:
        for ri, (alg, sigma, step) in enumerate(TABLE3_ROWS):
            row = Table3Row(alg, sigma, step)
            task = prog.add_task(f"Table 3 {ALG_LABEL[alg]} {sigma} mm {step} deg", total=trials)
            rc = Reconfiguration.from_names(spec, layout, buffer_mm=sigma, options=PlanOptions(
                algorithm=alg, step_deg=step, greed=greed, phobia=phobia,
                resolve="replace"))  # the paper's Sect. 5.2
            for t in range(trials):
                # the same targets for GC and MC rows of one (sigma, step)
                tg = rc.random_targets(np.random.default_rng([seed, 1, ri % 3, t]))
                rng = np.random.default_rng([seed, 1, ri, t, 1])
                try:
                    m = rc.plan(tg, rng)[0].metrics
                except Exception as exc:  # noqa: BLE001 (report, keep going)
                    row.failed += 1
                    err.print(f"[red]trial {t} of {alg} {sigma} mm failed:[/] {exc}")
                    prog.advance(task)
                    continue
                row.tau_pg.append(m["tau_pg_s"])
                row.tau_sr.append(m["tau_sr_s"])
                row.fold.append(m["fold_time_s"])
                row.eff.append(m["efficiency"])
                row.conv.append(m["convergence"])
                row.rounds.append(m["rounds"])
                row.unresolved += int(m["n_deadlocked"] > 0)
                prog.advance(task)
            rows.append(row)
    return rows


def report_table3(rows: list[Table3Row], greed: float, phobia: float) -> str:
    t = Table(title="Sayres 2021 Table 3: 547 robots, preset sdss-v (segment 0-15 mm), "
                    f"reverse + deadlock resolution, MC greed {greed} / phobia {phobia}; "
                    "means over trials (paper in brackets; paper tau on a 2.9 GHz i9, 1 thread)")
    for c in ("alg", "sigma mm", "d deg", "trials", "tau_pg s", "tau_sr s", "fold s",
              "efficiency", "eff. min", "conv. 1st run", "rounds", "unresolved"):
        t.add_column(c, justify="right")
    md_rows = []
    for r in rows:
        p = PAPER_TABLE3[(r.alg, r.sigma, r.step)]
        mean = (lambda v: float(np.mean(v)) if v else float("nan"))
        cells = [ALG_LABEL[r.alg], f"{r.sigma}", f"{r.step:.2f}", f"{r.n}" + (f" ({r.failed} failed)" if r.failed else ""),
                 f"{fmt(mean(r.tau_pg), 3)} ({p[0]:.2f})", f"{fmt(mean(r.tau_sr), 3)} ({p[1]:.2f})",
                 f"{fmt(mean(r.fold))} ({p[2]:.2f})", f"{fmt(mean(r.eff), 4)} ({p[3]:.4f})",
                 fmt(min(r.eff) if r.eff else float("nan"), 4), fmt(mean(r.conv), 4),
                 fmt(mean(r.rounds), 1), f"{r.unresolved}"]
        t.add_row(*cells)
        md_rows.append([ALG_LABEL[r.alg], f"{r.sigma}", f"{r.step:.2f}", f"{r.n}",
                        fmt(mean(r.tau_pg), 3), f"{p[0]:.2f}", fmt(mean(r.tau_sr), 3), f"{p[1]:.2f}",
                        f"{fmt(p[0] / mean(r.tau_pg), 0)}x / {fmt(p[1] / mean(r.tau_sr), 0)}x",
                        fmt(mean(r.fold)), f"{p[2]:.2f}", fmt(mean(r.eff), 4), f"{p[3]:.4f}",
                        fmt(min(r.eff) if r.eff else float("nan"), 4), fmt(mean(r.conv), 4),
                        fmt(mean(r.rounds), 1), f"{r.unresolved}"])
    console.print(t)
    header = ["alg", "sigma mm", "d deg", "trials", "tau_pg s ours", "paper", "tau_sr s ours",
              "paper", "speed-up pg / sr", "fold s ours", "paper", "efficiency ours", "paper",
              "eff. min", "conv. 1st run", "rounds", "unresolved"]
    return md_table(header, md_rows)


# --- section 2: kaiju anchor -------------------------------------------------------------
@dataclass
class AnchorCell:
    alg: str
    buffer: float
    home_all: int = 0
    conv: list = field(default_factory=list)
    tau_pg: list = field(default_factory=list)
    call: list = field(default_factory=list)
    fold: list = field(default_factory=list)
    failed: int = 0

    @property
    def n(self) -> int:
        return len(self.conv)


def run_anchor(trials: int, seed: int, buffers: list[float], greed: float, phobia: float,
               step: float = 0.1) -> tuple[dict, dict]:
    """First run only (resolve=False) of greedy and markov on the same targets per trial.

    Returns ({(alg, buffer): AnchorCell}, {buffer: [targets per trial]}).
    """
    cells, targets = {}, {}
    layout = Layout.sdss_v_fps()
    with progress_bar() as prog:
        for b in buffers:
            rcs = {alg: Reconfiguration.from_names(
                "sdss-v-production", layout, buffer_mm=b, options=PlanOptions(
                    algorithm=alg, step_deg=step, greed=greed, phobia=phobia, resolve="none"))
                for alg in ("greedy", "markov")}
            task = prog.add_task(f"kaiju anchor {b} mm ({layout.n_robots} robots)", total=2 * trials)
            for alg in ("greedy", "markov"):
                cells[(alg, b)] = AnchorCell(alg, b)
            targets[b] = []
            for t in range(trials):
                tg = rcs["greedy"].random_targets(
                    np.random.default_rng([seed, 2, int(round(b * 100)), t]))
                targets[b].append(tg)
                for ai, alg in enumerate(("greedy", "markov")):
                    cell = cells[(alg, b)]
                    rng = np.random.default_rng([seed, 2, int(round(b * 100)), t, ai])
                    try:
                        t0 = time.perf_counter()
                        m = rcs[alg].plan(tg, rng)[0].metrics
                        wall = time.perf_counter() - t0
                    except Exception as exc:  # noqa: BLE001
                        cell.failed += 1
                        err.print(f"[red]trial {t} of {alg} {b} mm failed:[/] {exc}")
                        prog.advance(task)
                        continue
                    cell.conv.append(m["convergence"])
                    cell.home_all += int(m["n_deadlocked"] == 0)
                    cell.tau_pg.append(m["tau_pg_s"])
                    cell.call.append(wall)
                    cell.fold.append(m["fold_time_s"])
                    prog.advance(task)
    return cells, targets


def report_anchor(cells: dict, buffers: list[float], greed: float, phobia: float) -> str:
    blocks = []
    for alg, title, ref in (
            ("greedy", "ours greedy (GC) vs kaiju greedy", KAIJU_GREEDY),
            ("markov", f"ours markov (MC, greed {greed} / phobia {phobia}) vs kaiju MDP2 "
                       "(production: greedy + stochastic nudging + up to 5 retries; greed 0.7 / "
                       "phobia 0.6) -- NOT the same algorithm", KAIJU_MDP2)):
        t = Table(title=f"kaiju anchor: 500-robot SDSS-V FPS + 60 fiducials, sdss-v-production, "
                        f"step 0.1 deg, first run only: {title}")
        header = ["buffer mm", "seg end mm", "trials", "all home ours", "kaiju",
                  "frac home ours (median)", "kaiju", "tau_pg s ours median [min-max]",
                  "call s ours median", "kaiju s", "kaiju / ours (call)", "fold s ours"]
        for c in header:
            t.add_column(c, justify="right")
        md_rows = []
        for b in buffers:
            c = cells.get((alg, b))
            if c is None:
                continue
            k = ref.get(b)
            seg = load_spec("sdss-v-production").segment_end(b)
            med_call = float(np.median(c.call)) if c.call else float("nan")
            row = [f"{b}", f"{seg:.2f}", f"{c.n}" + (f" ({c.failed} failed)" if c.failed else ""),
                   f"{c.home_all}/{c.n}", k[0] if k else "-",
                   fmt(float(np.median(c.conv)) if c.conv else float("nan"), 3),
                   f"{k[1]:.3f}" if k else "-", med_range(c.tau_pg), fmt_t(med_call),
                   f"{k[2]}" if k else "-", f"{k[2] / med_call:.0f}x" if k and c.call else "-",
                   fmt(float(np.median(c.fold)) if c.fold else float("nan"), 1)]
            t.add_row(*row)
            md_rows.append(row)
        if alg == "markov":
            c = cells.get(("markov", 2.5))
            if c is not None and c.call:
                k = KAIJU_MDP[2.5]
                med_call = float(np.median(c.call))
                row = ["2.5 (vs kaiju MDP 0.8/0.2)", f"{load_spec('sdss-v-production').segment_end(2.5):.2f}",
                       f"{c.n}", f"{c.home_all}/{c.n}", k[0], fmt(float(np.median(c.conv)), 3),
                       f"{k[1]:.3f}", med_range(c.tau_pg), fmt_t(med_call), f"{k[2]}",
                       f"{k[2] / med_call:.0f}x", fmt(float(np.median(c.fold)), 1)]
                t.add_row(*row)
                md_rows.append(row)
        console.print(t)
        blocks.append(f"**{title}**\n\n" + md_table(header, md_rows))
    return "\n\n".join(blocks)


def report_speed(cells: dict) -> str:
    lines = []
    t = Table(title="Speed targets: path generation, 500 robots, sdss-v-production, 2.0 mm, "
                    "step 0.1 deg, first run; median over trials after one warm-up call "
                    "(numba compilation / cache load excluded)")
    for c in ("algorithm", "trials", "target s", "tau_pg s (kernel) median", "call s median",
              "met (kernel)", "met (call)"):
        t.add_column(c, justify="right")
    md_rows = []
    for alg in ("greedy", "markov"):
        c = cells.get((alg, 2.0))
        if c is None or not c.tau_pg:
            continue
        target = SPEED_TARGET_S[alg]
        kp, kc = float(np.median(c.tau_pg)), float(np.median(c.call))
        row = [alg, f"{c.n}", f"<= {target}", f"{kp:.3f}", f"{kc:.3f}",
               "yes" if kp <= target else "NO", "yes" if kc <= target else "NO"]
        t.add_row(*row)
        md_rows.append(row)
        lines.append(f"{alg}: median tau_pg {kp:.3f} s, call {kc:.3f} s (target <= {target} s)")
    if not md_rows:
        console.print("[yellow]speed targets: 2.0 mm not in --buffers; skipped[/]")
        return ""
    console.print(t)
    header = ["algorithm", "trials", "target s", "tau_pg s (kernel) median", "call s median",
              "met (kernel)", "met (call)"]
    return md_table(header, md_rows)


# --- section 3: kaiju itself ------------------------------------------------------------
def run_kaiju_if_installed(targets: dict, buffers: list[float], step: float = 0.1) -> str:
    """Run kaiju on the same targets if it can be imported. Returns one markdown line.

    The kaiju branch follows kaiju 1.4's RobotGrid API; it cannot be exercised on this
    machine (sdss-kaiju does not install here), so any error in it is reported, not raised.
    """
    try:
        import kaiju  # noqa: F401
        from kaiju import RobotGrid
    except Exception:  # noqa: BLE001
        line = ("kaiju is not installed (sdss-kaiju's build downloads C++ sources); the "
                "SDSS-V kaiju 1.4.1 anchor figures, measured on this machine kind "
                "(benchmarks/RESULTS.md), are used instead.")
        console.print(f"[yellow]{line}[/]")
        return line
    lay = Layout.sdss_v_fps()
    results = []
    try:
        for b in buffers:
            for tg in targets.get(b, []):
                rg = RobotGrid(stepSize=step, epsilon=step * 2.2, seed=0)
                for rid, (x, y) in zip(lay.robot_ids, lay.robot_xy):
                    rg.addRobot(int(rid), str(int(rid)), [float(x), float(y), 0.0], True)
                for fid, (x, y) in zip(lay.fiducial_ids, lay.fiducial_xy):
                    rg.addFiducial(int(fid), [float(x), float(y), 0.0],
                                   load_spec("sdss-v-production").fiducial_buffer_mm)
                rg.setCollisionBuffer(b)
                rg.initGrid()
                for k, rid in enumerate(lay.robot_ids):
                    r = rg.getRobot(int(rid))
                    r.setAlphaBeta(float(tg[k, 0]), float(tg[k, 1]))
                    r.setDestinationAlphaBeta(10.0, 170.0)
                t0 = time.perf_counter()
                rg.pathGenGreedy()
                results.append((b, time.perf_counter() - t0, not rg.didFail))
    except Exception as exc:  # noqa: BLE001
        line = f"kaiju is importable but running it failed ({exc!r}); anchor figures are used."
        console.print(f"[yellow]{line}[/]")
        return line
    parts = [f"{b} mm: {s:.2f} s, {'all home' if ok else 'deadlocked'}" for b, s, ok in results]
    line = "kaiju greedy on the same targets: " + "; ".join(parts)
    console.print(line)
    return line


# --- main ------------------------------------------------------------------------------
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=10,
                    help="trials per row/cell (default 10: the whole run takes ~2.5 min on 2 cores)")
    ap.add_argument("--kaiju-trials", type=int, default=None,
                    help="trials per cell of the kaiju section (default: --trials)")
    ap.add_argument("--only", choices=("table3", "kaiju", "all"), default="all")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--buffers", type=float, nargs="+", default=[1.5, 2.0, 2.5, 3.0, 3.5],
                    help="buffers of the kaiju section, mm")
    ap.add_argument("--greed", type=float, default=0.9, help="MC greed (paper: 0.9)")
    ap.add_argument("--phobia", type=float, default=0.3, help="MC phobia (paper: 0.3)")
    ap.add_argument("--md-out", default=None, help="also write the markdown block to this file")
    args = ap.parse_args(argv)
    ktrials = args.kaiju_trials or args.trials

    info = machine_info("numba")
    cmd = command_line()
    fp_start, fp_time = source_fingerprint()
    console.rule("rfp-twin planner benchmark")
    console.print(f"command: {cmd}")
    console.print(f"machine (at start): {info}")
    console.print(f"sources: models/ + planners/ sha256 {fp_start} (newest file {fp_time})")
    md = ["<!-- bench:begin -->", f"Command: `{cmd}`", "",
          f"Machine (at start): {info}.", "",
          f"Sources: models/ + planners/ sha256 `{fp_start}` (newest file {fp_time}).", ""]

    t_all = time.perf_counter()
    err.print("warming up the numba kernels (not timed) ...")
    warm_up(("greedy", "markov"))

    if args.only in ("table3", "all"):
        t0 = time.perf_counter()
        rows = run_table3(args.trials, args.seed, args.greed, args.phobia)
        md += [f"### Sayres 2021 Table 3 (547 robots, preset sdss-v, {args.trials} trials per row, "
               f"MC greed {args.greed} / phobia {args.phobia})", "",
               report_table3(rows, args.greed, args.phobia), "",
               f"Section wall time {time.perf_counter() - t0:.0f} s. Paper: kaiju 0.5.0, one "
               "thread of a 2.9 GHz i9, 2000 trials (Fig. 10).", ""]
    if args.only in ("kaiju", "all"):
        t0 = time.perf_counter()
        cells, targets = run_anchor(ktrials, args.seed, args.buffers, args.greed, args.phobia)
        md += [f"### kaiju anchor (500-robot SDSS-V FPS, 60 fiducials, sdss-v-production, step "
               f"0.1 deg, first run only, {ktrials} trials per cell, same targets for GC and MC)", "",
               report_anchor(cells, args.buffers, args.greed, args.phobia), "",
               "### Speed targets (2.0 mm, path generation, median after one warm-up call; "
               "numba compilation excluded)", "", report_speed(cells), "",
               run_kaiju_if_installed(targets, args.buffers), "",
               f"Section wall time {time.perf_counter() - t0:.0f} s.", ""]
    load_end = load_average()
    total = time.perf_counter() - t_all
    fp_end, fp_end_time = source_fingerprint()
    if fp_end != fp_start:
        warn = (f"Note: models/ or planners/ changed on disk during this run ({fp_start} -> "
                f"{fp_end}, at {fp_end_time}); this process kept the modules it imported at "
                f"start ({fp_start}), so its figures are for that version only.")
        console.print(f"[red]{warn}[/]")
        md += [f"**{warn}**", ""]
    md += [f"Total wall time {total:.0f} s; load average at end {load_end}.", "<!-- bench:end -->"]
    console.rule("markdown for benchmarks/RESULTS.md")
    write_block("\n".join(md), args.md_out)   # plain print: rich would re-wrap the markdown
    return 0


if __name__ == "__main__":
    sys.exit(main())
