"""Benchmark of torque constants from currents (issue 24, item 2): k_t per motor against the truth.

Run, with OpenBLAS's tuning variables unset in that command alone::

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_torque_constants

Per seed (``--seeds``), :func:`manipdyn.identification.experiments.hardlog.hard_log_set` writes two
30 s current logs of the hard log's arm (coupled wrist, a negative gear ratio, rotor
inertias, motor-side viscous, asymmetric Coulomb and Stribeck friction, offsets, 16-bit
encoders, jittered, dropped and duplicated stamps, 1 % torque noise): one bare, one carrying
a known 2.8 kg payload, listed in a RUNS.toml.  ``md.identify`` then runs as the README's
command does (``--identify-torque-constants --armature --friction-terms
viscous,asymmetric,offset,stribeck --friction-side motor --smoothing 2 --stribeck-velocity 5
--method wls``) in two ways:

* ``payload``: the prior has no torque constants; the scale comes from the payload run;
* ``model``: the bare run only, the scale from the prior's k_t of motor 1.

Recorded: each motor's k_t relative error against the truth, its reported standard
deviation (relative), the worst over the motors (target: 2 %), and the wall time.  Results
are printed and written, atomically, to
``benchmarks/results/runs/<UTC time>-torque_constants/results.json`` (or ``--out DIR``).
"""

from __future__ import annotations

import os
import sys
import time
import warnings

import numpy as np

import manipdyn as md
from benchmarks.bench_identification import environment
from benchmarks.timing import publish, seeded_runs
from manipdyn.identification.experiments.hardlog import SMOOTHING, hard_log_set

#: the README's options for the hard log (motor-side law, Stribeck shapes by variable projection)
OPTIONS = dict(identify_torque_constants=True, armature=True, friction_terms="viscous,asymmetric,offset,stribeck",
               friction_side="motor", smoothing=SMOOTHING, stribeck_velocity=5.0, method="wls")


def run_seed(seed: int, folder: str) -> dict:
    """Write one log set and identify its torque constants both ways."""
    s = hard_log_set(seed, folder)
    out = {"seed": seed}
    for mode, prior, logs, extra in (("payload", s["prior"], s["runs"], {}),
                                     ("model", s["prior_kt"], os.path.join(folder, "run1.csv"),
                                      {"torque_constant_reference": [1]})):
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
            r = md.identify(prior, logs, **OPTIONS, **extra)
        tc = r.torque_constants
        err = tc.values / s["torque_constant"] - 1.0
        out[mode] = {"relative_error": err.tolist(), "relative_std": (tc.std / tc.values).tolist(),
                     "worst": float(np.max(np.abs(err))), "seconds": time.perf_counter() - t0}
    return out


def main(argv=None) -> int:
    env = environment()
    args, runs = seeded_runs("python -m benchmarks.bench_torque_constants", __doc__, "torque_constants", run_seed, argv)
    env["loadavg_end"] = list(os.getloadavg())
    for r in runs:
        for mode in ("payload", "model"):
            m = r[mode]
            print(f"seed {r['seed']}, scale from the {mode}: k_t error per motor "
                  + " ".join(f"{100 * e:+.2f}" for e in m["relative_error"]) + " %  (std "
                  + " ".join(f"{100 * e:.2f}" for e in m["relative_std"]) + f" %); worst {100 * m['worst']:.2f} % "
                  f"(target 2 %), {m['seconds']:.0f} s")
    print(f"BLAS: {env['blas']}; load average {env['loadavg_start']} -> {env['loadavg_end']}")
    publish(args, env, {"runs": runs}, "torque_constants")
    return 0


if __name__ == "__main__":
    sys.exit(main())
