"""The batch path's threads on a shared machine (issue 27, item 26).

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_batch_threads [--states 20000] [--load 0 1]

``arm.pinocchio.inverse_dynamics`` on a batch of ``--states`` UR5 states runs on
Pinocchio's thread pool (``rneaInParallel``).  A thread that has to share its core
with another process makes the whole batch wait for it, so on a loaded machine the
parallel batch can be slower than one thread, and under heavier load faster again.
The engine now times its batches and runs each on the faster of one thread and all
of them (:class:`manipdyn.engines.pinocchio.engine.ThreadChoice`), unless a thread count
was given.

For each ``--load K`` this starts ``K`` busy processes (pure Python spin loops, on
top of whatever else the machine runs), then times, interleaved in rounds (load
hits every candidate alike), per state:

* ``one thread``: an engine built with ``num_threads=1``;
* ``all cores``: ``num_threads`` = the cores (the old default, regardless of load);
* ``auto``: the default engine (``arm.pinocchio``), which chooses per batch;
* ``python loop``: ``pin.rnea`` per state in a Python loop.

The claim is ``auto <= one thread`` (within the rounds' spread) under load, and
``auto ~ all cores`` when cores are free.  Medians of per-round times and the best
round's are both printed: under heavy outside load the medians of candidates that
run the same code differ by tens of percent, and the best rounds are the steadier.  ``/proc/loadavg`` is recorded before and
after each case: on a machine shared with others "quiet" means "as found", and the
record says how quiet that was.  Results: printed, and written to
``benchmarks/results/runs/<UTC time>-batch-threads/results.json`` (``--publish``:
also ``benchmarks/results/batch_threads_reference.json``).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import sys
import time
from pathlib import Path

import numpy as np

from .timing import blas_config, interleaved, paired_ratio, write_atomic, write_run

REFERENCE = Path(__file__).resolve().parent / "results" / "batch_threads_reference.json"


def _spin(stop) -> None:
    x = 0
    while not stop.is_set():
        for _ in range(10000):
            x += 1


def _loadavg() -> str:
    try:
        with open("/proc/loadavg") as f:
            return f.read().strip()
    except OSError:
        return "unavailable"


def measure(states: int, load: int, rounds: int, target_s: float = 0.05) -> dict:
    import pinocchio as pin

    import manipdyn as md
    from manipdyn.engines.pinocchio.engine import PinocchioEngine

    arm = md.load("ur5")
    auto = PinocchioEngine(arm.pinocchio.model.copy())       # the default: chooses by measurement
    cores = auto.num_threads                              # the CPUs available, at most 8
    one = PinocchioEngine(auto.model.copy(), num_threads=1)
    every = PinocchioEngine(auto.model.copy(), num_threads=cores)
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-1, 1, (states, arm.n)) for _ in range(3))
    ref = one.inverse_dynamics(q, qd, qdd)
    for eng in (every, auto):
        if not np.array_equal(eng.inverse_dynamics(q, qd, qdd), ref):
            raise SystemExit("!!! WRONG ANSWER: the batch differs with the thread count")
    m, d = auto.model, auto.data
    qs, vs, as_ = list(q), list(qd), list(qdd)

    def loop():
        for a, b, c in zip(qs, vs, as_):
            pin.rnea(m, d, a, b, c)

    stop = mp.Event()
    procs = [mp.Process(target=_spin, args=(stop,), daemon=True) for _ in range(load)]
    for p in procs:
        p.start()
    try:
        time.sleep(1.0 if load else 0.0)                      # let the spinners be scheduled
        before = _loadavg()
        fns = {"one thread": lambda: one.inverse_dynamics(q, qd, qdd),
               "all cores": lambda: every.inverse_dynamics(q, qd, qdd),
               "auto": lambda: auto.inverse_dynamics(q, qd, qdd),
               "python loop": loop}
        s = interleaved(fns, rounds, target_s, per_call_scale={k: states for k in fns})
        after = _loadavg()
    finally:
        stop.set()
        for p in procs:
            p.join(5)
    return {"load_processes": load, "states": states, "cores": cores, "loadavg_before": before,
            "loadavg_after": after,
            "auto_cost_us_per_state": {str(k): v * 1e6 for k, v in auto.thread_choice.cost.items()},
            "us_per_state": {k: v.median * 1e6 for k, v in s.items()},
            "us_per_state_iqr": {k: v.iqr * 1e6 for k, v in s.items()},
            "us_per_state_best": {k: float(np.min(v.times)) * 1e6 for k, v in s.items()},
            "auto_over_one_thread": paired_ratio(s["auto"], s["one thread"]),
            "all_cores_over_one_thread": paired_ratio(s["all cores"], s["one thread"]),
            "best_auto_over_one_thread": float(np.min(s["auto"].times) / np.min(s["one thread"].times)),
            "best_all_cores_over_one_thread": float(np.min(s["all cores"].times) / np.min(s["one thread"].times))}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.bench_batch_threads", description=__doc__.split("\n\n")[0])
    p.add_argument("--states", type=int, default=20_000)
    p.add_argument("--load", type=int, nargs="+", default=[0, 1], help="busy processes to add, one case each")
    p.add_argument("--rounds", type=int, default=15)
    p.add_argument("--out", default=None, metavar="DIR")
    p.add_argument("--publish", action="store_true", help="also rewrite " + str(REFERENCE.name))
    p.add_argument("--no-write", action="store_true", help="print only")
    args = p.parse_args(argv)
    pools = blas_config()
    blas = pools if isinstance(pools, str) else [(i.get("internal_api"), i.get("num_threads")) for i in pools]
    print(f"UR5 inverse dynamics, batch of {args.states} states, us per state (median of {args.rounds} "
          f"interleaved rounds); BLAS/OpenMP pools: {blas or 'none loaded'}")
    cases = []
    for load in args.load:
        r = measure(args.states, load, args.rounds)
        cases.append(r)
        t = r["us_per_state"]
        print(f"+{load} busy process(es); /proc/loadavg {r['loadavg_before']} -> {r['loadavg_after']}; "
              f"auto's measured cost per state (us) by threads: "
              + ", ".join(f"{k}: {v:.3f}" for k, v in r["auto_cost_us_per_state"].items()))
        print("  median: " + "   ".join(f"{k} {v:.3f}" for k, v in t.items())
              + f"   auto/one {r['auto_over_one_thread']:.2f}, all cores/one {r['all_cores_over_one_thread']:.2f}")
        print("  best:   " + "   ".join(f"{k} {v:.3f}" for k, v in r["us_per_state_best"].items())
              + f"   auto/one {r['best_auto_over_one_thread']:.2f}, all cores/one "
                f"{r['best_all_cores_over_one_thread']:.2f}")
        sys.stdout.flush()
    result = {"environment": {"python": sys.version.split()[0], "pid_cpus": len(os.sched_getaffinity(0))
                              if hasattr(os, "sched_getaffinity") else os.cpu_count(), "blas": blas},
              "cases": cases}
    if not args.no_write:
        text = json.dumps(result, indent=2) + "\n"
        print(f"wrote {write_run(text, 'batch-threads', args.out)}")
        if args.publish:
            write_atomic(REFERENCE, text)
            print(f"wrote {REFERENCE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
