"""The cost of the single-call fast path over raw Pinocchio, per call (issue 11).

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.fast_path_guards [--arm ur5]

The fast path (``arm.pinocchio.inverse_dynamics`` etc. on one native float64
state) checks its arguments before calling Pinocchio: a big-endian, bool,
integer or masked array must never reach Pinocchio (it would read the bytes
as native doubles and return a wrong answer, or drop the mask).  This prints,
for each method and its raw Pinocchio call on the same state, the median over
interleaved blocks of the per-call ratio (both timed in the same block, so a
busy machine slows both alike), the best per-call times, and the BLAS
configuration.  Nothing is asserted: compare the ratios with an earlier run.

The floor (issue 27, item 27): any API over Pinocchio adds at least one Python
function frame between the caller and the C++ call.  The ``floor`` candidate is
exactly that, a function that does nothing but forward to the raw call, timed in
the same blocks; ``floor ratio`` is its cost over raw Pinocchio, and ``checks``
the checked call over the floor: what the dtype, shape and finiteness checks
themselves cost.  A ratio target below the floor ratio cannot be met by any
checked (or unchecked) Python-level method; the checks own only ``checks - 1``.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from .timing import blas_config


def _block(f, k: int) -> float:
    t = time.perf_counter()
    for _ in range(k):
        f()
    return (time.perf_counter() - t) / k


def measure(arm_name: str = "ur5", blocks: int = 201, calls: int = 200) -> list[tuple]:
    import pinocchio as pin

    import manipdyn as md

    arm = md.load(arm_name)
    P = arm.pinocchio
    m, d = P.model, P.data
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-1, 1, arm.n) for _ in range(3))
    rnea, crba, grav, aba = pin.rnea, pin.crba, pin.computeGeneralizedGravity, pin.aba

    def fwd3(call):
        def floor(a, b, c):
            return call(m, d, a, b, c)
        return floor

    def fwd1(call):
        def floor(a):
            return call(m, d, a)
        return floor

    ND, F64, isf = np.ndarray, np.dtype(np.float64), math.isfinite

    def guard1(call):         # the dtype/shape guard of the fast path, nothing else
        def f(a):
            if type(a) is ND and a.dtype is F64 and a.ndim == 1:
                return call(m, d, a)
        return f

    def finite1(call):        # the finiteness test of the fast path, nothing else
        def f(a):
            r = call(m, d, a)
            if isf(r.item(0) * a.item(0)):
                return r
        return f

    def guard3(call):
        def f(a, b, c):
            if (type(a) is type(b) is type(c) is ND and a.dtype is b.dtype is c.dtype is F64
                    and a.ndim == b.ndim == c.ndim == 1):
                return call(m, d, a, b, c)
        return f

    def finite3(call):
        def f(a, b, c):
            r = call(m, d, a, b, c)
            if isf(r.item(0)):
                return r
        return f

    one, three = (fwd1, guard1, finite1), (fwd3, guard3, finite3)
    U = P.unchecked
    cases = [("inverse_dynamics / rnea", lambda: P.inverse_dynamics(q, qd, qdd), rnea, three, (q, qd, qdd),
              lambda: U.inverse_dynamics(q, qd, qdd)),
             ("mass_matrix / crba", lambda: P.mass_matrix(q), crba, one, (q,), lambda: U.mass_matrix(q)),
             ("gravity_torque / computeGeneralizedGravity", lambda: P.gravity_torque(q), grav, one, (q,),
              lambda: U.gravity_torque(q)),
             ("forward_dynamics / aba", lambda: P.forward_dynamics(q, qd, qdd), aba, three, (q, qd, qdd),
              lambda: U.forward_dynamics(q, qd, qdd)),
             # the arm's own methods (issue 34): one more Python frame than the engine's
             ("arm.inverse_dynamics / rnea", lambda: arm.inverse_dynamics(q, qd, qdd), rnea, three, (q, qd, qdd),
              lambda: U.inverse_dynamics(q, qd, qdd)),
             ("arm.mass_matrix / crba", lambda: arm.mass_matrix(q), crba, one, (q,), lambda: U.mass_matrix(q))]
    out = []
    for label, f, call, makers, x, unchecked in cases:
        fl, gu, fi = (mk(call) for mk in makers)
        cands = {"checked": f, "raw": lambda call=call, x=x: call(m, d, *x), "floor": lambda fl=fl, x=x: fl(*x),
                 "guard": lambda gu=gu, x=x: gu(*x), "finite": lambda fi=fi, x=x: fi(*x), "unchecked": unchecked}
        for _ in range(calls):
            for g in cands.values():
                g()
        t = {k: [] for k in cands}
        for _ in range(blocks):
            for k, g in cands.items():
                t[k].append(_block(g, calls))
        raw = t["raw"]

        def ratio(k, to="raw"):
            # of the best blocks: on a machine shared with other work, a block that ran
            # uninterrupted is the candidate's own cost, and the minimum finds it
            return min(t[k]) / min(t[to])

        out.append((label, statistics.median(a / b for a, b in zip(t["checked"], raw)), min(t["checked"]) * 1e6,
                    min(raw) * 1e6, ratio("checked"), ratio("floor"), ratio("checked", "floor"),
                    ratio("guard", "floor"), ratio("finite", "floor"), ratio("unchecked")))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.fast_path_guards", description=__doc__.split("\n\n")[0])
    p.add_argument("--arm", default="ur5")
    p.add_argument("--blocks", type=int, default=201)
    p.add_argument("--calls", type=int, default=200)
    args = p.parse_args(argv)
    pools = blas_config()
    blas = pools if isinstance(pools, str) else [(i.get("internal_api"), i.get("num_threads")) for i in pools]
    print(f"arm {args.arm}; BLAS/OpenMP pools: {blas or 'none loaded'}")
    print(f"{'manipdyn call / raw Pinocchio':45s} {'median ratio':>12s} {'best us':>9s} {'raw us':>8s} "
          f"{'best ratio':>10s} {'floor':>6s} {'checks':>7s} {'guard':>6s} {'finite':>6s} {'unchecked':>9s}  verdict")
    for label, r, a, b, br, fl, ch, gu, fi, un in measure(args.arm, args.blocks, args.calls):
        print(f"{label:45s} {r:12.3f} {a:9.3f} {b:8.3f} {br:10.3f} {fl:6.3f} {ch:7.3f} {gu:6.3f} {fi:6.3f} "
              f"{un:9.3f}  {verdict(r, br, fl)}")
    print("median ratio: of per-block ratios; best ratio: of the best blocks (what an uninterrupted block "
          "costs; on a shared machine the steadier of the two); floor, checks, guard, finite: best blocks too")
    print("floor: a Python function that only forwards to the raw call, over the raw call (the least "
          "any Python-level API adds); checks: manipdyn's call over that floor; guard, finite: the floor "
          "plus only the dtype/shape guard, or only the finiteness test, over the floor (the two checks "
          "the fast path must make, issue 11)")
    print(f"unchecked: engine.unchecked's call (no checks at all) over raw Pinocchio, best blocks; verdict against "
          f"the goal {GOAL}x (issue 34): ok, ok (best) when only the best blocks meet it, 'floor' when the "
          "floor itself is over the goal (then no checked Python call can meet it: use engine.unchecked), "
          "else OVER")
    return 0


#: the checked single-state calls' goal over raw Pinocchio (issue 34)
GOAL = 1.5


def verdict(median_ratio: float, best_ratio: float, floor_ratio: float) -> str:
    """``ok`` / ``ok (best)`` / ``floor`` / ``OVER`` of one row against :data:`GOAL` (see main's legend)."""
    if median_ratio <= GOAL:
        return "ok"
    if best_ratio <= GOAL:
        return "ok (best)"
    return "floor" if floor_ratio > GOAL else "OVER"


if __name__ == "__main__":
    raise SystemExit(main())
