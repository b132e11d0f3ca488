"""Per-call times of each engine on one arm: what ``manipdyn check`` prints under the report.

Layer 4 (checks).  A quick look, not a benchmark (``benchmarks/`` measures with
interleaved rounds and reference runs): the median over ``calls`` calls of one
random state, after a warm-up call.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from .._support.errors import SingularMassMatrixError

__all__ = ["engine_timings"]


def _median_us(fn, calls: int) -> float:
    fn()  # warm-up (builds pools, caches)
    times = []
    for _ in range(calls):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1e6


def engine_timings(arm, calls: int = 200, engines=("pinocchio", "lagrange"), seed: int = 1) -> dict:
    """``{engine: {"inverse_dynamics_us", "mass_matrix_us", "forward_dynamics_us"}}``: median
    microseconds per call on one state drawn from ``seed`` (forward dynamics NaN where D is singular)."""
    rng = np.random.default_rng(seed)
    q = arm.random_state(rng)
    qd = rng.uniform(-1, 1, arm.n)
    qdd = rng.uniform(-1, 1, arm.n)
    out = {}
    for name in engines:
        eng = arm.engine(name)
        out[eng.name] = {
            "inverse_dynamics_us": _median_us(lambda: eng.inverse_dynamics(q, qd, qdd), calls),
            "mass_matrix_us": _median_us(lambda: eng.mass_matrix(q), calls),
        }
        try:
            out[eng.name]["forward_dynamics_us"] = _median_us(lambda: eng.forward_dynamics(q, qd, qdd), calls)
        except SingularMassMatrixError:
            out[eng.name]["forward_dynamics_us"] = float("nan")  # D singular: no forward dynamics
    return out
