"""Benchmark of ``manipdyn excite``'s work: ``excitation(...)`` at the CLI's defaults.

Run, with OpenBLAS's tuning variables unset in that command alone::

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_excite

For each arm (default: the bundled panda, 7 DOF, and ur5, 6 DOF) it times
``excitation(arm, duration=10, harmonics=5, rate=100, seed=0, iterations=60)``
(manipdyn/cli/excite.py's defaults) ``--repeats`` times, recording the wall
time (median), the process CPU time (less sensitive to other processes on a
shared machine), the number of objective evaluations and the condition number.
The base parameters are computed once outside the timed region (the CLI
computes them too: about 0.1 s) and passed in.

The answer is checked before it counts: the condition number is finite and
no worse than the unoptimised start's (iterations=0), and the limits hold on
a dense resampling of the trajectory (20 001 points per period), not only at
the samples.  A failed check exits 2.

The BLAS configuration (threadpoolctl) and the load average are recorded.
Results are printed and written, atomically, to
``benchmarks/results/runs/<UTC time>-excite/results.json`` (ignored by git;
or ``--out DIR``).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import warnings

import numpy as np

import manipdyn as md
from benchmarks.timing import blas_config, publish
from manipdyn.identification import base_parameters, excitation
from manipdyn.identification.experiments import trajectory as _trajectory

#: manipdyn/cli/excite.py's defaults
CLI_DEFAULTS = dict(duration=10.0, harmonics=5, rate=100.0, seed=0, iterations=60)


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)




def check(arm, ex, start) -> list[str]:
    """What is wrong with the excitation ``ex`` (empty when it is right)."""
    problems = []
    if not np.isfinite(ex.condition_number):
        problems.append("condition number is not finite")
    if ex.condition_number > start.condition_number:
        problems.append(f"condition number {ex.condition_number:.4g} worse than the start's "
                        f"{start.condition_number:.4g}")
    q, qd, qdd = ex.sample(np.linspace(0.0, ex.period, 20001))
    vmax, amax, lo, hi = _trajectory.motion_limits(arm, None, None, 0.05)
    if np.any(q < lo) or np.any(q > hi):
        problems.append("joint limits (with the 5 % margin) violated between samples")
    if np.any(np.abs(qd) > vmax) or np.any(np.abs(qdd) > amax):
        problems.append("velocity or acceleration limits violated between samples")
    return problems


def bench_arm(name: str, repeats: int) -> dict:
    arm = _load(name)
    base = base_parameters(arm)
    arm.pinocchio                                           # engines built outside the timing
    arm.lagrange
    start = excitation(arm, **{**CLI_DEFAULTS, "iterations": 0}, base=base)
    evals = [0]
    inner = _trajectory._log_cond_and_grad

    def counted(*a, **k):
        evals[0] += 1
        return inner(*a, **k)

    walls, cpus, ex = [], [], None
    _trajectory._log_cond_and_grad = counted
    try:
        for _ in range(repeats):
            evals[0] = 0
            w, c = time.perf_counter(), time.process_time()
            ex = excitation(arm, **CLI_DEFAULTS, base=base)
            walls.append(time.perf_counter() - w)
            cpus.append(time.process_time() - c)
    finally:
        _trajectory._log_cond_and_grad = inner
    return {"arm": name, "n": arm.n, "n_base": ex.n_base, "wall_s": walls,
            "median_wall_s": float(np.median(walls)), "median_cpu_s": float(np.median(cpus)),
            "objective_evaluations": evals[0], "condition_number": ex.condition_number,
            "start_condition_number": start.condition_number, "problems": check(arm, ex, start)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.bench_excite", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--arms", nargs="+", default=["panda", "ur5"])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", default=None, metavar="DIR",
                   help="folder of results.json (default benchmarks/results/runs/<UTC time>-excite)")
    p.add_argument("--no-write", action="store_true", help="print only")
    args = p.parse_args(argv)
    env = {"python": platform.python_version(), "numpy": np.__version__, "blas": blas_config(),
           "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE"),
           "OPENBLAS_L2_SIZE": os.environ.get("OPENBLAS_L2_SIZE"),
           "loadavg_start": list(os.getloadavg()), "defaults": CLI_DEFAULTS}
    rows = [bench_arm(name, args.repeats) for name in args.arms]
    env["loadavg_end"] = list(os.getloadavg())
    print(f"excitation at the CLI defaults {CLI_DEFAULTS}:")
    for r in rows:
        print(f"  {r['arm']:<8} n={r['n']}  wall {r['median_wall_s']:6.2f} s  cpu {r['median_cpu_s']:6.2f} s  "
              f"{r['objective_evaluations']} evaluations  condition number {r['condition_number']:.4g} "
              f"(start {r['start_condition_number']:.4g})")
        for prob in r["problems"]:
            print(f"  !!! WRONG ANSWER ({r['arm']}): {prob}", file=sys.stderr)
    print(f"load average {env['loadavg_start']} -> {env['loadavg_end']}")
    publish(args, env, {"results": rows}, "excite")
    return 2 if any(r["problems"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
