"""Benchmark of the trace-form Lagrange-Euler engine on the Puma 560.

Times ``arm.lagrange.dynamics_terms(q, qd)`` (D, h and g together, eq. 2.39)

* for one state, the median over many calls;
* per state in a batch of ``--batch`` states (one call on the whole batch,
  divided by the batch size);
* and Pinocchio's D, h and g for one state, timed in the same run, as the
  reference the ratio is taken against.

The arm is the bundled standard-DH Puma 560 without rotors or friction.  All
random inputs are drawn before the timed region, and the answers are checked
against Pinocchio's before anything is timed, so a fast wrong answer never
counts.  (The plain-loop transcription of the chapter lives with the tests,
``tests/reference.py``, which check the engine against it.)  Prints medians and inter-quartile ranges in microseconds.

Targets: <= 150 us for one state; <= 10 us per state in a batch of 1000.

Usage::

    python -m benchmarks.bench_lagrange [--repeat 2000] [--batch 1000]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np

import manipdyn as md
from manipdyn.check.crosscheck import TOLERANCE
from manipdyn.model.random_arms import random_state

from .arm_set import strip_actuators

TARGET_SINGLE_US = 150.0
TARGET_BATCH_US = 10.0


def quartiles_us(samples_ns) -> tuple[float, float, float]:
    """(median, q1, q3) of durations given in ns, returned in microseconds."""
    q1, med, q3 = np.percentile(np.asarray(samples_ns, dtype=float) / 1e3, [25, 50, 75])
    return float(med), float(q1), float(q3)


def time_calls(fn, args_list, repeat: int) -> list[int]:
    """Time ``fn(*args)`` once per call, cycling through pre-drawn ``args_list``."""
    out = []
    k = len(args_list)
    for r in range(repeat):
        args = args_list[r % k]
        t0 = time.perf_counter_ns()
        fn(*args)
        out.append(time.perf_counter_ns() - t0)
    return out


def check_agreement(arm, q, qd) -> float:
    """Largest relative difference, trace form vs Pinocchio, over D, h, g (the cross-check's measure)."""
    worst = 0.0
    for b in range(q.shape[0]):
        got = arm.lagrange.dynamics_terms(q[b], qd[b])
        exp = arm.pinocchio.dynamics_terms(q[b], qd[b])
        for x, y in zip(got, exp):
            worst = max(worst, float(np.max(np.abs(x - y) / np.maximum(1.0, np.abs(y)))))
    return worst


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeat", type=int, default=2000,
                   help="timed calls for the one-state engine timing (default 2000)")
    p.add_argument("--batch", type=int, default=1000, help="batch size (default 1000)")
    p.add_argument("--batch-repeat", type=int, default=200,
                   help="timed calls on the whole batch (default 200)")
    p.add_argument("--ref-repeat", type=int, default=2000,
                   help="timed calls of Pinocchio's D, h, g, the reference (default 2000)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--check-targets", action="store_true",
                   help="exit with status 1 if a target is missed")
    a = p.parse_args(argv)

    with warnings.catch_warnings():
        # the published Puma data has a massless link 1 with Iyy = 0.35 and a link 3
        # that breaks a triangle inequality; the warnings are expected here
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        arm = strip_actuators(md.load("puma560"))
    assert not np.any(arm.armature), "benchmark arm must have no rotors"
    lag = arm.lagrange

    # ---- inputs, drawn outside every timed region -------------------------
    rng = np.random.default_rng(a.seed)
    n_single = 256
    q1, qd1, _ = random_state(rng, arm, size=n_single)
    singles = [(q1[i].copy(), qd1[i].copy()) for i in range(n_single)]
    qB, qdB, _ = random_state(rng, arm, size=a.batch)

    # ---- correctness first -------------------------------------------------
    worst = check_agreement(arm, q1[:20], qd1[:20])
    if not worst <= TOLERANCE:
        print(f"FAIL: trace form and Pinocchio differ by {worst:.3g} (> {TOLERANCE})")
        return 2
    DB, hB, gB = lag.dynamics_terms(qB, qdB)
    for b in range(0, a.batch, max(1, a.batch // 50)):
        for x, y in zip(lag.dynamics_terms(qB[b], qdB[b]), (DB[b], hB[b], gB[b])):
            if not np.max(np.abs(x - y) / np.maximum(1.0, np.abs(y))) <= 1e-14:
                print("FAIL: batch result differs from the one-state result")
                return 2
    print(f"Puma 560 (standard DH, n = {arm.n}); trace form agrees with Pinocchio "
          f"to {worst:.2g} (relative, max over D, h, g of 20 states)")

    # ---- timing ------------------------------------------------------------
    for args in singles[:50]:  # warm-up
        lag.dynamics_terms(*args)
    single = quartiles_us(time_calls(lag.dynamics_terms, singles, a.repeat))

    lag.dynamics_terms(qB, qdB)
    batch_ns = time_calls(lag.dynamics_terms, [(qB, qdB)], a.batch_repeat)
    batch = quartiles_us(np.asarray(batch_ns) / a.batch)

    pin_terms = arm.pinocchio.dynamics_terms
    for args in singles[:50]:  # warm-up
        pin_terms(*args)
    reference = quartiles_us(time_calls(pin_terms, singles, a.ref_repeat))

    rows = [
        (f"trace form, one state ({a.repeat} calls)", single, TARGET_SINGLE_US),
        (f"trace form, per state in a batch of {a.batch} ({a.batch_repeat} calls)", batch,
         TARGET_BATCH_US),
        (f"Pinocchio (CRBA + 2 RNEA), one state ({a.ref_repeat} calls)", reference, None),
    ]
    print(f"{'D + h + g':<62} {'median':>10} {'IQR':>21}   target")
    ok = True
    for label, (med, lo, hi), target in rows:
        verdict = ""
        if target is not None:
            met = med <= target
            ok &= met
            verdict = f"<= {target:g} us {'met' if met else 'MISSED'}"
        print(f"{label:<62} {med:8.2f} us  [{lo:8.2f}, {hi:8.2f}] us   {verdict}")
    print(f"trace form / Pinocchio, one state, same run: {single[0] / reference[0]:.1f}x")
    return 0 if (ok or not a.check_targets) else 1


if __name__ == "__main__":
    sys.exit(main())
