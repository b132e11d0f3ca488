"""The batch path takes only the cores no other task wants (issue 27, item 26).  Speed itself is
measured by benchmarks/bench_batch_threads.py, never asserted here; these check the choice."""

from __future__ import annotations

import numpy as np

import manipdyn as md
from manipdyn import _threads, pinocchio_engine
from manipdyn.pinocchio_engine import PARALLEL_MIN_STATES, PinocchioEngine


def test_free_cores_reads_the_runnable_tasks(tmp_path, monkeypatch):
    """``running/total`` of /proc/loadavg counts the caller: 1 running leaves every core free, 2
    leave one fewer, many leave one; an unreadable file leaves them all."""
    import builtins

    real_open = builtins.open
    text = {"value": b"0.50 0.40 0.30 1/200 1234\n"}

    def fake_open(path, *a, **k):
        if path == "/proc/loadavg":
            f = tmp_path / "loadavg"
            f.write_bytes(text["value"])
            return real_open(f, *a, **k)
        return real_open(path, *a, **k)

    monkeypatch.setattr(builtins, "open", fake_open)
    assert _threads.free_cores(2) == 2
    text["value"] = b"1.00 1.00 1.00 2/200 1234\n"
    assert _threads.free_cores(2) == 1 and _threads.free_cores(4) == 3
    text["value"] = b"9.00 9.00 9.00 17/200 1234\n"
    assert _threads.free_cores(2) == 1
    text["value"] = b"garbage"
    assert _threads.free_cores(3) == 3


def test_a_batch_on_a_loaded_machine_runs_on_the_free_cores_only(monkeypatch):
    """The default engine asks free_cores per batch; a thread count given by the caller is kept.
    The answer is the same whatever the threads (bit for bit)."""
    arm = md.load("ur5")
    auto = PinocchioEngine(arm.pinocchio.model.copy(), num_threads=None)
    asked = PinocchioEngine(arm.pinocchio.model.copy(), num_threads=2)
    monkeypatch.setattr(pinocchio_engine, "_POOL_PID", [None])
    free = {"n": 1}
    monkeypatch.setattr(pinocchio_engine, "free_cores", lambda cores: min(cores, free["n"]))
    auto._num_threads = 2                     # as on a 2-core machine, whatever this one has
    assert auto._batch_threads(PARALLEL_MIN_STATES) == 1
    assert asked._batch_threads(PARALLEL_MIN_STATES) == 2
    free["n"] = 2
    assert auto._batch_threads(PARALLEL_MIN_STATES) == 2
    assert auto._batch_threads(PARALLEL_MIN_STATES - 1) == 1
    auto.num_threads = 2                      # set by the caller: kept
    free["n"] = 1
    assert auto._batch_threads(PARALLEL_MIN_STATES) == 2
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-1, 1, (PARALLEL_MIN_STATES, 6)) for _ in range(3))
    np.testing.assert_array_equal(auto.inverse_dynamics(q, qd, qdd),
                                  PinocchioEngine(arm.pinocchio.model.copy(), num_threads=1).inverse_dynamics(q, qd, qdd))
