"""``identify`` on the three KUKA LWR4+ runs with friction: the issue's bound of 120 s of CPU, measured.

    python -m benchmarks.bench_trust_runs [--data ../shared/realdata/lwr4_flobaroid]

The real logs (``run1.csv`` to ``run3.csv``, 5027 samples each at 200 Hz, beside the project in
``../shared/realdata/lwr4_flobaroid``; never copied into it) and the vendor route: prior
``kuka_lwr4_gaz.urdf``, ``friction_terms="viscous,coulomb,offset"``, nothing else hand-set.  That run
does the most work ``identify`` does on several logs: the repeats found (runs 1 and 2), the Coulomb
smoothing by held-out trajectories (five candidates, a refit per trajectory each), the consistent fit,
the band's blocked hold-outs (five refits) and held-out trajectories (one refit per trajectory).
Then the collision thresholds that ``manipdyn identify`` writes by default (issue 39): the band's
held-out trajectories, each run read again nearly raw and watched by the momentum observer of the
band's refit (:func:`manipdyn.control.collision.holdouts.identified_thresholds`, no refit of its own),
timed apart and added to the total the bound applies to.
Timed in CPU seconds of this process (all its threads) and in wall seconds.  Measured while writing it
(issue 37): see the report of that branch; the test suite never checks a time.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from benchmarks.realdata import lwr4_dir

DEFAULT = lwr4_dir()
BOUND = 120.0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", type=Path, default=DEFAULT, help="the folder of run1.csv .. run3.csv and the URDFs")
    args = p.parse_args(argv)
    runs = [args.data / f"run{k}.csv" for k in (1, 2, 3)]
    prior = args.data / "kuka_lwr4_gaz.urdf"
    if not prior.is_file() or not all(r.is_file() for r in runs):
        print(f"skipped: the LWR4 logs are not at {args.data} (--data to point at them)")
        return 0
    import manipdyn as md

    cpu, wall = time.process_time(), time.perf_counter()
    r = md.identify(str(prior), [str(x) for x in runs], friction_terms="viscous,coulomb,offset")
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    from manipdyn.control.collision.holdouts import identified_thresholds

    t_cpu = time.process_time()
    thr = identified_thresholds(r, [str(x) for x in runs])
    t_cpu = time.process_time() - t_cpu
    band = r.provenance.get("prediction_band", {})
    total = cpu + t_cpu
    print(f"identify, LWR4, 3 runs x 5027 samples, viscous + Coulomb + offset: {cpu:.1f} s CPU, {wall:.1f} s wall, "
          f"and {t_cpu:.1f} s CPU for the collision thresholds ({thr.source.split(',')[0]}); {total:.1f} s CPU in "
          f"all (bound {BOUND:g} s CPU): {'MEETS' if total < BOUND else 'MISSES'} the bound; band from "
          f"{band.get('trajectories', 1)} held-out trajectories, smoothing {r.provenance['options'].get('smoothing')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
