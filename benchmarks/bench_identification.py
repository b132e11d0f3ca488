"""Benchmark of identification: the regressor two ways, and the three fits.

Run, with OpenBLAS's tuning variables unset in that command alone::

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_identification

1. The regressor per state: the trace-form regressor on a batch of 1000 states
   (``arm.lagrange.regressor``, vectorised) against Pinocchio's
   ``computeJointTorqueRegressor`` called in a Python loop over the same states
   (``arm.pinocchio.regressor``), timed in interleaved rounds (benchmarks/timing.py);
   the ratio is the median of the per-round ratios.  Before timing, the two are
   checked to agree to 1e-9 relative (a fast wrong answer never counts).
2. Identifying a 7-DOF arm (Panda prior, perturbed true arm, friction on) from
   10^4 samples with 1 % torque noise: wall time of ``fit`` (base parameters
   included) per method, median of ``--repeats`` runs, and the ratio to ``ols``
   measured in the same rounds; each with the BLAS thread pools as found and
   limited to one thread (threadpoolctl), in interleaved rounds.

The BLAS configuration (threadpoolctl) and the load average are recorded.
Results are printed and written, atomically, to
``benchmarks/results/runs/<UTC time>-identification/results.json`` (ignored by
git; or ``--out DIR``); ``--publish`` also rewrites the committed reference
``benchmarks/results/identification_reference.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import manipdyn as md
from benchmarks.timing import blas_config, interleaved, paired_ratio, write_atomic, write_run
from manipdyn.identification import excitation, fit
from manipdyn.identification.experiments.demo import measure, true_arm

RESULTS = Path(__file__).resolve().parent / "results"
REFERENCE = RESULTS / "identification_reference.json"


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


def environment() -> dict:
    """Versions, BLAS threading (threadpoolctl) and the load average."""
    import cvxpy
    import pinocchio
    import scipy

    return {
        "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
        "cvxpy": cvxpy.__version__, "pinocchio": pinocchio.__version__,
        "blas": blas_config(),
        "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE"),
        "OPENBLAS_L2_SIZE": os.environ.get("OPENBLAS_L2_SIZE"),
        "cpus": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
        "loadavg_start": list(os.getloadavg()),
    }


def bench_regressor(names, batch: int, rounds: int) -> list:
    out = []
    for name in names:
        arm = _load(name)
        rng = np.random.default_rng(0)
        q = arm.random_state(rng, batch)
        qd = rng.uniform(-2, 2, q.shape)
        qdd = rng.uniform(-5, 5, q.shape)
        L, P = arm.lagrange, arm.pinocchio
        YL, YP = L.regressor(q, qd, qdd), P.regressor(q, qd, qdd)
        rel = float(np.max(np.abs(YL - YP)) / max(1.0, float(np.abs(YP).max())))
        assert rel <= 1e-9, f"{name}: regressors disagree ({rel:.3g})"
        s = interleaved({"lagrange_batch": lambda: L.regressor(q, qd, qdd),
                         "pinocchio_loop": lambda: P.regressor(q, qd, qdd)},
                        rounds=rounds, target_s=0.2, max_number=50,
                        per_call_scale={"lagrange_batch": batch, "pinocchio_loop": batch})
        out.append({"arm": name, "n": arm.n, "batch": batch, "max_rel_diff": rel,
                    "lagrange_us_per_state": s["lagrange_batch"].median * 1e6,
                    "pinocchio_us_per_state": s["pinocchio_loop"].median * 1e6,
                    "ratio_lagrange_over_pinocchio": paired_ratio(s["lagrange_batch"], s["pinocchio_loop"])})
    return out


def bench_fit(name: str, samples: int, repeats: int) -> dict:
    prior = _load(name)
    truth = true_arm(prior, seed=0)
    rate = 200.0
    trim = 2 * int(np.ceil(3 * rate / 5.0))             # what the zero-phase derivatives drop
    duration = (samples + trim) / rate
    traj = excitation(prior, duration=duration, harmonics=5, rate=rate, iterations=0, friction=True)
    data, _, _ = measure(truth, traj, np.random.default_rng(0))
    from threadpoolctl import threadpool_limits

    methods = ("ols", "wls", "consistent")
    # each method with the BLAS thread pools as they are, and limited to one thread
    # (on a loaded machine multi-threaded OpenBLAS can be many times slower)
    cases = [(m, t) for t in ("default", "1") for m in methods]
    times = {c: [] for c in cases}
    info = {}
    for r in range(repeats):
        order = cases[r % len(cases):] + cases[:r % len(cases)]
        for m, threads in order:
            with threadpool_limits(None if threads == "default" else 1):
                t0 = time.perf_counter()
                res = fit(prior, data.q, data.qd, data.qdd, data.tau, method=m, friction=True)
                times[(m, threads)].append(time.perf_counter() - t0)
            info[m] = {"consistent": res.consistent, "n_base": res.base.count,
                       "solver": res.report["solver"]}
    out = {"arm": name, "n": prior.n, "samples": len(data), "repeats": repeats, "methods": {}}
    for m in methods:
        row = dict(info[m])
        for threads in ("default", "1"):
            v = np.array(times[(m, threads)])
            ref = np.array(times[("ols", threads)])
            row[f"blas_threads_{threads}"] = {"median_s": float(np.median(v)),
                                              "ratio_to_ols": float(np.median(v / ref))}
        out["methods"][m] = row
    return out




def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.bench_identification", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--arms", nargs="+", default=["puma560", "panda"], help="arms of the regressor benchmark")
    p.add_argument("--batch", type=int, default=1000)
    p.add_argument("--rounds", type=int, default=15)
    p.add_argument("--fit-arm", default="panda")
    p.add_argument("--samples", type=int, default=10_000)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", default=None, metavar="DIR",
                   help="folder of results.json (default benchmarks/results/runs/<UTC time>-identification)")
    p.add_argument("--publish", action="store_true", help="also rewrite the committed reference results")
    p.add_argument("--no-write", action="store_true", help="print only")
    args = p.parse_args(argv)
    env = environment()
    reg = bench_regressor(args.arms, args.batch, args.rounds)
    fits = bench_fit(args.fit_arm, args.samples, args.repeats)
    env["loadavg_end"] = list(os.getloadavg())
    result = {"environment": env, "regressor": reg, "fit": fits}
    print("regressor per state (batch of %d), median us:" % args.batch)
    for r in reg:
        print(f"  {r['arm']:<10} n={r['n']}  trace form (batch) {r['lagrange_us_per_state']:8.2f}   "
              f"Pinocchio (loop) {r['pinocchio_us_per_state']:8.2f}   ratio {r['ratio_lagrange_over_pinocchio']:.2f}"
              f"   (agree to {r['max_rel_diff']:.1e})")
    print(f"identify {fits['arm']} ({fits['n']} DOF) from {fits['samples']} samples, friction on, "
          f"median of {fits['repeats']}:")
    for m, v in fits["methods"].items():
        d, o = v["blas_threads_default"], v["blas_threads_1"]
        print(f"  {m:<11} {d['median_s']:7.3f} s (x{d['ratio_to_ols']:.2f} of ols)   one BLAS thread "
              f"{o['median_s']:7.3f} s (x{o['ratio_to_ols']:.2f})   (consistent: {v['consistent']}, {v['solver']})")
    print(f"BLAS: {env['blas']}; load average {env['loadavg_start']} -> {env['loadavg_end']}")
    if not args.no_write:
        text = json.dumps(result, indent=2) + "\n"
        path = write_run(text, "identification", args.out)
        print(f"wrote {path}")
        if args.publish:
            write_atomic(REFERENCE, text)
            print(f"wrote {REFERENCE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
