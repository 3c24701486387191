"""What the benchmarks share: where and how they ran (machine, load, command, sources),
their markdown output, and the one scenario two of them draw (the hex-grid fold).

Every benchmark runs from the repository root as ``.venv/bin/python benchmarks/bench_x.py``:
this folder is then on ``sys.path`` (for this module) and the project packages come from
the virtual environment. Plans, post-processing and checks go through
:mod:`rfp_twin.twin.pipeline`, the chain ``rfp-twin plan`` runs. Units: mm, deg, s.
"""
from __future__ import annotations

import hashlib
import os
import platform
import shlex
import sys
import time
from pathlib import Path

import numpy as np

#: The repository (this file is benchmarks/bench_common.py).
ROOT = Path(__file__).resolve().parent.parent


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo, or "unknown"."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def load_average() -> str:
    """The 1/5/15-minute load averages as "a / b / c"."""
    try:
        return " / ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def now() -> str:
    return time.strftime("%Y-%m-%d %H:%M:%S %Z")


def python_version() -> str:
    return platform.python_version()


def command_line() -> str:
    """The command that ran this script, as a user would type it."""
    exe = os.path.relpath(sys.executable) if sys.executable.startswith(os.getcwd()) else sys.executable
    return " ".join(shlex.quote(a) for a in [exe, *sys.argv])


def machine_info(*modules: str) -> str:
    """One line: cores, CPU, Python, numpy and the versions of ``modules`` (imported
    here), load average now, date."""
    versions = [f"numpy {np.__version__}"]
    for name in modules:
        mod = __import__(name)
        versions.append(f"{name} {getattr(mod, '__version__', '?')}")
    return (f"nproc {os.cpu_count()}, {cpu_model()}; Python {python_version()}, "
            f"{', '.join(versions)}; load {load_average()}; {now()}")


def source_fingerprint(dirs: tuple[str, ...] = ("models", "planners")) -> tuple[str, str]:
    """Short sha256 of the sources under ``dirs`` (.py, .toml, .csv) and the newest
    file's modification time (UTC): which version of the code made the figures."""
    files = sorted(p for d in dirs for p in (ROOT / d).rglob("*")
                   if p.suffix in (".py", ".toml", ".csv") and "__pycache__" not in p.parts)
    h = hashlib.sha256()
    newest = 0.0
    for f in files:
        h.update(str(f.relative_to(ROOT)).encode())
        h.update(f.read_bytes())
        newest = max(newest, f.stat().st_mtime)
    stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(newest)) + " UTC" if files else "n/a"
    return h.hexdigest()[:12], stamp


def wide_console(stderr: bool = False):
    """A rich Console at least 160 columns wide (wide tables stay readable in logs)."""
    from rich.console import Console

    console = Console(stderr=stderr)
    if not console.is_terminal or console.width < 160:
        console = Console(width=200, stderr=stderr)
    return console


def md_table(header: list[str], rows: list[list[str]]) -> str:
    """A markdown table."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)


def add_row(lines: list[str], *cells) -> None:
    """Append one markdown table row of ``cells`` (each shown with ``str``) to ``lines``
    and echo it to stderr, so a long run shows its progress."""
    lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    print(lines[-1], file=sys.stderr)


def timed(fn, *args, **kwargs):
    """``(fn(*args, **kwargs), wall seconds)``."""
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


def seed_range(text: str) -> list[int]:
    """The seeds of ``--seeds`` text: ``"7"`` or an inclusive range ``"1-50"``."""
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def write_block(text: str, md_out: str | Path | None) -> None:
    """Print the markdown block of a run; with ``md_out``, also write it to that file."""
    print(text)
    if md_out:
        Path(md_out).write_text(text + "\n", encoding="utf-8")


def paste_note(target: Path | None) -> None:
    """What the old ``--append FILE`` options do now: say where the printed block goes.

    benchmarks/RESULTS.md is a table of current figures kept by hand (each section gives
    the latest figure, HISTORY.md the ones it replaced), so nothing is appended to it."""
    if target is not None:
        print(f"Paste the block above into {target} (its section; move the figure it "
              "replaces to benchmarks/HISTORY.md). Nothing was written.")


def hex_fold(n_positions: int, buffer_mm: float, seed: int, step_deg: float = 0.1):
    """The scenario of bench_sim and bench_render: preset ``sdss-v`` on a centred hex
    grid of ``n_positions``, seeded random targets and a greedy reverse plan with target
    replacement (:func:`rfp_twin.twin.pipeline.plan_random`, the sequence of
    ``rfp-twin plan --layout hex:N --resolve replace --seed S``).

    Returns ``(Reconfiguration, Plan fold -> targets, planning wall seconds)``;
    ``Trajectory.from_plan(plan).reversed()`` plays it targets -> fold.
    """
    from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration, plan_random

    rc = Reconfiguration.from_names("sdss-v", f"hex:{n_positions}", buffer_mm=buffer_mm,
                                    options=PlanOptions(step_deg=step_deg, resolve="replace"))
    t0 = time.perf_counter()
    _, plan, _ = plan_random(rc.geom, seed, rc.options)
    return rc, plan, time.perf_counter() - t0
