"""The batch path runs on one thread or all, whichever this engine measured faster (issue 27,
item 26).  Speed itself is measured by benchmarks/bench_batch_threads.py, never asserted here:
these check the choice, fed with given costs, and that the answers do not depend on it."""

from __future__ import annotations

import numpy as np

import manipdyn as md
from manipdyn.engines.pinocchio import engine as pinocchio_engine
from manipdyn.engines.pinocchio.engine import PARALLEL_MIN_STATES, PinocchioEngine, ThreadChoice


def test_choice_tries_both_then_keeps_the_faster_and_looks_again():
    c = ThreadChoice()
    assert c.pick(2) == 2                      # first: all threads
    c.record(2, 0.93e-6)                       # the loaded machine: 2 threads slower
    assert c.pick(2) == 1
    c.record(1, 0.72e-6)
    picks = []
    for _ in range(200):
        k = c.pick(2)
        picks.append(k)
        c.record(k, 0.72e-6 if k == 1 else 0.93e-6)
    looks = [i for i, k in enumerate(picks) if k == 2]
    # looks after 8, 16, 32, 64, 64, ... batches: few, so a slower option costs little
    assert 4 <= len(looks) <= 7 and all(b - a >= 8 for a, b in zip(looks, looks[1:]))
    assert np.diff(looks)[-1] == ThreadChoice.MAX_INTERVAL
    for i in range(2 * ThreadChoice.MAX_INTERVAL + 2):    # the load goes: 2 threads become faster
        k = c.pick(2)
        c.record(k, 0.72e-6 if k == 1 else 0.40e-6)
    assert c.cost[2] < c.cost[1] and c.pick(2) == 2


def test_engine_times_its_batches_and_keeps_a_given_count(monkeypatch):
    """The default engine feeds its choice the measured cost of each parallel-sized batch and runs
    the next on what the choice picks; an explicit num_threads is used as given and not timed.
    The answers are the same bit for bit."""
    monkeypatch.setattr(pinocchio_engine, "_POOL_PID", [None])
    arm = md.load("ur5")
    auto = PinocchioEngine(arm.pinocchio.model.copy())
    auto._num_threads = 2                      # as on a 2-core machine, whatever this one has
    asked = PinocchioEngine(arm.pinocchio.model.copy(), num_threads=2)
    used = []
    real = pinocchio_engine.pin.rneaInParallel

    def spy(threads, *args):
        used.append(threads)
        return real(threads, *args)

    monkeypatch.setattr(pinocchio_engine.pin, "rneaInParallel", spy)
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-1, 1, (PARALLEL_MIN_STATES, 6)) for _ in range(3))
    ref = PinocchioEngine(arm.pinocchio.model.copy(), num_threads=1).inverse_dynamics(q, qd, qdd)
    used.clear()
    for _ in range(2):
        np.testing.assert_array_equal(auto.inverse_dynamics(q, qd, qdd), ref)
    assert used == [2, 1] and set(auto.thread_choice.cost) == {1, 2}
    # the third batch runs on the faster so far (read before it runs: its own time, measured on a
    # loaded machine, may change which is faster afterwards)
    cost = auto.thread_choice.cost
    best = 1 if cost[1] <= cost[2] else 2          # a tie goes to one thread
    np.testing.assert_array_equal(auto.inverse_dynamics(q, qd, qdd), ref)
    assert used[2] == best
    used.clear()
    np.testing.assert_array_equal(asked.inverse_dynamics(q, qd, qdd), ref)
    assert used == [2] and asked.thread_choice.cost == {}
    used.clear()
    auto.inverse_dynamics(q[:10], qd[:10], qdd[:10])    # small batches: one thread, not timed
    assert used == [1]
