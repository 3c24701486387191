"""Kernels loaded from numba's cache on another thread (models/kernel_cache.py)."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from rfp_twin.models.kernel_cache import cached_signatures, kernel_by_name, preload_cached
from rfp_twin.planners.postprocess.timing.law import law_times
from rfp_twin.twin.pipeline import DELIVER_KERNELS, PLANNER_KERNEL

LAW_TIMES = "rfp_twin.planners.postprocess.timing.law:law_times"


def test_the_cache_holds_the_signature_a_call_compiled():
    law_times(np.linspace(0.0, 1.0, 5), np.ones(5))          # compiled or loaded, and cached
    sigs = cached_signatures(law_times)
    assert law_times.signatures[0] in [tuple(s) for s in sigs]
    assert cached_signatures(object()) == []                   # not a kernel: nothing


def test_names_that_are_not_kernels_are_refused():
    assert kernel_by_name(LAW_TIMES) is law_times
    with pytest.raises(LookupError, match="TimeLaw"):
        kernel_by_name("rfp_twin.planners.postprocess.timing.law:TimeLaw")
    with pytest.raises(ModuleNotFoundError):
        kernel_by_name("rfp_twin.no_such_module:f")


def test_every_kernel_the_pipeline_preloads_exists():
    """A renamed kernel would silently stop being preloaded: the list must name kernels."""
    for name in DELIVER_KERNELS + (PLANNER_KERNEL,):
        assert kernel_by_name(name).py_func.__name__ == name.rpartition(":")[2]


def test_a_fresh_process_gets_the_kernel_loaded_without_calling_it():
    law_times(np.linspace(0.0, 1.0, 5), np.ones(5))
    code = (
        "import time\n"
        "from rfp_twin.models.kernel_cache import preload_cached\n"
        "from rfp_twin.planners.postprocess.timing.law import law_times\n"
        "assert not law_times.overloads\n"
        "t = time.perf_counter()\n"
        # waits for a kernel nobody loads, until released
        f"p = preload_cached(['{LAW_TIMES}'], after='rfp_twin.planners.postprocess.timing.law:s_at_times')\n"
        "time.sleep(0.3)\n"
        "waiting = len(law_times.overloads)\n"
        "p.release()\n"
        "p.join()\n"
        "print(waiting, len(law_times.overloads))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, check=True).stdout.split()
    assert out == ["0", "1"]
