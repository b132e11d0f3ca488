"""What ``f_tool=None`` costs the arm's single-state calls (issue 31, item 17).

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.f_tool_overhead [--arm ur5]

``arm.inverse_dynamics`` and ``arm.forward_dynamics`` took a tool wrench ``f_tool`` (default
None).  This times each against a bound method with the body they had before (the engine
looked up, the call forwarded), in interleaved blocks, and a copy of that old body against
itself as the control: the control's ratio is what the machine's noise alone gives.  Nothing
is asserted; compare the ratios with the control.
"""

from __future__ import annotations

import argparse
import statistics
import time
import types

import numpy as np


def _block(f, args, k: int) -> float:
    t = time.perf_counter()
    for _ in range(k):
        f(*args)
    return (time.perf_counter() - t) / k


def _old(method: str):
    def call(self, a, b, c):
        eng = self._engines.get("pinocchio") or self.engine("pinocchio")
        return getattr(eng, method)(a, b, c)
    return call


def measure(arm_name: str = "ur5", blocks: int = 301, calls: int = 2000) -> list[tuple]:
    import manipdyn as md

    arm = md.load(arm_name)
    rng = np.random.default_rng(0)
    x = tuple(rng.uniform(-1, 1, arm.n) for _ in range(3))
    old_id, old_fd = (types.MethodType(_old(m), arm) for m in ("inverse_dynamics", "forward_dynamics"))
    copy_id = types.MethodType(_old("inverse_dynamics"), arm)
    cases = [("inverse_dynamics", arm.inverse_dynamics, old_id), ("forward_dynamics", arm.forward_dynamics, old_fd),
             ("control: old body / its copy", copy_id, old_id)]
    out = []
    for label, new, old in cases:
        r, bn, bo = [], [], []
        for _ in range(blocks):
            n, o = _block(new, x, calls), _block(old, x, calls)
            r.append(n / o)
            bn.append(n)
            bo.append(o)
        out.append((label, statistics.median(r), min(bn) * 1e9, min(bo) * 1e9))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.f_tool_overhead", description=__doc__.split("\n\n")[0])
    p.add_argument("--arm", default="ur5", help="bundled arm (default ur5)")
    p.add_argument("--blocks", type=int, default=301, help="interleaved blocks (default 301)")
    p.add_argument("--calls", type=int, default=2000, help="calls per block (default 2000)")
    args = p.parse_args(argv)
    print(f"{'call (f_tool=None) / the old body':34s} {'median ratio':>12s} {'best ns':>9s} {'old ns':>8s}")
    for label, r, a, b in measure(args.arm, args.blocks, args.calls):
        print(f"{label:34s} {r:12.4f} {a:9.0f} {b:8.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
