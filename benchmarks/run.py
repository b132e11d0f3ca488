"""manipdyn benchmark suite.

    python -m benchmarks.run            # full suite (~2 minutes on 2 cores)
    python -m benchmarks.run --smoke    # a few seconds, tiny sizes (what the test runs)

Every run writes ``results.json`` and ``results.md`` (atomically) and
``scaling.png`` (when matplotlib is installed) into its own folder,
``benchmarks/results/runs/<UTC time>-<mode>/`` (ignored by git), or into
``--out DIR``.  The committed reference results,
``benchmarks/results/reference.json`` and ``reference.md``, change only with
``--publish`` (a full run).  ``--strict`` (or ``--check-targets``) makes a missed target exit 1.
See benchmarks/README.md for what is measured and the targets.  This module runs the sections and
writes the results; the checks are :mod:`benchmarks.checks`, the scaling study :mod:`benchmarks.scaling`,
the targets and their verdicts :mod:`benchmarks.targets`.

Every answer is checked before it is timed: the fast path (Pinocchio), raw
Pinocchio, the trace-form engine, and the Robotics Toolbox are compared with
an independent energy-based referee (benchmarks/referee.py) at random
states.  A wrong answer aborts that row loudly.  Exit status: 2 if one of
manipdyn's own engines was wrong (or bad options), 1 with ``--strict``
if a target was missed, else 0.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import functools
import json
import math
import os
import platform
import sys
import time
import warnings
from dataclasses import dataclass

import numpy as np

import manipdyn as md
from manipdyn._support.files import atomic_write_text

from . import arm_set as bench_arms_mod
from . import report, rtb_adapter
from .cases import ARGS, IMPLS, OPS
from .checks import implementations, log, loud, run_checks, states
from .scaling import SCALING_SERIES, run_scaling  # noqa: F401  (SCALING_SERIES: the series a run reports)
from .targets import TARGETS, evaluate_targets  # noqa: F401  (TARGETS: the targets a run is held to)
from .timing import blas_config, interleaved, loop_overhead, paired_ratio

SCHEMA = "manipdyn-bench/1"


HERE = os.path.dirname(os.path.abspath(__file__))


RESULTS = os.path.join(HERE, "results")


#: where runs go by default: one folder per run, ignored by git
RUNS = os.path.join(RESULTS, "runs")


#: the published reference results (committed; rewritten only by --publish)
REFERENCE = ("reference.json", "reference.md")


@dataclass
class Config:
    mode: str
    check_states: int
    rounds: int
    target_s: float
    lagrange_batch: int
    batch_sizes: tuple   # ((N, ops), ...); the first is the one the targets use
    batch_rounds: int
    threads: tuple
    scaling_n: tuple
    scaling_rounds: int
    scaling_target_s: float
    scaling_batch: int
    profile_calls: int


FULL = Config(mode="full", check_states=3, rounds=21, target_s=4e-3, lagrange_batch=1000,
              batch_sizes=((100_000, ("inverse_dynamics", "forward_dynamics")), (2_000, ("inverse_dynamics",))),
              batch_rounds=5, threads=(1, 2),
              scaling_n=(2, 3, 4, 6, 8, 12, 16, 20, 24), scaling_rounds=9, scaling_target_s=2e-3,
              scaling_batch=1000, profile_calls=20_000)


SMOKE = Config(mode="smoke", check_states=1, rounds=3, target_s=2e-4, lagrange_batch=16,
               batch_sizes=((500, ("inverse_dynamics", "forward_dynamics")),), batch_rounds=2, threads=(1, 2),
               scaling_n=(2, 3, 4), scaling_rounds=3, scaling_target_s=2e-4,
               scaling_batch=8, profile_calls=200)


def machine_info():
    import pinocchio as pin

    cpu, detail = "unknown", None
    try:
        info = {}
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if not line.strip():
                    break  # the first processor is enough
                k, _, v = line.partition(":")
                info[k.strip()] = v.strip()
        cpu = info.get("model name", cpu)
        flags = set(info.get("flags", "").split())
        detail = (f"family {info.get('cpu family')} model {info.get('model')} stepping {info.get('stepping')}, "
                  f"{info.get('cpu MHz', '?')} MHz, cache {info.get('cache size', '?')}, "
                  + "/".join(f for f in ("avx2", "avx512f") if f in flags)
                  + (", under a hypervisor" if "hypervisor" in flags else ""))
    except OSError:
        cpu = platform.processor() or "unknown"
    mem = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemTotal"):
                    mem = round(int(line.split()[1]) / 1024**2, 1)
    except OSError:
        pass
    blas = None
    try:
        blas = np.show_config(mode="dicts")["Build Dependencies"]["blas"].get("name")
    except Exception:
        pass
    try:
        import matplotlib
        mpl = matplotlib.__version__
    except Exception:
        mpl = None
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "blas_config": blas_config(),
        "cpu": cpu, "cpu_detail": detail, "cores": cores, "memory_gib": mem, "platform": platform.platform(),
        "python": platform.python_version(), "numpy": np.__version__, "pinocchio": pin.__version__,
        "manipdyn": md.__version__, "roboticstoolbox": rtb_adapter.version(), "matplotlib": mpl,
        "blas": blas, "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE"),
        "OPENBLAS_L2_SIZE": os.environ.get("OPENBLAS_L2_SIZE"),
        "loadavg_start": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
    }


def run_per_call(bench, robots, wrong, cfg, rng):
    log("== 2. per-call times (interleaved rounds; median [IQR], microseconds)")
    rows, ratios, aborted = [], [], []
    for arm in bench:
        robot = robots.get(arm.name)
        impls = implementations(arm, robot)
        one = {k: v[0] for k, v in states(arm, rng, 1).items()}
        B = states(arm, rng, cfg.lagrange_batch)
        for op in OPS:
            fns, scale = {}, {}
            for impl in IMPLS:
                f = impls.get(impl, {}).get(op)
                if f is None:
                    continue
                if (impl, op) in wrong.get(arm.name, set()):
                    aborted.append({"arm": arm.name, "op": op, "impl": impl,
                                    "reason": "wrong answer in the checks"})
                    continue
                if impl == "lagrange_batch":
                    args = tuple(B[a] for a in ARGS[op])
                    scale[impl] = cfg.lagrange_batch
                else:
                    args = tuple(one[a] for a in ARGS[op])
                fns[impl] = functools.partial(f, *args)
            res = interleaved(fns, cfg.rounds, cfg.target_s, per_call_scale=scale)
            for impl, s in res.items():
                rows.append({"arm": arm.name, "op": op, "impl": impl, **s.as_dict(),
                             **({"batch": cfg.lagrange_batch} if impl == "lagrange_batch" else {})})
            for num, den in (("manipdyn", "pinocchio"), ("rtb", "manipdyn"), ("lagrange_batch", "pinocchio"),
                             ("lagrange", "manipdyn"), ("rtb_Cqd", "manipdyn")):
                if num in res and den in res:
                    ratios.append({"arm": arm.name, "op": op, "num": num, "den": den,
                                   "ratio": paired_ratio(res[num], res[den])})
            med = "  ".join(f"{k}={res[k].median * 1e6:.2f}" for k in res)
            log(f"   {arm.name:<9} {op:<17} {med}")
    return rows, ratios, aborted


def _set_threads(engine, k):
    """Set ``num_threads``; work around a pool created smaller (manipdyn bug, see README)."""
    engine.num_threads = k
    pool = getattr(engine, "_pool", None)
    if pool is not None and pool.size() < k:
        engine._pool = None


def run_batch(bench, cfg, rng):
    import pinocchio as pin

    log("== 3. batch throughput, N = " + " and ".join(str(N) for N, _ in cfg.batch_sizes) + " states (states/s)")
    rows, ratios = [], []
    for i, (N, ops) in enumerate(cfg.batch_sizes):
        # the extra, smaller batch sizes only on the first arm (time budget)
        for arm in (bench if i == 0 else bench[:1]):
            r, q = _batch_one(pin, arm, N, ops, cfg, rng)
            rows += r
            ratios += q
    return rows, ratios


def _batch_one(pin, arm, N, ops, cfg, rng):
    rows, ratios = [], []
    eng = arm.pinocchio
    default_threads = eng.num_threads
    S = states(arm, rng, N)
    m, d = eng.model, eng.model.createData()
    n = arm.n
    for op in ops:
        third, single = ("qdd", pin.rnea) if op == "inverse_dynamics" else ("tau", pin.aba)
        parallel = pin.rneaInParallel if op == "inverse_dynamics" else pin.abaInParallel
        Q, QD, X = S["q"], S["qd"], S[third]
        call = getattr(arm, op)

        def loop(single=single, Q=Q, QD=QD, X=X):
            out = np.empty((N, n))
            for i in range(N):
                out[i] = single(m, d, Q[i], QD[i], X[i])
            return out

        fns = {"python_loop": loop}
        _set_threads(eng, max(cfg.threads))
        for k in cfg.threads:
            def batch(k=k, call=call, Q=Q, QD=QD, X=X):
                _set_threads(eng, k)
                return call(Q, QD, X)
            fns[f"manipdyn_{k}t"] = batch
        # the same Pinocchio call without manipdyn's wrapper: isolates the wrapper's cost
        pool = pin.ModelPool(m, max(cfg.threads))
        QT, QDT, XT = Q.T, QD.T, X.T
        for k in cfg.threads:
            fns[f"pinocchio_{k}t"] = (lambda k=k, parallel=parallel, QT=QT, QDT=QDT, XT=XT:
                                      parallel(k, pool, QT, QDT, XT))
        # correctness first: each batch configuration against the loop
        m_chk = min(N, 2000)
        want = np.array([single(m, d, Q[i], QD[i], X[i]) for i in range(m_chk)])
        for k in cfg.threads:
            _set_threads(eng, k)
            for name, got in ((f"manipdyn_{k}t", call(Q[:m_chk], QD[:m_chk], X[:m_chk])),
                              (f"pinocchio_{k}t", parallel(k, pool, QT[:, :m_chk], QDT[:, :m_chk], XT[:, :m_chk]).T)):
                err = float(np.abs(got - want).max() / max(np.abs(want).max(), 1e-9))
                if not err <= 1e-9:
                    peer = (f"manipdyn's batch call, {k} thread(s)" if name.startswith("manipdyn")
                            else f"raw Pinocchio's ModelPool, {k} thread(s)")
                    loud(f"WRONG ANSWER ({peer}) batch {arm.name} {op}: relative error {err:.2e} against "
                         "the one-state loop of raw Pinocchio; run aborted")
                    raise SystemExit(2)
        if N >= 20_000:
            res = interleaved(fns, cfg.batch_rounds, 0.0, max_number=1, subtract_overhead=False)
        else:
            res = interleaved(fns, 3 * cfg.batch_rounds, 0.02, subtract_overhead=False)
        _set_threads(eng, default_threads)
        for impl, s in res.items():
            rows.append({"arm": arm.name, "op": op, "impl": impl, "N": N,
                         "threads": int(impl.split("_")[1][:-1]) if impl != "python_loop" else 1,
                         "states_per_s": N / s.median, **s.as_dict()})
        for k in cfg.threads:
            ratios.append({"arm": arm.name, "op": op, "N": N, "threads": k,
                           "default_threads": k == default_threads,
                           "speedup_vs_loop": paired_ratio(res["python_loop"], res[f"manipdyn_{k}t"]),
                           "raw_speedup_vs_loop": paired_ratio(res["python_loop"], res[f"pinocchio_{k}t"])})
        log(f"   N={N:<7} {arm.name:<9} {op:<17} " + "  ".join(
            f"{k}={N / s.median:,.0f}/s" for k, s in res.items()))
    eng.num_threads = default_threads
    return rows, ratios


def parse_args(argv):
    p = argparse.ArgumentParser(prog="python -m benchmarks.run", description=__doc__.split("\n\n")[0])
    p.add_argument("--smoke", action="store_true", help="a few seconds, tiny sizes (checks the code runs)")
    p.add_argument("--out", default=None,
                   help="output folder (default: a new benchmarks/results/runs/<UTC time>-<mode>/, ignored by git)")
    p.add_argument("--publish", action="store_true",
                   help="also rewrite the committed reference results benchmarks/results/reference.{json,md} "
                        "(full runs only)")
    p.add_argument("--strict", "--check-targets", dest="check_targets", action="store_true",
                   help="exit 1 when a performance target is missed (default: report it, exit 0); "
                        "--check-targets is the older name")
    p.add_argument("--arms", nargs="*", default=None,
                   help="bundled arms to time (default: puma560 stanford, and ur5 ur10 if bundled; "
                        "smoke: puma560)")
    p.add_argument("--no-rtb", action="store_true", help="leave the Robotics Toolbox out")
    p.add_argument("--no-plot", action="store_true", help="do not write scaling.png")
    p.add_argument("--skip", nargs="*", default=(), choices=("per-call", "batch", "scaling"),
                   help="sections to leave out")
    p.add_argument("--seed", type=int, default=2024)
    return p.parse_args(argv)


def main(argv=None):
    """Run the suite; Ctrl-C stops it quietly with exit 130 and removes the run's folder
    when this run created it (a folder given with --out that existed is left as it was,
    less the files this run had written into it)."""
    args = parse_args(sys.argv[1:] if argv is None else argv)
    cfg = SMOKE if args.smoke else FULL
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0)
    out_dir = os.path.abspath(args.out or os.path.join(RUNS, f"{now:%Y%m%dT%H%M%SZ}-{cfg.mode}"))
    existed = os.path.isdir(out_dir)
    before = set(os.listdir(out_dir)) if existed else set()
    try:
        return _main(args, argv, cfg, now, out_dir)
    except KeyboardInterrupt:
        import shutil

        if not existed:
            shutil.rmtree(out_dir, ignore_errors=True)
        elif os.path.isdir(out_dir):
            for name in set(os.listdir(out_dir)) - before:
                path = os.path.join(out_dir, name)
                shutil.rmtree(path, ignore_errors=True) if os.path.isdir(path) else os.remove(path)
        print("benchmarks.run: interrupted; nothing written", file=sys.stderr)
        return 130


def _main(args, argv, cfg, now, out_dir):
    if args.publish and (args.smoke or args.arms or args.skip):
        print("benchmarks.run: error: --publish needs a full run (no --smoke, --arms or --skip)",
              file=sys.stderr)
        return 2
    started = now.isoformat()
    os.makedirs(out_dir, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    t_start = time.perf_counter()

    skipped = []
    if args.no_rtb:
        rtb_reason = "left out (--no-rtb)"
    else:
        _, rtb_reason = rtb_adapter.toolbox()
    machine = machine_info()
    log(f"manipdyn benchmark ({cfg.mode}) on {machine['cpu']}, {machine['cores']} cores, numpy "
        f"{machine['numpy']}, pinocchio {machine['pinocchio']}, Toolbox {machine['roboticstoolbox'] or '-'}")
    loop_overhead()

    names = args.arms if args.arms else (["puma560"] if args.smoke else None)
    bench, sk = bench_arms_mod.bench_arms(names)
    skipped += [{"what": f"arm {n}", "reason": r} for n, r in sk]
    probes = bench_arms_mod.probe_arms()
    robots = {}
    if rtb_reason:
        skipped.append({"what": "Robotics Toolbox rows and targets T3/T4", "reason": rtb_reason})
        log(f"   Toolbox rows skipped: {rtb_reason}")
    else:
        for arm in bench + probes:
            robots[arm.name] = rtb_adapter.dhrobot(arm)

    sections = {}
    t0 = time.perf_counter()
    checks, wrong = run_checks(bench, probes, robots, cfg, rng)
    sections["checks"] = time.perf_counter() - t0
    per_call, pc_ratios, aborted = ([], [], [])
    batch, b_ratios = [], []
    scaling = None
    if "per-call" not in args.skip:
        t0 = time.perf_counter()
        per_call, pc_ratios, aborted = run_per_call(bench, robots, wrong, cfg, rng)
        sections["per_call"] = time.perf_counter() - t0
    if "batch" not in args.skip:
        t0 = time.perf_counter()
        batch, b_ratios = run_batch(bench, cfg, rng)
        sections["batch"] = time.perf_counter() - t0
    if "scaling" not in args.skip:
        t0 = time.perf_counter()
        scaling = run_scaling(cfg, rng, out_dir, plot=not args.no_plot)
        sections["scaling"] = time.perf_counter() - t0
    log("== 5. targets")
    t0 = time.perf_counter()
    targets = evaluate_targets(pc_ratios, b_ratios, rtb_reason, cfg, bench, rng)
    sections["targets_and_profiles"] = time.perf_counter() - t0
    machine["loadavg_end"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None

    results = {
        "schema": SCHEMA, "mode": cfg.mode, "started": started,
        "command": "python -m benchmarks.run" + (" " + " ".join(argv if argv is not None else sys.argv[1:])).rstrip(),
        "duration_s": None, "machine": machine, "config": cfg.__dict__,
        "arms": [{"name": a.name, "n": a.n, "convention": a.convention,
                  "joints": "".join("R" if t == "revolute" else "P" for t in a.joint_types)} for a in bench],
        "probe_arms": [{"name": a.name, "n": a.n, "convention": a.convention,
                        "joints": "".join("R" if t == "revolute" else "P" for t in a.joint_types),
                        "gravity": [float(v) for v in a.gravity]} for a in probes],
        "rtb": {"available": rtb_reason is None, "version": rtb_adapter.version(), "reason": rtb_reason},
        "skipped": skipped, "checks": checks, "per_call": per_call, "per_call_ratios": pc_ratios,
        "aborted_rows": aborted, "batch": batch, "batch_ratios": b_ratios, "scaling": scaling,
        "targets": targets, "timing_loop_overhead_s": loop_overhead(),
        "section_durations_s": {k: round(v, 1) for k, v in sections.items()},
    }
    results["duration_s"] = round(time.perf_counter() - t_start, 1)
    text_table = report.console(results)
    log(text_table)
    doc, summary = json.dumps(_clean(results), indent=1) + "\n", report.markdown(results)
    atomic_write_text(os.path.join(out_dir, "results.json"), doc)
    atomic_write_text(os.path.join(out_dir, "results.md"), summary)
    log(f"wrote {os.path.join(out_dir, 'results.json')} and results.md in {results['duration_s']} s")
    if args.publish:
        atomic_write_text(os.path.join(RESULTS, REFERENCE[0]), doc)
        atomic_write_text(os.path.join(RESULTS, REFERENCE[1]), summary)
        log(f"published as the reference results: {os.path.join(RESULTS, REFERENCE[0])} and {REFERENCE[1]}")
    return exit_status(checks, targets, args.check_targets)


def exit_status(checks: dict, targets: list, check_targets: bool) -> int:
    """2 when a manipdyn engine was wrong; 1 when asked to check targets and one was missed; else 0."""
    if not checks["passed"]:
        loud("a manipdyn engine gave a wrong answer: see the checks above")
        return 2
    missed = [t["id"] for t in targets if t.get("status") == "MISS"]
    if check_targets and missed:
        loud(f"--strict: missed {', '.join(missed)}")
        return 1
    if missed:
        log(f"missed target(s) {', '.join(missed)}: reported above, exit 0 (--strict makes a miss exit 1)")
    return 0


def _clean(x):
    """JSON-safe: NaN/inf -> None, numpy scalars -> Python."""
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


if __name__ == "__main__":
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        sys.exit(main())
