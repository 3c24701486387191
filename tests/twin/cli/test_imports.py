"""The CLI's import cost (issue #13: the whole `rfp-twin plan` command is what a user waits
for): importing the command-line app loads neither the study machinery (pyarrow, dask) nor
MuJoCo, the renderer or toppra; each command imports what it needs when it runs."""
from __future__ import annotations

import json
import subprocess
import sys

HEAVY = ("pyarrow", "dask", "distributed", "mujoco", "toppra", "matplotlib",
         "rfp_twin.twin.studies", "rfp_twin.twin.render", "rerun")


def test_importing_the_cli_loads_no_heavy_module():
    code = ("import json, sys; import rfp_twin.twin.cli; "
            f"print(json.dumps([m for m in {list(HEAVY)!r} if m in sys.modules]))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout.strip().splitlines()[-1]) == []
