"""Benchmark of the derivatives of the dynamics (issue 18), on the 6-DOF arms and the Panda.

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_derivatives [--arms ur5 panda] [--batch 1000]

Two comparisons, each timed in interleaved rounds (:func:`benchmarks.timing.interleaved`:
load from other processes hits every candidate alike; ratios are medians of
per-round ratios):

1. **Fast path per call**: ``arm.pinocchio.inverse_dynamics_derivatives``,
   ``forward_dynamics_derivatives`` and ``gravity_derivative`` on one native
   float64 state, against the raw Pinocchio call on the same model and data
   (``pin.computeRNEADerivatives`` ...).  The raw call returns views of
   ``pin.Data``; manipdyn copies them (the next call would overwrite them), so
   the copies are part of the measured overhead.  Target: ratio <= 1.5; with a
   friction law (the bundled Panda carries Gaz et al.'s sigmoid law) the RNEA
   and ABA derivatives <= 2.0 (issue 34: the law's derivative is part of the
   call; raw Pinocchio times the rigid bodies alone).
   The floor (issue 27, item 27) is timed in the same rounds: a Python function that
   calls the raw function and copies its answers, nothing else, the least any API
   returning caller-owned arrays costs (``computeGeneralizedGravityDerivatives``
   returns a new array of its own, so the gravity floor copies nothing).  ``floor`` is
   its ratio to raw Pinocchio, ``checks`` manipdyn's over the floor: what the checks
   themselves cost.  ``chk.fl`` (issue 34) is the floor of a CHECKED call: the floor
   plus only the tests the shortcut cannot do without (the dtype test, the one fused
   ``math.hypot`` finiteness and size test of the inputs and, for ABA, the singular-D
   test on Minv's diagonal unless the model's pivots are bounded below at every q,
   ``pivots_positive``), over raw Pinocchio; ``unchk`` is ``engine.unchecked``'s
   call (the same code without its tests, friction law included) over raw Pinocchio.
   ``ratio`` is the median of per-round ratios, ``best`` (and the others) the ratio
   of the best rounds, steadier on a machine shared with other work.
2. **Trace form per state in a batch**: ``arm.lagrange``'s derivatives on a batch
   of ``--batch`` states, divided by the batch size, against raw Pinocchio's
   per-call derivatives.  Target: <= 10x (moonshot 5x).

The arms are used as bundled (rotors included; the Panda with its friction law).
Each row prints its target and a verdict: ``ok`` when the median per-round
ratio meets the target, ``ok (best)`` when only the ratio of the best rounds
does (on a loaded machine the steadier estimate), ``floor`` when it does not and
the checked call's own floor (``chk.fl``) is over the target too (no checked
Python call can meet it there: ``engine.unchecked`` is the call that can),
``OVER`` otherwise.
Inputs are drawn before the timed region, and both engines' answers are
compared (to the cross-check's 1e-9) before anything is timed, so a fast wrong
answer never counts.  Nothing is asserted about time: compare with earlier runs.
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings

import numpy as np

from benchmarks.report import format_pools
import manipdyn as md
from manipdyn.check.crosscheck import TOLERANCE
from manipdyn.engines.pinocchio.derivatives import pivots_positive
from manipdyn.model.random_arms import random_state

from .timing import blas_config, interleaved, paired_ratio

TARGET_FAST = 1.5
#: the RNEA and ABA derivatives of an arm with a friction law (issue 34)
TARGET_FRICTION = 2.0
TARGET_BATCH = 10.0
MOONSHOT_BATCH = 5.0
DEFAULT_ARMS = ("puma560", "ur5", "ur10", "panda")


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


def _check(arm, q, qd, qdd, tau) -> None:
    L, P = arm.lagrange, arm.pinocchio
    pairs = (list(zip(L.inverse_dynamics_derivatives(q, qd, qdd), P.inverse_dynamics_derivatives(q, qd, qdd)))
             + list(zip(L.forward_dynamics_derivatives(q, qd, tau), P.forward_dynamics_derivatives(q, qd, tau)))
             + [(L.gravity_derivative(q), P.gravity_derivative(q))])
    for a, b in pairs:
        err = np.abs(a - b).reshape(len(a), -1).max(axis=1) / np.maximum(1.0, np.abs(a).reshape(len(a), -1).max(axis=1))
        if not float(err.max()) <= TOLERANCE:
            raise SystemExit(f"!!! WRONG ANSWER on {arm.name}: engines differ by {float(err.max()):.3g}")


def _best(a, b) -> float:
    """Ratio of the best rounds: what an uninterrupted round costs (on a shared machine the
    steadier estimate; the median per-round ratio is ``ratio``)."""
    return float(np.min(a.times) / np.min(b.times))


def measure(name: str, batch: int = 1000, rounds: int = 15, target_s: float = 0.02) -> dict:
    import pinocchio as pin

    arm = _load(name)
    P, L = arm.pinocchio, arm.lagrange
    m, d = P.model, P.data
    rng = np.random.default_rng(0)
    qb, qdb, qddb = random_state(rng, arm, size=batch)
    taub = L.inverse_dynamics(qb, qdb, qddb)
    _check(arm, qb[:50], qdb[:50], qddb[:50], taub[:50])
    q, qd, qdd, tau = qb[0].copy(), qdb[0].copy(), qddb[0].copy(), taub[0].copy()
    rnea_d, aba_d, grav_d = (pin.computeRNEADerivatives, pin.computeABADerivatives,
                             pin.computeGeneralizedGravityDerivatives)
    def inv_floor(a, b, c):
        r = rnea_d(m, d, a, b, c)
        return r[0].copy(), r[1].copy()

    def fwd_floor(a, b, c):
        r = aba_d(m, d, a, b, c)
        return r[0].copy(), r[1].copy(), r[2].copy()

    def grav_floor(a):
        return grav_d(m, d, a)          # a new array already (Pinocchio returns it by value)

    # the floor of a checked call: the floor plus the tests no checked shortcut can skip
    F64, hypot, isf = np.dtype(np.float64), math.hypot, math.isfinite

    def inv_chk(a, b, c):
        if a.dtype is b.dtype is c.dtype is F64 and hypot(*a.tolist(), *b.tolist(), *c.tolist()) < 1e50:
            r = rnea_d(m, d, a, b, c)
            return r[0].copy(), r[1].copy()

    pd = pivots_positive(m)           # D(q) positive definite at every q: no singular-D test

    def fwd_chk(a, b, c):
        if a.dtype is b.dtype is c.dtype is F64 and hypot(*a.tolist(), *b.tolist(), *c.tolist()) < 1e50:
            r = aba_d(m, d, a, b, c)
            if pd or isf(sum(r[2].diagonal().tolist())):
                return r[0].copy(), r[1].copy(), r[2].copy()

    def grav_chk(a):
        if a.dtype is F64 and hypot(*a.tolist()) < 1e50:
            return grav_d(m, d, a)

    U = P.unchecked

    fns = {
        "inv_floor": lambda: inv_floor(q, qd, qdd),
        "fwd_floor": lambda: fwd_floor(q, qd, tau),
        "grav_floor": lambda: grav_floor(q),
        "inv_chk": lambda: inv_chk(q, qd, qdd),
        "fwd_chk": lambda: fwd_chk(q, qd, tau),
        "grav_chk": lambda: grav_chk(q),
        "inv_unchecked": lambda: U.inverse_dynamics_derivatives(q, qd, qdd),
        "fwd_unchecked": lambda: U.forward_dynamics_derivatives(q, qd, tau),
        "grav_unchecked": lambda: U.gravity_derivative(q),
        "inv": lambda: P.inverse_dynamics_derivatives(q, qd, qdd),
        "inv_raw": lambda: rnea_d(m, d, q, qd, qdd),
        "fwd": lambda: P.forward_dynamics_derivatives(q, qd, tau),
        "fwd_raw": lambda: aba_d(m, d, q, qd, tau),
        "grav": lambda: P.gravity_derivative(q),
        "grav_raw": lambda: grav_d(m, d, q),
        "inv_trace_batch": lambda: L.inverse_dynamics_derivatives(qb, qdb, qddb),
        "fwd_trace_batch": lambda: L.forward_dynamics_derivatives(qb, qdb, taub),
        "grav_trace_batch": lambda: L.gravity_derivative(qb),
    }
    scale = {k: batch for k in fns if k.endswith("_batch")}
    s = interleaved(fns, rounds, target_s, per_call_scale=scale)
    out = {"arm": name, "n": arm.n, "batch": batch, "friction": arm.friction_model is not None}
    for k in ("inv", "fwd", "grav"):
        out[k] = {"manipdyn_us": s[k].median * 1e6, "raw_us": s[k + "_raw"].median * 1e6,
                  "ratio": paired_ratio(s[k], s[k + "_raw"]),
                  "best_ratio": _best(s[k], s[k + "_raw"]),
                  "floor_ratio": _best(s[k + "_floor"], s[k + "_raw"]),
                  "checks_over_floor": _best(s[k], s[k + "_floor"]),
                  "check_floor": _best(s[k + "_chk"], s[k + "_raw"]),
                  "unchecked": _best(s[k + "_unchecked"], s[k + "_raw"]),
                  "trace_per_state_us": s[k + "_trace_batch"].median * 1e6,
                  "trace_ratio": paired_ratio(s[k + "_trace_batch"], s[k + "_raw"])}
        out[k]["target"] = TARGET_FRICTION if (out["friction"] and k != "grav") else TARGET_FAST
        out[k]["verdict"] = verdict(out[k])
    return out


def verdict(row: dict) -> str:
    """``ok``, ``ok (best)``, ``floor`` or ``OVER`` against the row's target (module docstring)."""
    if row["ratio"] <= row["target"]:
        return "ok"
    if row["best_ratio"] <= row["target"]:
        return "ok (best)"
    return "floor" if row.get("check_floor", 0.0) > row["target"] else "OVER"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.bench_derivatives", description=__doc__.split("\n\n")[0])
    p.add_argument("--arms", nargs="+", default=[a for a in DEFAULT_ARMS if a in md.models()])
    p.add_argument("--batch", type=int, default=1000)
    p.add_argument("--rounds", type=int, default=15)
    p.add_argument("--target-s", type=float, default=0.02,
                   help="seconds per timed sample (default 0.02; on a loaded machine 0.001 with "
                        "--rounds 101: short samples are less often interrupted, and the best rounds show it)")
    args = p.parse_args(argv)
    pools = blas_config()
    print(f"BLAS/OpenMP pools: {format_pools(pools) or 'none loaded'}; batch {args.batch}; "
          f"targets: fast path <= {TARGET_FAST}x raw Pinocchio ({TARGET_FRICTION}x for the RNEA and ABA "
          f"derivatives of an arm with a friction law), trace form per state <= {TARGET_BATCH}x "
          f"(moonshot {MOONSHOT_BATCH}x)")
    print(f"{'arm':9s} {'derivative':9s} {'manipdyn us':>11s} {'raw pin us':>10s} {'ratio':>6s} {'best':>6s} "
          f"{'floor':>6s} {'checks':>6s} {'chk.fl':>6s} {'unchk':>6s}  {'trace us/state':>14s} {'trace/raw':>9s} "
          f"{'target':>6s}  verdict")
    for name in args.arms:
        r = measure(name, args.batch, args.rounds, args.target_s)
        for k, label in (("inv", "RNEA"), ("fwd", "ABA"), ("grav", "gravity")):
            x = r[k]
            print(f"{name:9s} {label:9s} {x['manipdyn_us']:11.2f} {x['raw_us']:10.2f} {x['ratio']:6.2f} "
                  f"{x['best_ratio']:6.2f} {x['floor_ratio']:6.2f} {x['checks_over_floor']:6.2f} "
                  f"{x['check_floor']:6.2f} {x['unchecked']:6.2f}  "
                  f"{x['trace_per_state_us']:14.2f} {x['trace_ratio']:9.2f} {x['target']:6.2f}  {x['verdict']}")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
