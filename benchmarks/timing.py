"""Interleaved timing for a noisy machine.

Everything that is compared is timed in the same rounds: each round times
every candidate once (in a rotated order), so a burst of load from another
process hits all candidates alike.  Reported numbers are medians with the
inter-quartile range; ratios are the median of the per-round ratios (paired),
which is much steadier than a ratio of two medians taken at different times.

The cost of the bare timing loop is measured once and subtracted from
per-call times (a few nanoseconds).
"""

from __future__ import annotations

import cProfile
import io
import math
import pstats
import sys
import time
import timeit

import numpy as np

__all__ = ["Sample", "interleaved", "paired_ratio", "loop_overhead", "profile_top"]


class Sample:
    """Per-call times (s) of one candidate, one value per round."""

    def __init__(self, times, number, scale=1.0):
        self.times = np.asarray(times, dtype=float) / scale
        self.number = int(number)

    @property
    def median(self):
        return float(np.median(self.times))

    @property
    def q25(self):
        return float(np.percentile(self.times, 25))

    @property
    def q75(self):
        return float(np.percentile(self.times, 75))

    @property
    def iqr(self):
        return self.q75 - self.q25

    def as_dict(self):
        return {"median_s": self.median, "iqr_s": self.iqr, "q25_s": self.q25, "q75_s": self.q75,
                "min_s": float(self.times.min()), "rounds": int(self.times.size), "number": self.number}


_OVERHEAD = None


def loop_overhead():
    """Seconds per iteration of the bare timing loop (``for _ in it: pass``).

    Only the loop is subtracted: calling the candidate is part of its cost
    (candidates are ``functools.partial`` objects where possible, so that a
    raw Pinocchio call is timed without a Python frame around it).
    """
    global _OVERHEAD
    if _OVERHEAD is None:
        t = timeit.Timer("pass")
        _OVERHEAD = min(t.timeit(1_000_000) for _ in range(5)) / 1_000_000
    return _OVERHEAD


def _calibrate(timer, target_s, max_number):
    """Smallest power-of-two-ish ``number`` whose run takes >= target_s."""
    number = 1
    while True:
        t = timer.timeit(number)
        if t >= target_s or number >= max_number:
            return number, t
        # aim straight for the target, with a margin, at least doubling
        number = min(max_number, max(2 * number, int(math.ceil(number * 1.2 * target_s / max(t, 1e-9)))))


def interleaved(fns, rounds, target_s, max_number=1_000_000, per_call_scale=None, subtract_overhead=True):
    """Time callables in interleaved rounds.

    Parameters
    ----------
    fns : dict name -> zero-argument callable
    rounds : number of rounds (samples per candidate)
    target_s : wall time of one sample of one candidate (sets ``number``)
    per_call_scale : dict name -> divisor (e.g. the batch size, to get
        per-state times); default 1
    Returns dict name -> :class:`Sample` of per-call (or per-state) seconds.
    """
    names = list(fns)
    timers = {k: timeit.Timer(fns[k]) for k in names}
    numbers = {}
    for k in names:
        numbers[k], _ = _calibrate(timers[k], target_s, max_number)
    over = loop_overhead() if subtract_overhead else 0.0
    times = {k: [] for k in names}
    m = len(names)
    for r in range(rounds):
        order = names[r % m:] + names[:r % m]
        for k in order:
            t = timers[k].timeit(numbers[k]) / numbers[k]
            times[k].append(max(t - over, 1e-12))
    scale = per_call_scale or {}
    return {k: Sample(times[k], numbers[k], scale.get(k, 1.0)) for k in names}


def paired_ratio(a: Sample, b: Sample) -> float:
    """Median over rounds of a/b (both sampled in the same rounds)."""
    return float(np.median(a.times / b.times))


def profile_top(fn, calls, top=8):
    """cProfile ``calls`` calls of ``fn``: the top functions by own time.

    Returns a list of dicts (function, ncalls, tottime_s, share of the total
    own time, per-call own time in microseconds per profiled call of fn).
    """
    pr = cProfile.Profile()
    pr.enable()
    for _ in range(calls):
        fn()
    pr.disable()
    st = pstats.Stats(pr, stream=io.StringIO())
    total = sum(v[2] for v in st.stats.values()) or 1e-12
    rows = []
    for (filename, line, func), (cc, nc, tt, ct, _callers) in st.stats.items():
        if (func == "<lambda>" and "benchmarks" in filename) or "_lsprof" in func:
            continue  # the harness and the profiler themselves
        where = filename.rsplit("/", 2)
        where = "/".join(where[-2:]) if filename not in ("~", "") else ""
        label = f"{func} ({where}:{line})" if where else func
        rows.append({"function": label, "ncalls": int(nc), "tottime_s": float(tt),
                     "share": float(tt / total), "us_per_call": float(tt / calls * 1e6)})
    rows.sort(key=lambda r: -r["tottime_s"])
    return rows[:top]


def blas_config() -> list | str:
    """The BLAS/OpenMP thread pools this process runs with (threadpoolctl), without file paths.

    OPENBLAS_CORETYPE changes which kernels OpenBLAS uses (on some machines it
    halves the speed of numpy's small matrix products), so every result records it.
    """
    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        return "threadpoolctl not installed (pip install 'manipdyn[bench]')"
    keep = ("user_api", "internal_api", "prefix", "version", "num_threads", "threading_layer", "architecture")
    return [{k: v for k, v in pool.items() if k in keep} for pool in threadpool_info()]


def write_atomic(path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (a temporary file beside it, then a rename)."""
    import os
    import tempfile
    from pathlib import Path

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)          # mkstemp's 0600 is not what a results file should have
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_run(text: str, label: str, out=None):
    """Write a benchmark's ``results.json`` text into ``out`` or, by default, its own
    ``benchmarks/results/runs/<UTC time>-<label>/`` folder (ignored by git); returns the file."""
    import time
    from pathlib import Path

    stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
    folder = Path(out) if out else Path(__file__).resolve().parent / "results" / "runs" / f"{stamp}-{label}"
    path = folder / "results.json"
    write_atomic(path, text)
    return path


def publish(args, env: dict, payload: dict, label: str) -> None:
    """Unless ``args.no_write``: write ``{"environment": env, **payload}`` as the run's
    ``results.json`` (:func:`write_run`, into ``args.out`` if given) and say where."""
    import json

    if not args.no_write:
        path = write_run(json.dumps({"environment": env, **payload}, indent=2) + "\n", label, args.out)
        print(f"wrote {path}")


def seeded_runs(prog: str, doc: str, label: str, run_seed, argv=None):
    """The command line and the loop shared by the seeded hard-log benchmarks.

    Parses ``--seeds`` (default 0 1 2), ``--out`` and ``--no-write``, then calls
    ``run_seed(seed, folder)`` for each seed with a fresh folder in one temporary
    directory, saying on stderr which seed runs and how long each took (a seed takes
    tens of seconds; ``--quiet`` says nothing).  Returns ``(args, runs)``.
    """
    import argparse
    import os
    import tempfile

    p = argparse.ArgumentParser(prog=prog, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--out", default=None, metavar="DIR",
                   help=f"folder of results.json (default benchmarks/results/runs/<UTC time>-{label})")
    p.add_argument("--no-write", action="store_true", help="print only")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    args = p.parse_args(argv)
    say = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    t0 = time.perf_counter()
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, seed in enumerate(args.seeds, start=1):
            say(f"[{time.perf_counter() - t0:6.1f} s] {label}: seed {seed} ({k}/{len(args.seeds)}) ...")
            t1 = time.perf_counter()
            runs.append(run_seed(seed, os.path.join(tmp, f"seed{seed}")))
            say(f"[{time.perf_counter() - t0:6.1f} s] {label}: seed {seed} done in {time.perf_counter() - t1:.1f} s")
    return args, runs
