"""Seeded fuzzing of the command line's option sets: ``excite`` and ``montecarlo``.

Run from the repository root::

    python -m tests.fuzz_cli --cases 2000            # the long run (minutes)
    python -m tests.fuzz_cli --cases 120 --jobs 2    # what CI runs (tests/test_fuzz.py)

Each case is a small, fast base command (``excite ur5 --iterations 0
--duration 1 --rate 20``; ``montecarlo puma560 --runs 1 --duration 0.03
--scheduler sync``) with one to three options set to hostile values (0,
negative, nan, inf, 1e308, 1e-308, 400-digit integers, words, the empty
string, non-ASCII digits, addresses that are not Dask's ...).  Case ``i`` of
seed ``s`` is always the same command (``--show KIND:I`` prints it).

The contract, checked on every case (``manipdyn.cli.main`` in a worker
process, with a timeout), the same as for files:

* exit 0 with a meaningful result: ``excite`` wrote its CSV (a header and
  rows of finite numbers), ``montecarlo --json`` printed strict JSON; or
* exit 2 with exactly one line on stderr that names the option (or MODEL);

never exit 3 or 1, a traceback, a hang (over ``--timeout`` s) or a crash.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import random
import sys

from tests.fuzz import run_pool

#: the outcomes that satisfy the contract
PASS = ("refused (exit 2, the option named)", "ran (exit 0, output checked)")

HOSTILE = ["0", "-1", "-0", "nan", "inf", "-inf", "1e308", "-1e308", "1e-308", "5e-324", "1e-9", "1e9",
           "9" * 400, "-" + "9" * 400, "abc", "", " ", "0x10", "1_000", "٣", "1e", "--", "None", "2.5",
           "3", "1", "0.5", "1e300", "10000000000"]
INTS = ["0", "-1", "1", "2", "3", "1000000000000", "9" * 400, "abc", "", "1.5", "٣", "-9"]

#: option -> value pool; each case sets 1 to 3 of them
EXCITE = {"--duration": HOSTILE, "--harmonics": INTS, "--rate": HOSTILE, "--seed": INTS,
          "--vmax": HOSTILE, "--amax": HOSTILE, "--iterations": ["0", "-1", "abc", "", "1"],
          "-o": ["", ".", "/", "/dev/null", "/nonexistent/t.csv", "{tmp}", "{tmp}/t.csv", "{tmp}/a/b.csv"]}
MONTECARLO = {"--runs": ["0", "-1", "1", "2", "abc", "", "1000000000000", "9" * 400],
              "--seed": INTS, "--chunk-size": INTS, "--duration": HOSTILE, "--dt": HOSTILE,
              "--bandwidth": HOSTILE, "--tau-max": HOSTILE, "--payload-mass": HOSTILE,
              "--link-scale": HOSTILE, "--friction-viscous": HOSTILE, "--friction-coulomb": HOSTILE,
              "--q0-offset": HOSTILE, "--torque-noise": HOSTILE,
              "--controllers": ["", ",", "pd,pd", "PD", "pd,,ct", "xx", "pd,adaptive", "ct\x00"],
              "--scheduler": ["", "garbage", "http://x:80", "tcp://", "tcp://host", "tcp://h:0",
                              "tcp://h:99999", "sync", "inproc://"]}
BASE = {"excite": ["excite", "ur5", "--iterations", "0", "--duration", "1", "--rate", "20",
                   "-o", "{tmp}/t.csv"],
        "montecarlo": ["montecarlo", "puma560", "--runs", "1", "--duration", "0.03",
                       "--scheduler", "sync", "--json"]}
#: the pools hold no value that asks, validly, for a long run (runs, steps and samples
#: stay tiny unless a value is refused), so a slow case is a finding, not a big study
POOLS = {"excite": EXCITE, "montecarlo": MONTECARLO}


def make_cli_case(kind: str, seed: int, index: int) -> list[str]:
    """The argv of case ``index`` of ``kind`` (excite or montecarlo), without the program name."""
    rng = random.Random(f"{kind}:{seed}:{index}")
    pool = POOLS[kind]
    chosen = rng.sample(sorted(pool), rng.randint(1, 3))
    argv = list(BASE[kind])
    for opt in chosen:
        value = rng.choice(pool[opt])
        if opt in argv:                              # replace the base value
            argv[argv.index(opt) + 1] = value
        else:
            argv += [opt, value] if not value.startswith("-") else [f"{opt}={value}"]
    return argv


def _check_output(kind: str, argv: list[str], out: str, folder: str) -> str | None:
    """None when an exit-0 result is meaningful, else what is wrong with it."""
    if kind == "montecarlo":
        try:
            doc = json.loads(out, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
        except ValueError as exc:
            return f"stdout is not strict JSON ({exc})"
        return None if "controllers" in doc or "per_run" in doc or doc else "empty JSON"
    path = argv[argv.index("-o") + 1] if "-o" in argv else next(
        a.split("=", 1)[1] for a in argv if a.startswith("-o="))
    try:
        with open(path, encoding="utf-8") as fh:
            rows = fh.read().splitlines()
    except OSError as exc:
        return f"exit 0 but {path} cannot be read ({exc})"
    if len(rows) < 3 or not rows[0].startswith("t,q1"):
        return f"exit 0 but {path} holds {len(rows)} line(s)"
    bad = [r for r in rows[1:] if not all(math.isfinite(float(x)) for x in r.split(","))]
    return f"exit 0 but {len(bad)} row(s) are not finite" if bad else None


def run_cli_case(kind: str, seed: int, index: int, folder: str) -> tuple[str, str]:
    """(outcome, detail) of one case, run through ``manipdyn.cli.main`` in this process."""
    import warnings

    from manipdyn.cli import main

    case = os.path.join(folder, f"{kind}-{index}")
    os.makedirs(case, exist_ok=True)
    argv = [a.replace("{tmp}", case) for a in make_cli_case(kind, seed, index)]
    out, err = io.StringIO(), io.StringIO()
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            warnings.simplefilter("ignore")
            try:
                code = main(argv)
            except SystemExit as exc:           # argparse: exit 2 with its usage line
                code = exc.code
    except BaseException as exc:  # noqa: BLE001 - classifying is the point
        return f"FOREIGN {type(exc).__name__}", f"{argv}: {exc!s:.300}"
    lines = [l for l in err.getvalue().splitlines() if l.strip()]
    where = " ".join(repr(a) if not a or " " in a else a for a in argv)
    if code == 0:
        problem = _check_output(kind, argv, out.getvalue(), case)
        return ("ran (exit 0, output checked)", where) if problem is None else ("MEANINGLESS SUCCESS", f"{where}: {problem}")
    if code == 2:
        usage = [l for l in lines if not l.startswith("usage:") and not l.startswith("  ")]
        if len(usage) != 1:
            return "UNCLEAR (exit 2 without one error line)", f"{where}: {lines[-5:]}"
        # the option, as typed or as its field name (distributions: link_scale: ...)
        names = [o for o in POOLS[kind] if o != "-o"] + ["-o ", "-o:", "the folder"] + \
            [o.lstrip("-").replace("-", "_") for o in POOLS[kind] if len(o) > 3]
        if not any(n in usage[0] for n in names):
            return "UNNAMED (exit 2, no option named)", f"{where}: {usage[0][:300]}"
        return "refused (exit 2, the option named)", f"{where}: {usage[0][:200]}"
    return f"EXIT {code}", f"{where}: {' | '.join(lines[-3:])[:400]}"


def fuzz_cli(n_excite: int, n_montecarlo: int, seed: int = 0, jobs: int = 2, timeout: float = 20.0,
             progress=None) -> dict:
    """Run the cases; the result of :func:`tests.fuzz.run_pool`."""
    jobs_list = [("excite", seed, i) for i in range(n_excite)] + \
                [("montecarlo", seed, i) for i in range(n_montecarlo)]
    return run_pool(jobs_list, ("excite", "montecarlo"), seed, jobs, timeout, progress,
                    runner=run_cli_case, passing=PASS)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.fuzz_cli", description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", type=int, default=200, help="cases per subcommand (default 200)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--timeout", type=float, default=20.0, help="seconds per case before it is a hang")
    p.add_argument("--show", metavar="KIND:INDEX", default=None, help="print one case's command and exit")
    args = p.parse_args(argv)
    if args.show:
        kind, idx = args.show.split(":")
        print("manipdyn " + " ".join(repr(a) for a in make_cli_case(kind, args.seed, int(idx))))
        return 0
    res = fuzz_cli(args.cases, args.cases, args.seed, args.jobs, args.timeout)
    print(f"fuzz_cli: {res['cases']} cases in {res['seconds']:.0f} s (seed {args.seed})")
    for kind, c in res["counts"].items():
        for outcome, k in sorted(c.items(), key=lambda x: -x[1]):
            print(f"  {kind:<10} {k:6d}  {outcome}{'' if outcome in PASS else '   <-- FAILS THE CONTRACT'}")
    for kind, idx, outcome, detail in res["failures"][:40]:
        print(f"  FAIL {kind}:{idx} {outcome}: {detail[:400]}")
    return 1 if res["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
