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
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from .timing import blas_config


def _block(f, k: int) -> float:
    t = time.perf_counter()
    for _ in range(k):
        f()
    return (time.perf_counter() - t) / k


def measure(arm_name: str = "ur5", blocks: int = 41, calls: int = 2000) -> list[tuple]:
    import pinocchio as pin

    import manipdyn as md

    arm = md.load(arm_name)
    P = arm.pinocchio
    m, d = P.model, P.data
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-1, 1, arm.n) for _ in range(3))
    pairs = [
        ("inverse_dynamics / rnea", lambda: P.inverse_dynamics(q, qd, qdd), lambda: pin.rnea(m, d, q, qd, qdd)),
        ("mass_matrix / crba", lambda: P.mass_matrix(q), lambda: pin.crba(m, d, q)),
        ("gravity_torque / computeGeneralizedGravity", lambda: P.gravity_torque(q),
         lambda: pin.computeGeneralizedGravity(m, d, q)),
        ("forward_dynamics / aba", lambda: P.forward_dynamics(q, qd, qdd), lambda: pin.aba(m, d, q, qd, qdd)),
    ]
    out = []
    for label, f, g in pairs:
        for _ in range(calls):
            f()
            g()
        ratios, fs, gs = [], [], []
        for _ in range(blocks):
            a, b = _block(f, calls), _block(g, calls)
            ratios.append(a / b)
            fs.append(a)
            gs.append(b)
        out.append((label, statistics.median(ratios), min(fs) * 1e6, min(gs) * 1e6))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.fast_path_guards", description=__doc__.split("\n\n")[0])
    p.add_argument("--arm", default="ur5")
    args = p.parse_args(argv)
    pools = blas_config()
    blas = pools if isinstance(pools, str) else [(i.get("internal_api"), i.get("num_threads")) for i in pools]
    print(f"arm {args.arm}; BLAS/OpenMP pools: {blas or 'none loaded'}")
    print(f"{'manipdyn call / raw Pinocchio':45s} {'median ratio':>12s} {'best us':>9s} {'raw us':>8s}")
    for label, r, a, b in measure(args.arm):
        print(f"{label:45s} {r:12.3f} {a:9.3f} {b:8.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
