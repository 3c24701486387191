"""Kernels loaded from numba's cache on another thread (models/kernel_cache.py)."""
from __future__ import annotations

import subprocess
import sys
import threading

import numpy as np
import pytest
from numba import njit

from rfp_twin.models.kernel_cache import (DELIVERY, cached_signatures, call_kernel,
                                          kernel_by_name, preload_cached, warm_kernels, warm_up)
from rfp_twin.planners.postprocess.timing.law import law_times, s_at_times
from rfp_twin.twin.pipeline import PLANNER_KERNEL

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


def test_the_pipeline_preloads_the_kernels_their_modules_register():
    """Each module registers the kernels it calls from Python where they are defined: the
    stage the pipeline preloads holds kernels only, the plan's paths, the post-processing's
    and the 2D check's among them; the planner's kernel it waits for exists."""
    from numba.core.registry import CPUDispatcher

    kernels = warm_kernels(DELIVERY)
    assert kernels and all(isinstance(k, CPUDispatcher) for k in kernels)
    assert {"rfp_twin.planners.plan.result", "rfp_twin.planners.postprocess.timing.kernel",
            "rfp_twin.planners.postprocess.smoothing", "rfp_twin.validation.checker2d.kernel",
            "rfp_twin.models.kinematics"} <= {k.py_func.__module__ for k in kernels}
    assert kernel_by_name(PLANNER_KERNEL).py_func.__name__ == PLANNER_KERNEL.rpartition(":")[2]


def test_warm_up_keeps_the_order_given_and_each_kernel_once():
    warm_up("test-stage", law_times, s_at_times)
    warm_up("test-stage", law_times)
    assert warm_kernels("test-stage") == (law_times, s_at_times)
    assert warm_kernels("no-such-stage") == ()


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


def test_a_first_call_compiles_on_its_own_thread_and_returns_or_raises():
    seen = []
    real_start = threading.Thread.start

    def start(self):
        seen.append(self.name)
        real_start(self)

    @njit
    def halve(x):
        if x < 0:
            raise ValueError("negative")
        return x / 2

    threading.Thread.start = start
    try:
        assert call_kernel(halve, 3.0) == 1.5          # first call: compiles on a new thread
        assert seen == ["rfp-kernel-first-call"] and halve.overloads
        assert call_kernel(halve, 5.0) == 2.5          # compiled: called here
        assert seen == ["rfp-kernel-first-call"]
        with pytest.raises(ValueError, match="negative"):
            call_kernel(halve, -1.0)
    finally:
        threading.Thread.start = real_start

    @njit
    def fails(x):
        raise KeyError("first call")

    with pytest.raises(KeyError, match="first call"):
        call_kernel(fails, 1.0)
