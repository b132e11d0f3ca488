"""One thread or all of them for a batch of the Pinocchio engine, by measurement.

Layer 3 (engines: pinocchio), part of :mod:`manipdyn.engines.pinocchio.engine` (whose
``_batch_threads`` asks :class:`ThreadChoice` and tells it what each batch cost; importable from
there as before).
"""

from __future__ import annotations

__all__ = ["ThreadChoice"]


class ThreadChoice:
    """One thread or all of them for the next batch, by measurement (issue 27, item 26).

    A batch on Pinocchio's thread pool waits for its slowest thread, so on a machine
    shared with other processes it can be slower than one thread (measured on a 2-core
    machine under one other busy process, 20,000 UR5 states: 0.93 us per state on 2
    threads, 0.72 on one), and under a heavier load faster again (a process with more
    threads gets more of the machine): neither the core count nor the load average
    predicts which.  So each engine times its batches: the first parallel-sized batch
    runs on all threads, the second on one, and from then on each runs on the one with
    the lower cost per state (an average over its recent batches, weight :data:`WEIGHT`
    for the newest), except for a look at the other one after :data:`EXPLORE` batches,
    then after twice as many each time the look confirms the choice (at most
    :data:`MAX_INTERVAL`), so that a change of load is seen while a slow option costs
    little: 3 % of the batches at most once settled.  The answers do not depend on the
    threads (bit for bit).  ``benchmarks/bench_batch_threads.py`` times it against one
    thread and all of them.
    """

    #: batches before the first look at the currently slower option
    EXPLORE = 8
    #: the longest interval between looks, in batches
    MAX_INTERVAL = 64
    #: weight of the newest batch in the running cost per state
    WEIGHT = 0.5

    def __init__(self):
        self.cost, self.calls, self.interval, self.next_look = {}, 0, self.EXPLORE, self.EXPLORE

    def _best(self, threads: int) -> int:
        return 1 if self.cost[1] <= self.cost[threads] else threads

    def pick(self, threads: int) -> int:
        """Threads for the next batch: 1 or ``threads``."""
        self.calls += 1
        if threads not in self.cost:
            return threads
        if 1 not in self.cost:
            return 1
        best = self._best(threads)
        if self.calls >= self.next_look:
            self.next_look = self.calls + self.interval
            self.interval = min(2 * self.interval, self.MAX_INTERVAL)
            return threads if best == 1 else 1
        return best

    def record(self, threads: int, seconds_per_state: float) -> None:
        """The cost per state of a batch that ran on ``threads`` (1 or the engine's count)."""
        many = max(self.cost.keys() | {threads})
        before = self._best(many) if len(self.cost) == 2 else None
        old = self.cost.get(threads)
        x = float(seconds_per_state)
        self.cost[threads] = x if old is None else old + self.WEIGHT * (x - old)
        if before is not None and self._best(many) != before:     # the load changed: look more often
            self.interval = self.EXPLORE
            self.next_look = self.calls + self.EXPLORE
