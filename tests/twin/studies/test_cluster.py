"""Where trials run (twin/studies/cluster.py): batches, the scheduler connection."""
from __future__ import annotations

import socket
import time

import pytest

from tests.twin.studies.builders import TINY
from rfp_twin.twin.studies import StudyError, machine_workers, parse_study
from rfp_twin.twin.studies import cluster


def free_port() -> int:
    """A local TCP port nothing listens on (bound, then released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_batches_keep_the_order_and_size_tasks_by_robots():
    trials = parse_study(TINY.replace("trials = 2", "trials = 10")).trial_list()   # 40 x 19
    auto = cluster.batches(trials, "auto")
    assert [t for b in auto for t in b] == trials
    per = -(-cluster.AUTO_BATCH_ROBOTS // 19)        # 16 trials of 19 robots reach 300
    assert [len(b) for b in auto] == [per, per, len(trials) - 2 * per]
    assert [len(b) for b in cluster.batches(trials, 3)] == [3] * 13 + [1]
    big = parse_study("[grid]\nn_robots = 547\nbuffer_mm = [2.0, 3.0]\n").trial_list()
    assert [len(b) for b in cluster.batches(big, "auto")] == [1, 1]   # 547 robots: a task each
    assert cluster.batches([], "auto") == []
    assert machine_workers() >= 1


def test_an_unreachable_scheduler_is_one_study_error(monkeypatch):
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1.0)
    address = f"tcp://127.0.0.1:{free_port()}"
    t0 = time.perf_counter()
    with pytest.raises(StudyError) as info:
        cluster.connect(address)
    msg = str(info.value)
    assert "cannot reach the Dask scheduler" in msg and address in msg and "\n" not in msg
    assert time.perf_counter() - t0 < 20
