"""The generated-C engine called from Python, one state at a time, against Pinocchio (issue 46, item 20).

Run, with OpenBLAS's tuning variables unset in that command alone::

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_c_calls [--arm ur5]

``bench_codegen`` times the generated C inside C; this times what a Python user pays:
``arm.engine("c").inverse_dynamics(q, qd, qdd)`` (and ``mass_matrix``,
``forward_dynamics``, ``gravity_torque``) on one native float64 state, against the
same call of ``arm.engine("pinocchio")`` and against the engine's general path
(the class's method: per-argument validation, contiguous copies, numpy's ctypes
addresses, a new output, the path every call took before the shortcuts of
``manipdyn.engines.c.fast``).  Candidates are timed in interleaved rounds
(:func:`benchmarks.timing.interleaved`); reported: the median per call with its
inter-quartile range, and the paired ratios (median over rounds of the per-round
ratio) c / pinocchio and general / shortcut.  The goal (issue 46): under 5 us a
call on the UR5.  Nothing is asserted; the BLAS configuration is recorded (no
candidate uses BLAS).  Results: ``benchmarks/results/runs/<UTC time>-c-calls/``.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

import numpy as np

import manipdyn as md

from .timing import blas_config, interleaved, paired_ratio, publish

METHODS = ("inverse_dynamics", "mass_matrix", "forward_dynamics", "gravity_torque")
ARGS = {"inverse_dynamics": ("q", "qd", "qdd"), "mass_matrix": ("q",), "forward_dynamics": ("q", "qd", "tau"),
        "gravity_torque": ("q",)}
GOAL_US = 5.0


def measure(arm_name: str, rounds: int, target_s: float, seed: int = 0) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        arm = md.load(arm_name)
    c, pin = arm.engine("c"), arm.engine("pinocchio")
    rng = np.random.default_rng(seed)
    q = arm.random_state(rng)
    s = {"q": q, "qd": rng.uniform(-1, 1, arm.n), "qdd": rng.uniform(-1, 1, arm.n)}
    s["tau"] = pin.inverse_dynamics(q, s["qd"], s["qdd"])
    out = {"arm": arm_name, "n": arm.n, "methods": {}}
    for m in METHODS:
        a = [s[k] for k in ARGS[m]]
        cf, pf, gf = getattr(c, m), getattr(pin, m), getattr(type(c), m).__get__(c)
        assert np.array_equal(cf(*a), gf(*a)), m       # the shortcut is the general path's answer
        fns = {"c": lambda cf=cf, a=a: cf(*a), "pinocchio": lambda pf=pf, a=a: pf(*a),
               "c_general": lambda gf=gf, a=a: gf(*a)}
        t = interleaved(fns, rounds, target_s)
        out["methods"][m] = {**{k: v.as_dict() for k, v in t.items()},
                             "ratio_c_to_pinocchio": paired_ratio(t["c"], t["pinocchio"]),
                             "ratio_general_to_c": paired_ratio(t["c_general"], t["c"])}
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.bench_c_calls", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--arm", default="ur5")
    p.add_argument("--rounds", type=int, default=31)
    p.add_argument("--target", type=float, default=0.02, help="seconds of one sample of one candidate")
    p.add_argument("--out", default=None, metavar="DIR")
    p.add_argument("--no-write", action="store_true", help="print only")
    args = p.parse_args(argv)
    from .run import machine_info

    env = machine_info()
    env["blas"] = blas_config()
    env["openblas_env"] = {k: os.environ.get(k) for k in ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")}
    env["loadavg_start"] = list(os.getloadavg())
    res = measure(args.arm, args.rounds, args.target)
    env["loadavg_end"] = list(os.getloadavg())
    print(f"{args.arm}: us per call, median [q25, q75] over {args.rounds} interleaved rounds")
    print(f"{'call':20s} {'c':>18s} {'pinocchio':>18s} {'c general path':>18s} {'c/pin':>6s} {'gen/c':>6s}  goal")
    for m, r in res["methods"].items():
        cell = lambda k: f"{r[k]['median_s'] * 1e6:6.2f} [{r[k]['q25_s'] * 1e6:.2f}, {r[k]['q75_s'] * 1e6:.2f}]"  # noqa: E731
        ok = "met" if r["c"]["median_s"] * 1e6 < GOAL_US else "MISSED"
        print(f"{m:20s} {cell('c'):>18s} {cell('pinocchio'):>18s} {cell('c_general'):>18s} "
              f"{r['ratio_c_to_pinocchio']:6.2f} {r['ratio_general_to_c']:6.2f}  < {GOAL_US:g} us {ok}")
    print(f"OPENBLAS_CORETYPE={env['openblas_env']['OPENBLAS_CORETYPE']} "
          f"OPENBLAS_L2_SIZE={env['openblas_env']['OPENBLAS_L2_SIZE']}; "
          f"load average {env['loadavg_start']} -> {env['loadavg_end']}")
    publish(args, env, {"goal_us": GOAL_US, "rounds": args.rounds, "results": res}, "c-calls")
    return 0


if __name__ == "__main__":
    sys.exit(main())
