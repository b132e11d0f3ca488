"""``identify`` with its options chosen by held-out error, on 7 joints and 5000 samples: the 60 s bound.

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_identify_options [--samples 5000]

Issue 30 item 3: the Coulomb smoothing is chosen by blocked hold-outs of the fit data
(:mod:`manipdyn.identification.inputs.smoothing`: 5 candidates x 5 folds of the user's
method), then the fit, then the band's 5 refits and the leverage reference.  The log is the
synthetic Panda of :mod:`benchmarks.bench_prior_weight` (a sum of sines, Coulomb and viscous
friction, white noise, 200 Hz), given as Measurements with a velocity noise of 0.005 rad/s so
the search starts where a filtered log would start it.  The whole ``md.identify`` call
(``consistent``, ``viscous,coulomb,offset``) is timed in CPU seconds of this process and in
wall seconds; the test suite checks what the search does, never its time.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import manipdyn as md
from manipdyn.formats.logs.measurements import Measurements

from .bench_prior_weight import panda_log


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=5000, help="samples of the log (default 5000)")
    args = p.parse_args(argv)
    arm, q, qd, qdd, tau = panda_log(args.samples)
    data = Measurements(np.arange(len(q)) / 200.0, q, qd, qdd, tau, source="synthetic panda",
                        qd_noise=np.full(arm.n, 0.005))
    cpu, wall = time.process_time(), time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = md.identify(arm, [data], friction_terms="viscous,coulomb,offset")
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    chosen = r.provenance["options"].get("smoothing")
    tried = ", ".join(f"{row['smoothing']:g}" for row in r.report()["smoothing_selection"])
    print(f"identify (smoothing by held-out error, fit, band), {arm.n} joints, {args.samples} samples: {cpu:.1f} s "
          f"CPU, {wall:.1f} s wall (bound 60 s CPU): {'MEETS' if cpu < 60 else 'MISSES'} the bound; smoothing "
          f"{chosen:g} rad/s of {tried}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
