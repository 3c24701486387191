"""Run ``rfp-twin`` as a user does: a subprocess, its exit code, stdout and stderr."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``rfp-twin ARGS`` (as ``python -m rfp_twin.twin.cli``); text output, 300 s limit."""
    return subprocess.run([sys.executable, "-m", "rfp_twin.twin.cli", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=300)


def plan_ok(out: Path, *args: str) -> tuple[subprocess.CompletedProcess, dict]:
    """``rfp-twin plan ARGS --out OUT``, which must exit 0; the process and OUT/summary.json."""
    r = run("plan", *args, "--out", str(out))
    assert r.returncode == 0, r.stderr
    return r, json.loads((out / "summary.json").read_text())
