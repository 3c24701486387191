"""The process's worker thread beside the main thread (models/second_thread.py)."""
from __future__ import annotations

import multiprocessing
import threading

from rfp_twin.models.second_thread import second_thread


def _thread_name() -> str:
    return threading.current_thread().name


def _in_child(queue) -> None:
    queue.put(second_thread().submit(_thread_name).result(timeout=30))


def test_one_worker_thread_made_once():
    assert second_thread() is second_thread()
    assert second_thread().submit(_thread_name).result().startswith("rfp-second")


def test_a_forked_child_gets_a_worker_of_its_own():
    """The parent's worker thread does not exist in a forked child: the child's first
    task would wait forever on the parent's executor."""
    second_thread().submit(_thread_name).result()            # the parent's worker exists
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_in_child, args=(queue,))
    child.start()
    child.join(60)
    assert child.exitcode == 0
    assert queue.get(timeout=5).startswith("rfp-second")
