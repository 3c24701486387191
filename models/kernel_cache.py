"""Load numba kernels from the on-disk cache ahead of their first call, on another thread.

A fresh process loads each ``@njit(cache=True)`` kernel from numba's cache at its first
call: 3-70 ms a kernel (unpickling, then LLVM linking the object code), ~0.2 s for the
kernels of post-processing and its 2D check on the 500-robot SDSS-V layout. While a
long kernel that releases the GIL runs on the main thread (the stepwise planners' run,
``nogil=True``), another thread can load the kernels of the next stage instead:
:func:`preload_cached` starts that thread. It only *loads* what the cache holds for the
current code (the signatures in each kernel's cache index whose source hash and target
match), so it loads and does not compile: with a cold cache the kernels compile at their
first call, as without it.

numba's compiler lock serialises loads: a kernel that the main thread calls while the
thread loads another waits for that load. So the thread can be told to start only once
the main thread's long kernel is loaded (``after``).

A kernel's first call in a process may compile it, and numba's compiler recurses deeply in
Python. On CPython 3.11 a recursion that keeps crossing a boundary between two chunks of
the interpreter's frame stack maps and unmaps a chunk at each crossing (CPython issue
gh-142183, fixed in 3.13): where the boundaries fall depends on the caller's stack depth,
and at an unlucky depth the stepwise kernel's compile spends more time in the kernel
(mmap, munmap, page faults) than in the compiler. :func:`call_kernel` makes a kernel's
first call on a new thread, whose stack starts empty, so its compile runs at the same
depth from every caller (CLI, tests, study workers).

Which kernels to load is registered where they live: a module calls :func:`warm_up` on
the kernels it calls from Python, under the stage that calls them (:data:`DELIVERY`: a
plan's paths, its post-processing and the 2D check), and the pipeline asks
:func:`warm_kernels` for a stage's kernels.
"""
from __future__ import annotations

import importlib
import threading
import time
from collections.abc import Iterable

__all__ = ["DELIVERY", "Preload", "cached_signatures", "call_kernel", "kernel_by_name",
           "preload_cached", "warm_kernels", "warm_up"]

#: How often the thread looks whether the kernel it waits for is loaded, s.
_POLL_S = 0.002

#: Stage of the kernels called from Python once the planner's runs are over: the plan's
#: paths, post-processing and the independent 2D check.
DELIVERY = "delivery"

#: Stage -> the kernels registered for it, in registration order.
_WARM: dict[str, list] = {}


def warm_up(stage: str, *kernels) -> None:
    """Register ``kernels`` (``@njit(cache=True)`` dispatchers) as called from Python by
    ``stage``, in the order given (the order the stage calls them), for
    :func:`preload_cached` to load ahead. The module that defines them calls this at
    import. Name only kernels called from Python: one called from another kernel is
    compiled into its caller."""
    own = _WARM.setdefault(stage, [])
    own.extend(k for k in kernels if k not in own)


def warm_kernels(stage: str) -> tuple:
    """The kernels registered for ``stage`` (:func:`warm_up`) by the modules imported
    so far, in registration order."""
    return tuple(_WARM.get(stage, ()))


def cached_signatures(dispatcher) -> list[tuple]:
    """The argument-type tuples that numba's cache holds for ``dispatcher`` (a
    ``@njit(cache=True)`` kernel) as compiled from its current source for this machine;
    [] when it holds none, or the kernel is not cached."""
    cache = getattr(dispatcher, "_cache", None)
    cache_file = getattr(cache, "_cache_file", None)
    if cache_file is None:
        return []
    try:
        index = cache_file._load_index()
        codegen = dispatcher.targetctx.codegen()
    except Exception:                   # an unreadable or foreign index: load at first call
        return []
    out = []
    for key in index:
        sig = key[0]
        try:
            if key == cache._index_key(sig, codegen):
                out.append(sig)
        except Exception:
            continue
    return out


def kernel_by_name(name: str):
    """The kernel ``"package.module:function"`` (the module is imported if needed);
    LookupError if it is not a numba kernel."""
    from numba.core.registry import CPUDispatcher

    module_name, _, attr = name.partition(":")
    value = getattr(importlib.import_module(module_name), attr, None)
    if not isinstance(value, CPUDispatcher):
        raise LookupError(f"{name}: not a numba kernel")
    return value


def _load(names: tuple, after: str | None, go: threading.Event) -> None:
    if after is not None:
        # let the main thread load (and start) that kernel first: numba's compiler lock
        # would otherwise make it wait for the loads below
        first = kernel_by_name(after)
        while not first.overloads and not go.wait(_POLL_S):
            pass
    for name in names:
        dispatcher = kernel_by_name(name) if isinstance(name, str) else name
        if dispatcher.overloads:
            continue                    # loaded already (a process's later runs)
        for sig in cached_signatures(dispatcher):
            if tuple(sig) not in dispatcher.overloads:
                try:
                    dispatcher.compile(tuple(sig))
                except Exception:       # the first call will load or compile it as usual
                    pass


class Preload:
    """The thread of :func:`preload_cached`."""

    def __init__(self, names: tuple, after: str | None) -> None:
        self._go = threading.Event()
        self._thread = threading.Thread(target=_load, args=(names, after, self._go),
                                        name="rfp-kernel-preload", daemon=True)
        self._thread.start()

    def release(self) -> None:
        """Stop waiting for the ``after`` kernel: load now (e.g. the stage that was to
        load it is over without it)."""
        self._go.set()

    def join(self) -> None:
        """Wait until every kernel is loaded (before a process forks, say)."""
        self._go.set()
        self._thread.join()


def preload_cached(names: Iterable, *, after: str | None = None) -> Preload:
    """Start a daemon thread that loads the kernels ``names`` (dispatchers, e.g. from
    :func:`warm_kernels`, or "package.module:function"; in the order they will be called)
    from numba's cache, each with every signature the
    cache holds for its current source. Name only the kernels called from Python: a kernel
    called from another kernel is compiled into its caller, so loading it alone would only
    cost time. With ``after`` (a kernel's name), the thread first waits until that kernel
    is loaded (the long nogil call the loads are to hide behind) or
    :meth:`Preload.release` is called."""
    return Preload(tuple(names), after)


def call_kernel(kernel, *args):
    """``kernel(*args)`` for a ``@njit`` dispatcher; while it has no compiled signature yet
    (its first call in this process, which loads or compiles it) the call runs on a new
    thread, so the compile starts from an empty Python stack (module docstring). Returns
    what the kernel returns; an exception it raises is raised here."""
    if kernel.overloads:
        return kernel(*args)
    out: list = []

    def run() -> None:
        try:
            out.append((True, kernel(*args)))
        except BaseException as exc:        # raised again on the caller's thread below
            out.append((False, exc))

    thread = threading.Thread(target=run, name="rfp-kernel-first-call", daemon=True)
    thread.start()
    thread.join()
    ok, value = out[0]
    if not ok:
        raise value
    return value
