"""The kaiju side of the cross-check: runs under the side environment's python (.venv-kaiju).

It imports kaiju (SDSS-V's planner, sdss-kaiju 1.4.1) and never rfp_twin: what it reports
comes from kaiju's own placement and kinematics, built from the calibration CSV files our
instruments read (``positionerTable.csv``, ``wokCoords.csv``, ``fiducialCoords.csv`` of a
folder of ``models/data/calibrations/``) the way SDSS-V's software builds its grid
(``RobotGrid._load_from_tables``: robot buffer 2 mm, fiducials and guide cameras 3 mm).

Commands (each writes one JSON file):

``replay --calib DIR --traj FILE --out JSON [--dt 0.01] [--buffer 2.0]``
    Replays a trajectory file in encoder angles (``{robot_id: {"alpha": [[deg, s], ...],
    "beta": [...]}}``, a run folder's ``trajectories_encoder.json`` or a jaeger file),
    linearly interpolated at times ``t0, t0 + dt, ..., t1`` (and ``t1``): every robot's
    encoder angles are set on kaiju's robots, which apply their ``alphaOffset`` /
    ``betaOffset`` themselves, and its beta collision segment is read from
    ``robot.collisionSegWokXYZ`` (3D wok frame, mm). It reports, for every pair kaiju
    lists as neighbours (robot-robot, robot-fiducial, robot-guide camera), the smallest
    distance over the samples and when; the samples closer than kaiju's keep-out
    (``2 buffer`` for two robots, ``buffer + 3`` mm for a fiducial or a guide camera);
    the samples where a robot kaiju watches (``fiducialWatch``) is in its forbidden zone
    ``beta < 41.2853 - 1.3085 alpha``; and each robot's metrology fiber at the last sample.
``plan --calib DIR --poses CSV --out JSON [--algorithm greedy|mdp2] [--seed S] ...``
    Times kaiju's path generation from the poses of a CSV (``robot_id, alpha, beta,
    dest_alpha, dest_beta``, encoder deg) on the calibrated grid: ``pathGenGreedy`` or
    ``pathGenMDP2(greed, phobia, tries)``; reports seconds, steps, tries, the robots home.
``production --calib DIR --poses CSV --out JSON --traj-out FILE [--seed S] ...``
    The trajectory SDSS-V's controller (jaeger) would send for these targets (CSV
    ``robot_id, alpha, beta``, encoder deg), in its order: the grid (step 0.1 deg, RDP
    epsilon 2 x step) with every robot at its target and the lattice position (10, 170) as
    destination; robot-by-robot decollision (``decollideRobot`` on each robot still
    collided); ``pathGenMDP2(greed, phobia, False, tries)``; on a deadlock, up to
    ``--retries`` times, one deadlocked robot drawn at random is given a random pose
    (``setXYUniform``, decollided if needed) and the grid is planned again from the saved
    poses; then ``getPathPair(speed, smoothPoints, collisionShrink, pathDelay)``. Writes
    the ``fromDestination`` paths (lattice -> targets, encoder deg, times with the path
    delay) to ``--traj-out`` and reports the robots moved off their targets, attempts,
    steps and the seconds (wall and CPU) of path generation and of ``getPathPair``.

Segment distances are computed here with numpy (closest points of two 3D segments,
clamped parameters), not with kaiju's own distance code.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

#: kaiju's forbidden zone of a watched robot: beta < FW_C0 + FW_C1 alpha (encoder deg).
FW_C0, FW_C1 = 41.2853, -1.3085


def load_grid(calib: Path, step_deg: float = 0.1, seed: int = 0, epsilon: float | None = None):
    """kaiju's RobotGrid built from a calibration folder's three CSV files (``epsilon``:
    the RDP tolerance of its ``getPathPair``, deg; None: kaiju's default)."""
    from kaiju.robotGrid import RobotGrid

    tables = [pd.read_csv(calib / f) for f in ("positionerTable.csv", "wokCoords.csv",
                                              "fiducialCoords.csv")]

    class FolderGrid(RobotGrid):
        def _load_grid(self):
            self._load_from_tables(*tables)

    return FolderGrid(stepSize=step_deg, seed=seed, epsilon=epsilon)


def segment_distance_3d(p0, p1, q0, q1):
    """Distance between 3D segments p0-p1 and q0-q1, arrays (..., 3) -> (...), mm."""
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = np.einsum("...k,...k", d1, d1)
    e = np.einsum("...k,...k", d2, d2)
    f = np.einsum("...k,...k", d2, r)
    c = np.einsum("...k,...k", d1, r)
    b = np.einsum("...k,...k", d1, d2)
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > 1e-12, np.clip((b * f - c * e) / denom, 0.0, 1.0), 0.0)
        t = np.where(e > 1e-12, (b * s + f) / e, 0.0)
        s = np.where(t < 0.0, np.where(a > 1e-12, np.clip(-c / a, 0.0, 1.0), 0.0), s)
        s = np.where(t > 1.0, np.where(a > 1e-12, np.clip((b - c) / a, 0.0, 1.0), 0.0), s)
    t = np.clip(t, 0.0, 1.0)
    # q a point (a fiducial): the closest point of p to it
    point = e <= 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(point, np.where(a > 1e-12, np.clip(-c / a, 0.0, 1.0), 0.0), s)
    t = np.where(point, 0.0, t)
    diff = (p0 + s[..., None] * d1) - (q0 + t[..., None] * d2)
    return np.sqrt(np.einsum("...k,...k", diff, diff))


def chunked(fn, n_times: int, chunk: int = 128) -> np.ndarray:
    """``fn(slice)`` -> (k, p) distances, evaluated over time slices and stacked (n_times, p):
    bounds the temporaries of the vectorised distance to ``chunk`` samples."""
    return np.concatenate([fn(slice(s, min(s + chunk, n_times)))
                           for s in range(0, n_times, chunk)])


def _sample(traj: dict, ids: list[int], times: np.ndarray) -> np.ndarray:
    """(n_times, n, 2) encoder angles of robots ``ids`` at ``times``, deg."""
    out = np.empty((times.size, len(ids), 2))
    for k, rid in enumerate(ids):
        for ax, name in enumerate(("alpha", "beta")):
            pts = np.asarray(traj[str(rid)][name], dtype=np.float64).reshape(-1, 2)
            out[:, k, ax] = np.interp(times, pts[:, 1], pts[:, 0])
    return out


def replay(args) -> dict:
    grid = load_grid(Path(args.calib))
    grid.setCollisionBuffer(args.buffer)
    traj = json.loads(Path(args.traj).read_text())
    robots = grid.robotDict
    unknown = sorted(set(int(k) for k in traj) - set(robots))
    if unknown:
        raise SystemExit(f"{args.traj}: positioner ids {unknown[:5]} are not robots of {args.calib}")
    ids = sorted(int(k) for k in traj)
    t_all = np.concatenate([np.asarray(traj[str(i)][ax], dtype=np.float64).reshape(-1, 2)[:, 1]
                            for i in ids for ax in ("alpha", "beta")])
    t0, t1 = float(t_all.min()), float(t_all.max())
    times = np.unique(np.append(np.arange(t0, t1, args.dt), t1))
    angles = _sample(traj, ids, times)
    clock = time.perf_counter()
    seg = np.empty((times.size, len(ids), 2, 3))
    for k, rid in enumerate(ids):
        r = robots[rid]
        for s in range(times.size):
            r.setAlphaBeta(angles[s, k, 0], angles[s, k, 1])
            seg[s, k] = r.collisionSegWokXYZ
    kin_s = time.perf_counter() - clock
    met = {}
    for k, rid in enumerate(ids):
        robots[rid].setAlphaBeta(angles[-1, k, 0], angles[-1, k, 1])
        met[str(rid)] = list(robots[rid].metWokXYZ)
    where = {rid: k for k, rid in enumerate(ids)}
    cb = float(args.buffer)
    out = {"calib": str(args.calib), "traj": str(args.traj), "buffer_mm": cb,
           "dt_s": args.dt, "t0_s": t0, "t1_s": t1, "n_times": int(times.size),
           "robot_ids": ids, "kinematics_s": kin_s,
           "fiducial_watch_ids": sorted(rid for rid in ids if robots[rid].fiducialWatch),
           "met_wok_final": met}
    violations = []

    def report(kind, pairs, dist, keepout):
        """Per-pair minima of dist (n_times, p) and the samples inside the keep-out."""
        imin = np.argmin(dist, axis=0)
        dmin = dist[imin, np.arange(dist.shape[1])]
        bad_t, bad_p = np.nonzero(dist < keepout)
        for p in np.unique(bad_p):
            ts = bad_t[bad_p == p]
            violations.append({"kind": kind, "a": pairs[p][0], "b": pairs[p][1],
                               "t_first_s": float(times[ts[0]]), "t_last_s": float(times[ts[-1]]),
                               "n_samples": int(ts.size), "min_mm": float(dmin[p]),
                               "keepout_mm": float(keepout[p] if np.ndim(keepout) else keepout)})
        out[kind] = {"pairs": pairs, "min_mm": dmin.tolist(), "t_min_s": times[imin].tolist()}

    rpairs = sorted({(min(a, b), max(a, b)) for a in ids for b in robots[a].robotNeighbors
                     if b in where})
    ia = np.array([where[a] for a, _ in rpairs])
    ib = np.array([where[b] for _, b in rpairs])
    dist = chunked(lambda t: segment_distance_3d(seg[t, ia, 0], seg[t, ia, 1], seg[t, ib, 0],
                                                 seg[t, ib, 1]), times.size)
    report("robot_pairs", [list(p) for p in rpairs], dist,
           np.array([robots[a].collisionBuffer + robots[b].collisionBuffer for a, b in rpairs]))

    fpairs = [(a, f) for a in ids for f in robots[a].fiducialNeighbors]
    if fpairs:
        ia = np.array([where[a] for a, _ in fpairs])
        fx = np.array([grid.fiducialDict[f].xyzWok for _, f in fpairs])
        dist = chunked(lambda t: segment_distance_3d(seg[t, ia, 0], seg[t, ia, 1], fx[None],
                                                     fx[None]), times.size)
        report("fiducial_pairs", [list(p) for p in fpairs], dist,
               np.array([robots[a].collisionBuffer + grid.fiducialDict[f].collisionBuffer
                         for a, f in fpairs]))
    gpairs = [(a, g) for a in ids for g in robots[a].gfaNeighbors]
    if gpairs:
        ia = np.array([where[a] for a, _ in gpairs])
        g0 = np.array([grid.gfaDict[g].collisionSegWokXYZ[0] for _, g in gpairs])
        g1 = np.array([grid.gfaDict[g].collisionSegWokXYZ[1] for _, g in gpairs])
        dist = chunked(lambda t: segment_distance_3d(seg[t, ia, 0], seg[t, ia, 1], g0[None],
                                                     g1[None]), times.size)
        report("gfa_pairs", [list(p) for p in gpairs], dist,
               np.array([robots[a].collisionBuffer + grid.gfaDict[g].collisionBuffer
                         for a, g in gpairs]))
        out["gfa_segments_wok"] = {str(g): [list(v) for v in grid.gfaDict[g].collisionSegWokXYZ]
                                   for g in grid.gfaDict}
    watch = []
    for rid in out["fiducial_watch_ids"]:
        k = where[rid]
        bad = angles[:, k, 1] < FW_C0 + FW_C1 * angles[:, k, 0]
        if bad.any():
            s = int(np.flatnonzero(bad)[0])
            watch.append({"robot": rid, "t_first_s": float(times[s]), "n_samples": int(bad.sum()),
                          "alpha": float(angles[s, k, 0]), "beta": float(angles[s, k, 1])})
    out["violations"] = violations
    out["fiducial_watch_violations"] = watch
    return out


def plan(args) -> dict:
    grid = load_grid(Path(args.calib), args.step, args.seed)
    grid.setCollisionBuffer(args.buffer)
    poses = pd.read_csv(args.poses)
    for row in poses.itertuples():
        r = grid.robotDict[int(row.robot_id)]
        r.setAlphaBeta(float(row.alpha), float(row.beta))
        r.setDestinationAlphaBeta(float(row.dest_alpha), float(row.dest_beta))
    n_coll = grid.getNCollisions()
    # kaiju prints a line per MDP2 try on stdout: keep it off ours
    with open(os.devnull, "w") as null, contextlib.redirect_stdout(null):
        sys.stdout.flush()
        saved = os.dup(1)
        os.dup2(null.fileno(), 1)
        try:
            t0 = time.perf_counter()
            c0 = time.process_time()
            if args.algorithm == "greedy":
                grid.pathGenGreedy(False, False)
            else:
                grid.pathGenMDP2(args.greed, args.phobia, False, args.tries)
            seconds = time.perf_counter() - t0
            cpu = time.process_time() - c0
        finally:
            os.dup2(saved, 1)
            os.close(saved)
    ids = [int(i) for i in poses.robot_id]
    home = [rid for rid in ids if grid.robotDict[rid].score() == 0]
    return {"calib": str(args.calib), "algorithm": args.algorithm, "seed": args.seed,
            "buffer_mm": args.buffer, "step_deg": args.step, "n_robots": len(ids),
            "initial_collisions": int(n_coll), "seconds": seconds, "cpu_s": cpu,
            # mdp2iter: index of the last try (nTries when every try failed)
            "n_steps": int(grid.nSteps), "tries": min(int(grid.mdp2iter) + 1, args.tries)
            if args.algorithm == "mdp2" else 1, "did_fail": bool(grid.didFail),
            "n_home": len(home), "fraction_home": len(home) / max(1, len(ids)),
            "not_home": sorted(set(ids) - set(home)),
            "fiducial_watch_ids": sorted(rid for rid in ids if grid.robotDict[rid].fiducialWatch)}


class _Quiet:
    """Context: the process's stdout (fd 1) to /dev/null (kaiju prints per MDP2 try)."""

    def __enter__(self):
        sys.stdout.flush()
        self.null = open(os.devnull, "w")
        self.saved = os.dup(1)
        os.dup2(self.null.fileno(), 1)
        return self

    def __exit__(self, *exc):
        os.dup2(self.saved, 1)
        os.close(self.saved)
        self.null.close()


def production(args) -> dict:
    calib = Path(args.calib)
    step = args.step
    rng = np.random.default_rng(args.seed)

    def grid_at(state: dict):
        """A fresh grid with every robot at ``state[rid]`` (encoder deg), lattice as
        destination (jaeger rebuilds its grid from a dump before each retry)."""
        g = load_grid(calib, step, args.seed, epsilon=args.epsilon_factor * step)
        g.setCollisionBuffer(args.buffer)
        for rid, (a, b) in state.items():
            r = g.robotDict[rid]
            r.setAlphaBeta(a, b)
            r.setDestinationAlphaBeta(args.lattice_alpha, args.lattice_beta)
        return g

    poses = pd.read_csv(args.poses)
    asked = {int(r.robot_id): (float(r.alpha), float(r.beta)) for r in poses.itertuples()}
    clock = time.perf_counter()
    grid = grid_at(asked)
    build_s = time.perf_counter() - clock
    # jaeger's decollision: robot by robot, each robot still collided
    decollided = []
    for rid in grid.getCollidedRobotList():
        if grid.isCollided(rid):
            grid.decollideRobot(rid)
            decollided.append(int(rid))
    state = {rid: (grid.robotDict[rid].alpha, grid.robotDict[rid].beta) for rid in asked}
    still = len(grid.getCollidedRobotList())
    unlocked, attempts, gen_s, gen_cpu, steps_per_attempt, tries = [], 0, 0.0, 0.0, [], []
    failed = None
    while True:
        attempts += 1
        if attempts > 1:
            grid = grid_at(state)
        with _Quiet():
            t0, c0 = time.perf_counter(), time.process_time()
            grid.pathGenMDP2(args.greed, args.phobia, False, args.tries)
            gen_s += time.perf_counter() - t0
            gen_cpu += time.process_time() - c0
        steps_per_attempt.append(int(grid.nSteps))
        tries.append(min(int(grid.mdp2iter) + 1, args.tries))
        if not grid.didFail:
            break
        deadlocks = [int(r) for r in grid.deadlockedRobots()]
        if attempts > args.retries:
            failed = f"{len(deadlocks)} deadlocked after {args.retries} retries"
            break
        move = int(rng.choice(deadlocks))
        grid = grid_at(state)
        grid.robotDict[move].setXYUniform()
        if grid.isCollided(move):
            grid.decollideRobot(move)
            if grid.isCollided(move):
                failed = f"robot {move} cannot be decollided"
                break
        state[move] = (grid.robotDict[move].alpha, grid.robotDict[move].beta)
        if move not in unlocked:
            unlocked.append(move)
    out = {"calib": str(calib), "seed": args.seed, "buffer_mm": args.buffer, "step_deg": step,
           "greed": args.greed, "phobia": args.phobia, "tries_max": args.tries,
           "retries_max": args.retries, "grid_s": build_s, "decollided": decollided,
           "collided_after_decollision": int(still), "unlocked": unlocked,
           "attempts": attempts, "steps": steps_per_attempt, "tries": tries,
           "pathgen_s": gen_s, "pathgen_cpu_s": gen_cpu, "failed": failed,
           "planned_poses": {str(r): list(v) for r, v in state.items()}}
    if failed is None:
        with _Quiet():
            t0, c0 = time.perf_counter(), time.process_time()
            _, from_dest = grid.getPathPair(speed=args.speed, smoothPoints=args.smooth_points,
                                            collisionShrink=args.collision_shrink,
                                            pathDelay=args.path_delay)
            out["pathpair_s"] = time.perf_counter() - t0
            out["pathpair_cpu_s"] = time.process_time() - c0
        traj = {str(rid): {ax: [[float(a), float(t)] for a, t in path[ax]]
                           for ax in ("alpha", "beta")} for rid, path in from_dest.items()}
        tmp = Path(args.traj_out + ".tmp")
        tmp.write_text(json.dumps(traj))
        tmp.replace(args.traj_out)
        out["traj"] = args.traj_out
    return out


# Each sub-command's arguments as (flag, type, default); a default of None makes it required.
ALL_COMMANDS = (("--calib", str, None), ("--out", str, None), ("--buffer", float, 2.0))
PLANNING = (("--poses", str, None), ("--seed", int, 0), ("--step", float, 0.1),
            ("--greed", float, 0.7), ("--phobia", float, 0.6), ("--tries", int, 5))
REPLAY = (("--traj", str, None), ("--dt", float, 0.01))
PRODUCTION = (("--traj-out", str, None), ("--epsilon-factor", float, 2.0), ("--retries", int, 5),
              ("--lattice-alpha", float, 10.0), ("--lattice-beta", float, 170.0),
              ("--speed", float, 2.0), ("--smooth-points", int, 21),
              ("--collision-shrink", float, 0.08), ("--path-delay", float, 1.0))


def add_sub_command(sub, name: str, *groups) -> argparse.ArgumentParser:
    """Sub-command ``name`` with the arguments every one takes (``--calib``, ``--out``,
    ``--buffer`` in mm) and those of ``groups`` (tuples as in :data:`PLANNING`)."""
    parser = sub.add_parser(name)
    for flag, kind, default in (arg for group in (ALL_COMMANDS, *groups) for arg in group):
        if default is None:
            parser.add_argument(flag, type=kind, required=True)
        else:
            parser.add_argument(flag, type=kind, default=default)
    return parser


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    add_sub_command(sub, "replay", REPLAY)
    plan_parser = add_sub_command(sub, "plan", PLANNING)
    plan_parser.add_argument("--algorithm", choices=("greedy", "mdp2"), default="mdp2")
    add_sub_command(sub, "production", PLANNING, PRODUCTION)
    args = ap.parse_args(argv)
    result = {"replay": replay, "plan": plan, "production": production}[args.cmd](args)
    tmp = Path(args.out + ".tmp")
    tmp.write_text(json.dumps(result))
    tmp.replace(args.out)


if __name__ == "__main__":
    main()
