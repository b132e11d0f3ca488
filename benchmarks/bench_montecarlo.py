"""Benchmark of the Monte-Carlo path: single calls, one simulation, a study, and its scaling.

Four parts, in one run:

1. **Per-call ratios** (issue 14, item 5) on a 6-DOF arm (UR5 and Puma 560):
   ``arm.pinocchio.inverse_dynamics`` and ``arm.pinocchio.mass_matrix`` (the
   checked fast path) and ``arm.pinocchio.unchecked`` against raw ``pin.rnea`` / ``pin.crba`` on
   the same model, timed in interleaved rounds (benchmarks/timing.py).  Two
   call sites: from a Python loop (each candidate called by Python code, as in
   a control loop: what a user pays) and through ``functools.partial`` (no
   Python caller: the raw call has no frame around it at all, the strictest
   comparison).  Targets: checked <= 1.3x, unchecked <= 1.1x.
2. **One simulation against the base revision** (item 4): a plain loop of
   ``md.simulate`` (Puma 560, four demo controllers, 1 s at 1 kHz, a 1 kg
   payload) with this tree and with ``--against REV`` (exported with ``git
   archive``), alternately, each in its own process.
3. **A local study against the plain loop** (item 4's target, <= 0.5x per run): the
   same ``--runs`` runs x 4 controllers as a plain Python loop of
   ``md.simulate`` (controllers built once, each run's plant and start from
   ``study.setup``: exactly the study's work, in one process) and as a study on
   a local Dask cluster of 2 workers (started beforehand; its start-up is
   reported apart).  The study steps the runs of a chunk together
   (manipdyn/control/montecarlo/lockstep.py), each run's numbers bit for bit those of
   ``md.simulate`` alone: both answers must agree exactly.
4. **Scaling with local workers** (1, 2): study throughput (simulations per second).

BLAS configuration (threadpoolctl) and the machine are recorded.  Run with
``OPENBLAS_CORETYPE`` and ``OPENBLAS_L2_SIZE`` unset in that command alone::

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_montecarlo [--runs 200]
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

from benchmarks.report import format_pools
import manipdyn as md
from manipdyn import montecarlo as mc

from .timing import blas_config

from manipdyn._support.files import atomic_write_text
from manipdyn.check.scale import local_cores

from .timing import interleaved, paired_ratio

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CHECKED_TARGET, UNCHECKED_TARGET, STUDY_TARGET = 1.3, 1.1, 0.5


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


# -- 1. per-call ratios ------------------------------------------------------------------
def _looped(fn, *args, reps=100):
    """A Python function calling ``fn(*args)`` ``reps`` times (a Python call site)."""
    if len(args) == 1:
        def run(fn=fn, a=args[0]):
            for _ in range(reps):
                fn(a)
    elif len(args) == 3:
        def run(fn=fn, a=args[0], b=args[1], c=args[2]):
            for _ in range(reps):
                fn(a, b, c)
    else:
        def run(fn=fn, args=args):
            for _ in range(reps):
                fn(*args)
    return run


def per_call(rounds: int) -> dict:
    import pinocchio as pin

    out = {}
    for name in ("ur5", "puma560"):
        arm = _load(name)
        eng = arm.pinocchio
        m, d = eng.model, eng.data
        rng = np.random.default_rng(0)
        q, qd, qdd = arm.random_state(rng), rng.uniform(-1, 1, arm.n), rng.uniform(-1, 1, arm.n)
        # answers first: a fast wrong answer never counts
        np.testing.assert_array_equal(eng.inverse_dynamics(q, qd, qdd), pin.rnea(m, d, q, qd, qdd))
        np.testing.assert_array_equal(eng.unchecked.inverse_dynamics(q, qd, qdd), pin.rnea(m, d, q, qd, qdd))
        np.testing.assert_array_equal(eng.mass_matrix(q), pin.crba(m, d, q))
        np.testing.assert_array_equal(eng.unchecked.mass_matrix(q), pin.crba(m, d, q))
        P = functools.partial
        rnea_raw, crba_raw = P(pin.rnea, m, d), P(pin.crba, m, d)   # model and data bound, like the engine
        cands = {
            "loop rnea raw": _looped(pin.rnea, m, d, q, qd, qdd),
            "loop rnea checked": _looped(eng.inverse_dynamics, q, qd, qdd),
            "loop rnea unchecked": _looped(eng.unchecked.inverse_dynamics, q, qd, qdd),
            "loop crba raw": _looped(pin.crba, m, d, q),
            "loop crba checked": _looped(eng.mass_matrix, q),
            "loop crba unchecked": _looped(eng.unchecked.mass_matrix, q),
            "partial rnea raw": P(rnea_raw, q, qd, qdd),
            "partial rnea checked": P(eng.inverse_dynamics, q, qd, qdd),
            "partial rnea unchecked": P(eng.unchecked.inverse_dynamics, q, qd, qdd),
            "partial crba raw": P(crba_raw, q),
            "partial crba checked": P(eng.mass_matrix, q),
            "partial crba unchecked": P(eng.unchecked.mass_matrix, q),
        }
        scale = {k: (100 if k.startswith("loop") else 1) for k in cands}
        s = interleaved(cands, rounds=rounds, target_s=0.02, per_call_scale=scale)
        res = {}
        for site in ("loop", "partial"):
            for call in ("rnea", "crba"):
                raw = s[f"{site} {call} raw"]
                res[f"{site} {call}"] = {
                    "raw_us": raw.median * 1e6,
                    "checked_ratio": paired_ratio(s[f"{site} {call} checked"], raw),
                    "unchecked_ratio": paired_ratio(s[f"{site} {call} unchecked"], raw)}
        out[name] = res
    return out


# -- 2. one simulation against a base revision -------------------------------------------
_LOOP = r"""
import json, sys, time, warnings
import numpy as np
import manipdyn as md
from manipdyn.control import with_payload
try:
    from manipdyn.control.demo import demo_path, make_controller
except ImportError:
    from manipdyn.control.cli import demo_path, make_controller
warnings.simplefilter("ignore")
arm = md.load("puma560")
plant = with_payload(arm, 1.0, com=(0.0, 0.0, 0.1))
duration, runs = float(sys.argv[1]), int(sys.argv[2])
path = demo_path(arm, duration)
ctrls = [make_controller(k, arm) for k in ("pd", "pdg", "ct", "adaptive")]
md.simulate(arm, ctrls[2], path, 0.2, plant=plant)        # warm-up
t = time.perf_counter()
err = []
for _ in range(runs):
    for c in ctrls:
        err.append(float(np.abs(md.simulate(arm, c, path, duration, plant=plant).e).max()))
print(json.dumps({"seconds": time.perf_counter() - t, "sims": 4 * runs, "max_error": err[:4]}))
"""


def against(rev: str, duration: float, runs: int, repeat: int) -> dict:
    with tempfile.TemporaryDirectory() as base:
        arch = subprocess.run(["git", "-C", ROOT, "archive", rev, "manipdyn"], check=True, capture_output=True)
        subprocess.run(["tar", "-x", "-C", base], input=arch.stdout, check=True)
        trees = {"this tree": ROOT, f"base {rev}": base}
        times = {k: [] for k in trees}
        answers = {}
        for _ in range(repeat):
            for label, tree in trees.items():
                env = dict(os.environ, PYTHONPATH=tree)
                r = subprocess.run([sys.executable, "-c", _LOOP, str(duration), str(runs)], env=env,
                                   cwd=tempfile.gettempdir(), check=True, capture_output=True, text=True)
                doc = json.loads(r.stdout)
                times[label].append(doc["seconds"] / doc["sims"])
                answers[label] = doc["max_error"]
    med = {k: statistics.median(v) for k, v in times.items()}
    here, base_label = "this tree", f"base {rev}"
    # the two trees evaluate the reference differently (vectorised vs per step): same answer to rounding
    np.testing.assert_allclose(answers[here], answers[base_label], rtol=1e-6)
    return {"ms_per_simulation": {k: v * 1e3 for k, v in med.items()},
            "ratio": med[here] / med[base_label], "duration_s": duration}


# -- 3 and 4. a study against the plain loop, and scaling ------------------------------------
def plain_loop(study) -> tuple[float, list]:
    """The study's runs one after another in this process: ``run_one`` is
    ``md.simulate(**study.setup(run, key).simulate_kwargs())`` plus the run's figures."""
    from manipdyn.control.montecarlo.study import run_one

    cache = {k: study.controller(k) for k in study.controllers}
    study.plant(0)                                          # warm-up: arm, path
    t = time.perf_counter()
    recs = []
    for run in range(study.runs):
        for key in study.controllers:
            recs.append(run_one(study, run, key, cache))    # md.simulate(**study.setup(run, key)) + figures
    return time.perf_counter() - t, recs


def study_on(study, workers: int) -> tuple[float, float, object]:
    """(wall s of the study, start-up s, report) on a fresh local cluster of ``workers``.

    Start-up is the cluster's start plus a warm-up study (each worker imports
    manipdyn and Pinocchio and rebuilds the arm once): paid once per cluster,
    reported apart from the study's own time.
    """
    import logging

    import distributed

    t0 = time.perf_counter()
    cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.ERROR)
    warm = mc.Study(study.model, 2 * workers, study.seed, study.controllers, 10 * study.dt, study.dt)
    mc.run(warm, scheduler=cluster.scheduler_address, chunk_size=1)
    startup = time.perf_counter() - t0
    try:
        t = time.perf_counter()
        report = mc.run(study, scheduler=cluster.scheduler_address)
        wall = time.perf_counter() - t
    finally:
        cluster.close()
    return wall, startup, report


def _spin(_):
    """A fixed amount of pure-Python work (the parallelism probe)."""
    s = 0
    for i in range(3_000_000):
        s += i
    return s


def parallelism_probe() -> float:
    """What this machine gives two processes right now: the speed-up of 2 over 1 on pure CPU work.

    2.0 on two idle cores; less when other processes hold them.  The study's
    scaling is to be read against it (measured just before and after).
    """
    import multiprocessing as mpc

    ctx = mpc.get_context("spawn")
    times = {}
    for procs in (1, 2):
        with ctx.Pool(procs) as pool:
            pool.map(_spin, range(procs))          # start-up and imports, untimed
            t = time.perf_counter()
            pool.map(_spin, range(4))
            times[procs] = time.perf_counter() - t
    return times[1] / times[2]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=200, help="runs of the study (default 200)")
    p.add_argument("--duration", type=float, default=1.0, help="simulated seconds per run (default 1)")
    p.add_argument("--rounds", type=int, default=21, help="rounds of the per-call timing (default 21)")
    p.add_argument("--against", default=None, metavar="REV",
                   help="base revision for the one-simulation comparison (default: the merge base "
                        "with main; '' to skip)")
    p.add_argument("--out", default=os.path.join(ROOT, "benchmarks", "results", "runs", "montecarlo_latest.json"),
                   help="results file (default: benchmarks/results/runs/montecarlo_latest.json, ignored by git)")
    p.add_argument("--publish", action="store_true",
                   help="also rewrite the committed reference benchmarks/results/montecarlo_reference.json")
    args = p.parse_args(argv)
    env_note = {k: os.environ.get(k) for k in ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")}
    result = {"machine": {"platform": platform.platform(), "python": platform.python_version(),
                          "cpus": local_cores(), "blas": blas_config(), "env": env_note,
                          "load_average_at_start": os.getloadavg()}}

    print("1. per-call ratios against raw Pinocchio (median of paired ratios)")
    calls = per_call(args.rounds)
    result["per_call"] = calls
    for arm, res in calls.items():
        for key, r in res.items():
            print(f"  {arm:<8} {key:<13} raw {r['raw_us']:5.2f} us   checked {r['checked_ratio']:.2f}x "
                  f"(target {CHECKED_TARGET})   unchecked {r['unchecked_ratio']:.2f}x (target {UNCHECKED_TARGET})")

    if args.against is None:
        r = subprocess.run(["git", "-C", ROOT, "merge-base", "HEAD", "main"], capture_output=True, text=True)
        args.against = r.stdout.strip()[:12] if r.returncode == 0 else ""
    if args.against:
        print(f"2. one simulation: plain md.simulate loop, this tree against {args.against}")
        a = against(args.against, args.duration, 3, 3)
        result["simulate_vs_base"] = a
        for k, v in a["ms_per_simulation"].items():
            print(f"  {k:<16} {v:7.1f} ms per simulation ({args.duration:g} s at 1 kHz)")
        print(f"  ratio {a['ratio']:.2f}x")

    arm = _load("puma560")
    study = mc.study(arm, runs=args.runs, seed=1, duration=args.duration)
    sims = args.runs * len(study.controllers)
    print(f"3. {args.runs}-run study ({sims} simulations of {args.duration:g} s) against the plain loop")
    loop_s, loop_recs = plain_loop(study)
    scaling = {}
    probe_before = parallelism_probe()
    for workers in (1, 2):
        wall, startup, report = study_on(study, workers)
        assert report.per_run == loop_recs, "the study and the plain loop disagree"
        scaling[workers] = {"wall_s": wall, "cluster_startup_s": startup, "sims_per_s": sims / wall,
                            "ms_per_simulation": 1e3 * wall / sims, "ratio_to_plain_loop": wall / loop_s}
    probe_after = parallelism_probe()
    two = scaling[2]
    result["study"] = {"runs": args.runs, "simulations": sims, "duration_s": args.duration,
                       "plain_loop_s": loop_s, "plain_loop_ms_per_simulation": 1e3 * loop_s / sims,
                       "study_2_workers_ratio": two["wall_s"] / loop_s,
                       "study_2_workers_ratio_with_startup": (two["wall_s"] + two["cluster_startup_s"]) / loop_s,
                       "workers": scaling,
                       "machine_parallelism_2_over_1": [probe_before, probe_after]}
    st = result["study"]
    print(f"  plain loop      {loop_s:7.2f} s  ({st['plain_loop_ms_per_simulation']:.1f} ms per simulation)")
    print(f"  study, 2 workers {two['wall_s']:6.2f} s  -> {st['study_2_workers_ratio']:.2f}x the loop "
          f"(target {STUDY_TARGET}); with the cluster start-up and warm-up ({two['cluster_startup_s']:.1f} s): "
          f"{st['study_2_workers_ratio_with_startup']:.2f}x")
    print("4. scaling with local workers (machine's own 2-process speed-up on pure CPU work, "
          f"probed before and after: {probe_before:.2f}x, {probe_after:.2f}x)")
    for w, r in scaling.items():
        print(f"  {w} worker(s): {r['sims_per_s']:6.1f} simulations/s ({r['ms_per_simulation']:.1f} ms each), "
              f"speed-up {r['sims_per_s'] / scaling[1]['sims_per_s']:.2f}x; "
              f"{r['ratio_to_plain_loop']:.2f}x the plain loop's time")
    result["machine"]["load_average_at_end"] = os.getloadavg()
    print(f"load average (1, 5, 15 min): {result['machine']['load_average_at_start']} at the start, "
          f"{result['machine']['load_average_at_end']} at the end (other work on this machine)")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    atomic_write_text(args.out, json.dumps(result, indent=2) + "\n")
    if args.publish:
        atomic_write_text(os.path.join(ROOT, "benchmarks", "results", "montecarlo_reference.json"),
                          json.dumps(result, indent=2) + "\n")
    print(f"BLAS: {format_pools(result['machine']['blas'])}")
    print(f"results written to {os.path.relpath(args.out, ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
