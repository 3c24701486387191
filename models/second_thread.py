"""The process's one worker thread for work beside the main thread (the second core).

Compiled kernels that release the GIL (``nogil=True``) run there while the main thread
goes on: the search's batches swept ahead
(:mod:`rfp_twin.planners.roadmap.sweep_batches`), half of the one-robot groups of
post-processing (:mod:`rfp_twin.planners.postprocess.singles`), the interaction pairs
while the plan is smoothed. One thread, made on first use; a task must not wait for
another task of this thread (it would wait forever). A process forked while it exists
(a process pool) gets a new one when it first asks: the parent's thread does not exist
in the child.
"""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

__all__ = ["second_thread"]

_WORKER: ThreadPoolExecutor | None = None
_LOCK = threading.Lock()


def second_thread() -> ThreadPoolExecutor:
    """The worker (a one-thread executor), made on first use."""
    global _WORKER
    with _LOCK:
        if _WORKER is None:
            _WORKER = ThreadPoolExecutor(1, thread_name_prefix="rfp-second")
        return _WORKER


def _forget() -> None:
    """In a forked child the parent's worker thread does not exist: make a new one."""
    global _WORKER, _LOCK
    _WORKER = None
    _LOCK = threading.Lock()


os.register_at_fork(after_in_child=_forget)
