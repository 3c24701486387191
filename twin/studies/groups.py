"""Study rows grouped by grid point, the series a figure draws, and their labels.

:func:`load_groups` reads a study folder's rows (:func:`rfp_twin.twin.studies.store.read_results`)
into one :class:`Group` per grid point: the point's parameters and, per metric, the
values of its trials that did not fail. :func:`make_series` cuts groups into the lines of a
figure (one per algorithm and value of the other varied parameters). Units: mm, deg, s.
"""
from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rfp_twin.models.errors import RfpError
from rfp_twin.twin.studies.parse import parse_study
from rfp_twin.twin.studies.spec import PARAM_COLUMNS
from rfp_twin.twin.studies.store import STUDY_COPY, read_results

__all__ = ["Group", "load_groups", "varied_params", "make_series", "series_label",
           "fmt_val", "fmt_num", "sort_key", "ALG_SHORT", "ALG_ORDER", "SERIES_PARAMS", "CATALOGUE_PARAMS", "SHORT"]

#: Parameters that define a series (the resolved grid keys minus derived ones).
SERIES_PARAMS = ("preset", "layout", "n_robots", "pitch_mm", "alpha_length_mm",
                 "beta_length_mm", "fold_alpha_deg", "fold_beta_deg", "buffer_mm", "step_deg",
                 "greed", "phobia", "resolution", "direction", "max_rounds")
#: Parameters of a yield point's catalogue (absent from planning-only studies).
CATALOGUE_PARAMS = ("catalogue", "density")
SHORT = {"preset": "", "layout": "", "n_robots": "n", "pitch_mm": "pitch",
         "alpha_length_mm": "l_a", "beta_length_mm": "l_b", "fold_alpha_deg": "fold a",
         "fold_beta_deg": "fold b", "buffer_mm": "sigma",
         "step_deg": "step", "greed": "greed", "phobia": "phobia", "resolution": "resolve",
         "direction": "", "max_rounds": "rounds"}
ALG_SHORT = {"greedy": "GC", "markov": "MC", "apf": "APF", "capf": "CAPF"}
ALG_ORDER = ("markov", "greedy", "capf", "apf")   # the paper's panels: MC first (top), GC second
METRICS = ("efficiency", "convergence", "fold_time_s", "tau_pg_s", "tau_sr_s", "n_replaced",
           "rounds", "wall_s")


@dataclass
class Group:
    """All trials of one grid point."""

    point_id: str
    params: dict
    n: int = 0                 # trials (rows)
    n_error: int = 0
    n_deadlocked: int = 0      # trials left with deadlocked robots
    n_checked: int = 0
    n_collision_trials: int = 0
    collisions: int = 0
    values: dict = field(default_factory=dict)   # metric -> (k,) array, non-error trials
    errors: list = field(default_factory=list)

    @property
    def alg(self) -> str:
        return self.params["algorithm"]

    @property
    def pitch_over_reach(self) -> float:
        return self.params["pitch_mm"] / (self.params["alpha_length_mm"]
                                          + self.params["beta_length_mm"])

    def v(self, metric: str) -> np.ndarray:
        return self.values.get(metric, np.empty(0))

    def mean(self, metric: str) -> float:
        x = self.v(metric)
        return float(np.mean(x)) if x.size else math.nan

    def min(self, metric: str) -> float:
        x = self.v(metric)
        return float(np.min(x)) if x.size else math.nan

    def ci95(self, metric: str) -> tuple[float, float]:
        """95 % confidence interval of the mean (Student t); NaN with fewer than 2 trials."""
        x = self.v(metric)
        if x.size < 2:
            return math.nan, math.nan
        from scipy.stats import t

        half = float(t.ppf(0.975, x.size - 1) * np.std(x, ddof=1) / math.sqrt(x.size))
        m = float(np.mean(x))
        return m - half, m + half


def load_groups(study_dir: str | Path, all_points: bool = False) -> tuple[list[Group], dict]:
    """Rows of a study folder grouped by grid point.

    Returns (groups, info); info holds the parsed study (or None), the number of rows
    read and of rows left out because their point is not in ``study.toml``.
    """
    study_dir = Path(study_dir)
    table = read_results(study_dir)
    info: dict = {"study": None, "rows": table.num_rows, "ignored_rows": 0, "note": ""}
    copy = study_dir / STUDY_COPY
    keep: set[str] | None = None
    if copy.is_file():
        try:
            info["study"] = parse_study(copy.read_text(encoding="utf-8"), source=str(copy),
                                        base_dir=study_dir, default_name=study_dir.name)
            keep = {p.point_id for p in info["study"].points}
        except RfpError as exc:
            info["note"] = f"study.toml could not be read ({exc}); every row is reported."
    cols = table.to_pydict()
    n = table.num_rows
    workers = {w for w in cols["worker"] if w}
    info["worker_processes"] = len(workers)
    info["hosts"] = sorted({w.rsplit(":", 1)[0] for w in workers})
    by_point: dict[str, list[int]] = defaultdict(list)
    for i in range(n):
        by_point[cols["point_id"][i]].append(i)
    groups = []
    for pid, idx in by_point.items():
        if keep is not None and not all_points and pid not in keep:
            info["ignored_rows"] += len(idx)
            continue
        first = idx[0]
        g = Group(pid, {k: cols[k][first] for k in PARAM_COLUMNS})
        for k in CATALOGUE_PARAMS:          # yield points: the catalogue is part of the point
            if cols.get(k) and cols[k][first] is not None:
                g.params[k] = cols[k][first]
        g.n = len(idx)
        ok = [i for i in idx if cols["status"][i] != "error"]
        g.n_error = g.n - len(ok)
        g.errors = sorted({cols["error"][i] for i in idx if cols["status"][i] == "error"})
        g.n_deadlocked = sum(cols["status"][i] == "deadlocked" for i in idx)
        for m in METRICS:
            g.values[m] = np.array([cols[m][i] for i in ok if cols[m][i] is not None], dtype=float)
        # targets kept: Eq. 11, with robots still deadlocked after the last round counted lost
        g.values["kept"] = np.array([cols["efficiency"][i] - cols["n_deadlocked"][i]
                                     / max(1, cols["n_robots"][i]) for i in ok
                                     if cols["efficiency"][i] is not None], dtype=float)
        checked = [i for i in ok if cols["checked"][i] and cols["collisions"][i] is not None]
        g.n_checked = len(checked)
        g.collisions = int(sum(cols["collisions"][i] for i in checked))
        g.n_collision_trials = sum(cols["collisions"][i] > 0 for i in checked)
        g.values["trial"] = np.array([cols["trial"][i] for i in ok], dtype=float)
        g.values["seed"] = np.array([cols["seed"][i] for i in ok], dtype=np.int64)
        groups.append(g)
    groups.sort(key=lambda g: tuple(sort_key(g.params[k]) for k in SERIES_PARAMS)
                + (ALG_ORDER.index(g.alg),))
    return groups, info


def sort_key(v):
    """Numbers before strings, each in their order."""
    return (0, v, "") if isinstance(v, (int, float)) else (1, 0, str(v))


def varied_params(groups: list[Group]) -> list[str]:
    """Series parameters with more than one value (greed / phobia over MC points only)."""
    out = []
    for k in SERIES_PARAMS:
        gs = [g for g in groups if g.alg == "markov"] if k in ("greed", "phobia") else groups
        if len({g.params[k] for g in gs}) > 1:
            out.append(k)
    return out


def fmt_val(k: str, v) -> str:
    """A parameter value as a report shows it (floats in %g)."""
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def make_series(groups: list[Group], x: str, varied: list[str], extra_exclude=()) -> dict:
    """{(alg, slice): [groups sorted by x]}; slice = values of the other varied params."""
    others = [k for k in varied if k not in (x, "algorithm", *extra_exclude)]
    out: dict = defaultdict(list)
    for g in groups:
        sl = tuple((k, g.params[k]) for k in others
                   if not (g.alg == "greedy" and k in ("greed", "phobia")))   # MC only
        out[(g.alg, sl)].append(g)
    xkey = (lambda g: g.pitch_over_reach) if x == "pitch_over_reach" else (lambda g: g.params[x])
    for k in out:
        out[k].sort(key=xkey)
    order = sorted(out, key=lambda s: (ALG_ORDER.index(s[0]),
                                       tuple(sort_key(v) for _, v in s[1])))
    return {k: out[k] for k in order}


def series_label(alg: str, sl: tuple) -> str:
    """``GC, sigma 2.5, step 0.1``: the algorithm and a slice's values."""
    parts = [ALG_SHORT.get(alg, alg)]
    for k, v in sl:
        short = SHORT.get(k, k)
        parts.append(f"{short} {fmt_val(k, v)}".strip())
    return ", ".join(parts)


def fmt_num(x, nd=4) -> str:
    """``x`` with ``nd`` decimals; ``-`` for None, NaN or inf."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{nd}f}"
