"""``--prior-weight auto`` on 7 joints and 5000 samples: the issue's bound of 60 s, measured.

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_prior_weight [--samples 5000]

The log is synthetic: the bundled Panda driven by a sum of sines (seeded), with Coulomb and
viscous friction and white torque noise, 200 Hz.  The blocked cross-validation of
:func:`manipdyn.identification.estimation.selection.choose_prior_weight` (5 weights x 5 folds) is timed
in CPU seconds of this process (all its threads: the algorithm's cost) and in wall seconds
(what a user waits on this machine).  Measured while writing it: 72 s CPU before the folds
shared their base parameters, regressor and QR factors, 22 s after.  The test suite checks
the sharing itself (tests/test_identification_traps.py), never the time.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import manipdyn as md


def panda_log(N: int = 5000, rate: float = 200.0, seed: int = 0):
    """``(arm, q, qd, qdd, tau)``: N samples of the bundled Panda at ``rate`` Hz (SI units)."""
    arm = md.load("panda")
    t = np.arange(N) / rate
    rng = np.random.default_rng(seed)
    n = arm.n
    f = rng.uniform(0.1, 0.5, (3, n))
    ph = rng.uniform(0, 2 * np.pi, (3, n))
    w = 2 * np.pi * f
    a = 0.4 / 3
    q = sum(a * np.sin(w[k] * t[:, None] + ph[k]) for k in range(3)) + np.asarray(arm.qlim).mean(axis=1)
    qd = sum(a * w[k] * np.cos(w[k] * t[:, None] + ph[k]) for k in range(3))
    qdd = sum(-a * w[k] ** 2 * np.sin(w[k] * t[:, None] + ph[k]) for k in range(3))
    tau = arm.inverse_dynamics(q, qd, qdd) + 0.3 * np.sign(qd) + 0.1 * qd
    tau = tau + rng.normal(scale=0.05, size=tau.shape)
    return arm, q, qd, qdd, tau


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=5000, help="samples of the log (default 5000)")
    args = p.parse_args(argv)
    from manipdyn.identification.estimation.selection import choose_prior_weight

    arm, q, qd, qdd, tau = panda_log(args.samples)
    cpu, wall = time.process_time(), time.perf_counter()
    choice = choose_prior_weight(arm, q, qd, qdd, tau, friction=md.FrictionTerms(("viscous", "coulomb", "offset")))
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    print(f"prior weight auto, {arm.n} joints, {args.samples} samples: {cpu:.1f} s CPU, {wall:.1f} s wall "
          f"(bound 60 s): {'MEETS' if cpu < 60 else 'MISSES'} the bound; chose {choice!r:.80}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
