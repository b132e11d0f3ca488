"""``manipdyn check``: cross-check both engines on arms, and time them.

Layer 7 (CLI, the top).
"""

from __future__ import annotations

import json

from ..check.crosscheck import QUANTITIES, as_engines, crosscheck
from ..check.timing import engine_timings
from .._support.errors import ModelError
from ..formats.save import write_urdf
from ..formats.loading import models
from .common import (EXIT_DISAGREE, EXIT_OK, TIP_HELP, Progress, add_progress_options, load_all,
                     output_folder, progress_wanted, urdf_target, usage_error)

__all__ = ["register", "run"]


def _crosscheck(arm, args, progress):
    """``crosscheck`` here, or spread over Dask workers with ``--scheduler``/``--workers``."""
    scheduler = args.scheduler
    if scheduler is None and args.workers is not None:
        scheduler = "local"
    if args.workers is not None and args.workers < 1:
        raise ModelError(f"--workers: must be >= 1, got {args.workers}")
    return crosscheck(arm, samples=args.samples, seed=args.seed, progress=progress,
                      scheduler=scheduler, workers=args.workers, engines=args.engines)


def _print_result(report, timing, urdf_path, strict_failed: bool) -> None:
    print(report)                       # the arm's notes are part of the report
    if strict_failed:
        print(f"  STRICT: {len(report.notes)} note(s) above fail --strict")
    if timing:                          # one column per engine compared, in the report's order
        names = list(timing)
        print(f"  per call (median, us)   " + " ".join(f"{e:>10}" for e in names))
        for key, label in (("inverse_dynamics_us", "inverse dynamics"),
                           ("mass_matrix_us", "mass matrix"),
                           ("forward_dynamics_us", "forward dynamics")):
            print(f"  {label:<22} " + " ".join(f"{timing[e][key]:10.1f}" for e in names))
    if urdf_path:
        print(f"  URDF written to {urdf_path}")
    print()


def run(args) -> int:
    specs = list(args.models)
    if args.all:
        specs = models() + specs
    specs = list(dict.fromkeys(specs))  # each arm once, in order
    if not specs:
        return usage_error("check", "name at least one model or file, or pass --all")
    if args.samples < 1:
        return usage_error("check", f"--samples must be >= 1, got {args.samples}")
    if args.timing_calls < 0:
        return usage_error("check", f"--timing-calls must be >= 0 (0 skips the timing), got {args.timing_calls}")
    if args.urdf_out:
        output_folder(args.urdf_out, "--urdf-out")
    if args.engines is not None:
        try:
            args.engines = as_engines(args.engines)
        except ModelError as exc:
            return usage_error("check", str(exc).replace("engines:", "--engines:", 1))
    loaded = load_all(specs, args.tip)         # every name checked before any arm runs
    seen: dict = {}
    targets = [urdf_target(args.urdf_out, arm, seen, "--urdf-out", specs) if args.urdf_out else None
               for _spec, arm, _notes in loaded]                 # every output checked before any work
    show_progress = progress_wanted(args)
    results, worst = [], EXIT_OK
    for (spec, arm, notes), urdf_path in zip(loaded, targets):
        if urdf_path:
            write_urdf(arm, urdf_path)
        report = _crosscheck(arm, args, Progress(arm.name or spec, show_progress))
        timing = (engine_timings(arm, calls=args.timing_calls, engines=report.engines)
                  if args.timing_calls > 0 else {})
        strict_failed = bool(args.strict and notes)
        if not report.ok or strict_failed or report.not_compared:
            # a quantity that could not be compared (forward dynamics of a
            # singular D) is a failed condition, never "all agree"
            worst = EXIT_DISAGREE
        results.append({"model": spec, "notes": notes, "urdf": urdf_path, "timing": timing,
                        "strict_failed": strict_failed, "report": report})
        if not args.json:
            _print_result(report, timing, urdf_path, strict_failed)
    if args.json:
        print(json.dumps([{**r, "report": r["report"].to_dict()} for r in results], indent=2))
    else:
        bad = [r["model"] for r in results if not r["report"].ok]
        failed = [r["model"] for r in results if r["report"].ok and r["report"].not_compared]
        print(f"{len(results) - len(bad) - len(failed)}/{len(results)} arms agree"
              + (f"; DISAGREEMENT: {', '.join(bad)}" if bad else "")
              + (f"; FAILED (a quantity could not be compared, see the notes): {', '.join(failed)}"
                 if failed else ""))
        strict = [r["model"] for r in results if r["strict_failed"]]
        if strict:
            print(f"--strict: {', '.join(strict)} have notes (physically impossible or suspicious values, or a tool frame taken by default)")
    return worst


def register(sub) -> None:
    """Add ``manipdyn check``."""
    c = sub.add_parser("check", help="cross-check both engines on arms",
                       description="For each arm: build the URDF, load the engines, compare on random "
                                   f"states the {len(QUANTITIES)} quantities below, and time each engine "
                                   "compared (inverse dynamics, mass matrix, forward dynamics). Every "
                                   "model is loaded before the first is run. Compared: "
                                   + "; ".join(f"{k}: {v}" for k, v in QUANTITIES.items()) + ".",
                       epilog="Exit codes: 0 every arm agrees; 1 a quantity disagrees, or could not be "
                              "compared (forward dynamics of an arm whose mass matrix is singular: a "
                              "failed condition, never 'all agree'), or a note under --strict; 2 usage "
                              "or model error; 3 a bug.")
    c.add_argument("models", nargs="*", metavar="MODEL_OR_FILE",
                   help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd)")
    c.add_argument("--all", action="store_true", help="check every bundled model")
    c.add_argument("--samples", type=int, default=1000, help="random states per arm (default 1000)")
    c.add_argument("--seed", type=int, default=0, help="seed of the random states (default 0)")
    c.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    c.add_argument("--strict", action="store_true",
                   help="fail (exit 1) on every note: physically impossible link inertias, values in "
                        "suspicious units, a URDF tool frame taken by default where others were passed over "
                        "(default: check them as published, and say so)")
    c.add_argument("--json", action="store_true", help="print one JSON document instead of tables")
    c.add_argument("--urdf-out", metavar="DIR", default=None, help="also write each arm's URDF into DIR")
    c.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="spread the states over this Dask cluster ('local': a cluster of this "
                        "machine's cores); the report is the same as a local run's")
    c.add_argument("--workers", type=int, default=None,
                   help="with --scheduler local (implied): worker processes (default one per core)")
    c.add_argument("--engines", default=None, metavar="E1,E2[,...]",
                   help="the engines to compare, the referee first, e.g. lagrange,pinocchio,c (the "
                        "generated C: needs a C compiler, and CasADi on the first build of an arm), "
                        "or pinocchio,mujoco (MuJoCo on the arm's MJCF: the mujoco extra; what MuJoCo does "
                        "not compute is left out with a note); default lagrange,pinocchio")
    c.add_argument("--timing-calls", type=int, default=200,
                   help="calls per engine for the per-call timing (0 to skip; default 200)")
    add_progress_options(c)
    c.set_defaults(func=run)
