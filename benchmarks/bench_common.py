"""What every benchmark prints about where and how it ran (machine, load, command)."""
from __future__ import annotations

import os
import platform
import shlex
import sys
import time


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
