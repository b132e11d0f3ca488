"""Benchmark of the consistent fit's compiled programs (issue 46 item 19): CPU seconds per fit, cached and not.

Run, with OpenBLAS's tuning variables unset in that command alone::

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_dpp

A Panda (7 joints, viscous, Coulomb and offset friction) on a 6 s excitation at 100 Hz with 0.05 N m
of torque noise, fitted ``consistent`` (plausible bounds) on ``--folds`` slices of the data, as the
smoothing choice and the band's refits do: once through the programs compiled per structure
(:mod:`manipdyn.identification.estimation.programs`, cvxpy's DPP) and once with them built afresh
for every solve (the path before), in interleaved rounds.  CPU seconds (``time.process_time``) per fit,
median over ``--rounds``, and their ratio; the first cached round pays the compilation.  Before the
timings count, the two paths' predicted torques are checked to agree to 1e-5 of the torque's scale
(the solver's accuracy on the residual's flat bottom: tests/test_sdp_programs.py).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings

import numpy as np

import manipdyn as md
from manipdyn._support.threads import blas_threads
from manipdyn.identification import excitation
from manipdyn.identification.estimation import fitting, programs


def _data(seed: int):
    arm = md.load("panda")
    ex = excitation(arm, duration=6.0, harmonics=3, rate=100.0, iterations=0, seed=seed)
    rng = np.random.default_rng(seed)
    tau = (arm.inverse_dynamics(ex.q, ex.qd, ex.qdd) + 0.3 * np.tanh(ex.qd / 0.05) + 0.2 * ex.qd
           + 0.05 * rng.standard_normal(ex.q.shape))
    return arm, ex.q, ex.qd, ex.qdd, tau


def _fits(data, folds: int, cached: bool):
    """``(CPU seconds per fit, the fits)`` of ``folds`` fits, each leaving out one block of the samples."""
    arm, q, qd, qdd, tau = data
    law = md.FrictionTerms(terms=("viscous", "coulomb", "offset"), smoothing=0.05)
    edges = np.linspace(0, len(q), folds + 1).astype(int)
    out = []
    t = time.process_time()
    for k in range(folds):
        keep = np.ones(len(q), bool)
        keep[edges[k]:edges[k + 1]] = False
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if cached:
                r = fitting.fit(arm, q[keep], qd[keep], qdd[keep], tau[keep], method="consistent", friction=law,
                                complete=False)
            else:
                with programs.uncached():
                    r = fitting.fit(arm, q[keep], qd[keep], qdd[keep], tau[keep], method="consistent",
                                    friction=law, complete=False)
        out.append(r)
    return (time.process_time() - t) / folds, out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--folds", type=int, default=5, help="fits per round (default 5)")
    p.add_argument("--rounds", type=int, default=3, help="interleaved rounds (default 3)")
    p.add_argument("--seed", type=int, default=2)
    p.add_argument("--json", metavar="FILE", help="also write the results as JSON")
    a = p.parse_args(argv)
    data = _data(a.seed)
    arm, q, qd, qdd, tau = data
    cached, fresh = [], []
    with blas_threads(1):
        programs.clear_cache()
        for _ in range(a.rounds):
            s, fits_c = _fits(data, a.folds, True)
            cached.append(s)
            s, fits_f = _fits(data, a.folds, False)
            fresh.append(s)
    worst = max(float(np.abs(c.predict(q, qd, qdd) - f.predict(q, qd, qdd)).max()) for c, f in zip(fits_c, fits_f))
    scale = float(np.abs(tau).max())
    if not worst <= 1e-5 * scale:
        print(f"bench_dpp: the cached and fresh fits disagree by {worst:.3g} N m ({worst / scale:.2g} of the "
              "torque's scale): no timing reported", file=sys.stderr)
        return 2
    res = {"folds": a.folds, "rounds": a.rounds, "cpu_per_fit_cached": cached, "cpu_per_fit_fresh": fresh,
           "median_cached": float(np.median(cached)), "median_fresh": float(np.median(fresh)),
           "ratio": float(np.median(fresh) / np.median(cached)), "torque_difference": worst,
           "cache": programs.cache_info(), "loadavg": list(__import__("os").getloadavg())}
    print(f"consistent fit, Panda, {a.folds} folds x {a.rounds} rounds (CPU s per fit, median): "
          f"programs compiled once {res['median_cached']:.3f}, built afresh {res['median_fresh']:.3f}, "
          f"ratio {res['ratio']:.2f}x; first cached round (compiling) {cached[0]:.3f}; "
          f"predictions agree to {worst:.2g} N m; load {res['loadavg'][0]:.1f}")
    if a.json:
        from benchmarks.timing import write_atomic

        write_atomic(a.json, json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
