"""Benchmark of the closed-loop simulation: 10 s of the Puma 560 at 1 kHz.

``manipdyn.simulate`` with fixed-step RK4 (four forward-dynamics calls per step,
Pinocchio's ABA through ``arm.forward_dynamics``) and the controller called once
per step (zero-order hold).  Times the whole run (wall clock, median of
``--repeat`` runs after one warm-up; the process's CPU time is printed too, as
it is less disturbed by other load on the machine), per controller:

* computed torque (one RNEA call per step), the target case:
  **10 s at 1 kHz in under 2 s**;
* PD + gravity, and the Slotine-Li adaptive controller (two joint-torque
  regressor calls per step), for comparison.

The path is the CLI's demo path (``manipdyn track``) on the Puma 560 as
bundled (rotor inertias included).  Every run's answer is checked before its
time counts: with a perfect model, computed torque must track within 1e-3 rad
(its residual is the sampling, ~ jerk dt / (2 Kp) ~ 1e-4 rad on this path at
Kp = 100 1/s^2, see tests/test_control.py; a wrong model shows at 1e-2 and
more), and every controller's log must be finite.

Usage::

    python benchmarks/bench_simulate.py [--duration 10] [--dt 0.001] [--repeat 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings

import numpy as np

import manipdyn as md
from manipdyn.control.demo import demo_path, make_controller

TARGET_S = 2.0          # for 10 s of computed torque at 1 kHz
CT_MAX_ERROR = 1e-3     # rad, perfect model, bandwidth 10 rad/s (module docstring)


def run(arm, kind, path, duration, dt):
    """(wall s, CPU s of this process, log): CPU time is what the run costs on a busy machine."""
    ctrl = make_controller(kind, arm)
    t0, c0 = time.perf_counter(), time.process_time()
    log = md.simulate(arm, ctrl, path, duration, dt=dt)
    return time.perf_counter() - t0, time.process_time() - c0, log


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--duration", type=float, default=10.0, help="simulated seconds (default 10)")
    p.add_argument("--dt", type=float, default=1e-3, help="step, s (default 0.001)")
    p.add_argument("--repeat", type=int, default=3, help="timed runs per controller (default 3)")
    args = p.parse_args(argv)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        arm = md.load("puma560")
    path = demo_path(arm, args.duration)
    steps = int(round(args.duration / args.dt))
    print(f"Puma 560, demo path, {args.duration:g} s at {1 / args.dt:g} Hz: {steps} RK4 steps, "
          f"{4 * steps} forward-dynamics calls")
    run(arm, "ct", path, min(args.duration, 0.5), args.dt)         # warm-up
    ok = True
    for kind in ("ct", "pdg", "adaptive"):
        times, cpu, log = [], [], None
        for _ in range(args.repeat):
            t, c, log = run(arm, kind, path, args.duration, args.dt)
            times.append(t)
            cpu.append(c)
        finite = all(np.all(np.isfinite(x)) for x in (log.q, log.qd, log.tau))
        err = float(np.abs(log.e).max())
        med = statistics.median(times)
        line = (f"  {log.controller:<24} {med:6.3f} s wall (min {min(times):.3f}, max {max(times):.3f}), "
                f"{statistics.median(cpu):6.3f} s CPU  {med / steps * 1e6:6.1f} us/step  max |e| {err:.2e} rad")
        if kind == "ct":
            right = finite and err <= CT_MAX_ERROR
            fast = med * (10.0 / args.duration) * (args.dt / 1e-3) <= TARGET_S
            line += f"  [{'ok' if right else 'WRONG ANSWER'}; target < {TARGET_S:g} s per 10 s at 1 kHz: " \
                    f"{'met' if fast else 'MISSED'}]"
            ok = ok and right and fast
        elif not finite:
            line += "  [WRONG ANSWER: non-finite log]"
            ok = False
        print(line)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
