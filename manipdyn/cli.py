"""Command line: ``manipdyn check``, ``manipdyn urdf``, ``manipdyn models``.

Exit codes: 0 all engines agree (or the command succeeded), 1 some quantity
disagrees, 2 usage or model error (one line on stderr, no traceback),
3 an unexpected internal error (one line; ``--debug`` shows the traceback).
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import json
import os
import re
import sys
import time
import warnings

from .errors import ModelError, SingularMassMatrixError

__all__ = ["main"]

EXIT_OK, EXIT_DISAGREE, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 3

#: modules that add their own subcommand (``compare``, ``track``)
_PLUGIN_MODULES = ("manipdyn.comparison", "manipdyn.control.cli", "manipdyn.montecarlo.cli")


class _Progress:
    """A one-line progress bar on stderr (only when stderr is a terminal, or forced)."""

    def __init__(self, label: str, enabled: bool, width: int = 30):
        self.label, self.enabled, self.width = label, enabled, width
        self.t0 = time.perf_counter()

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        frac = done / total if total else 1.0
        bar = "#" * int(self.width * frac) + "-" * (self.width - int(self.width * frac))
        el = time.perf_counter() - self.t0
        sys.stderr.write(f"\r{self.label:<16} [{bar}] {done}/{total} states  {el:5.1f} s")
        if done >= total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def _median_us(fn, calls: int) -> float:
    import statistics

    fn()  # warm-up (builds pools, caches)
    times = []
    for _ in range(calls):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1e6


def _timings(arm, calls: int = 200) -> dict:
    import numpy as np

    rng = np.random.default_rng(1)
    q = arm.random_state(rng)
    qd = rng.uniform(-1, 1, arm.n)
    qdd = rng.uniform(-1, 1, arm.n)
    out = {}
    for eng in (arm.pinocchio, arm.lagrange):
        out[eng.name] = {
            "inverse_dynamics_us": _median_us(lambda: eng.inverse_dynamics(q, qd, qdd), calls),
            "mass_matrix_us": _median_us(lambda: eng.mass_matrix(q), calls),
        }
        try:
            out[eng.name]["forward_dynamics_us"] = _median_us(lambda: eng.forward_dynamics(q, qd, qdd), calls)
        except SingularMassMatrixError:
            out[eng.name]["forward_dynamics_us"] = float("nan")  # D singular: no forward dynamics
    return out


def _urdf_target(outdir: str, arm, seen: dict, option: str) -> str:
    """``outdir/<name>.urdf`` for an arm, with the name made a safe file name.

    Refuses two arms that would write the same file.
    """
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", arm.name or "arm").strip("._") or "arm"
    if stem in seen:
        raise ModelError(f"{option}: {seen[stem]!r} and {arm.name!r} would both be written to {stem}.urdf")
    seen[stem] = arm.name
    return os.path.join(outdir, f"{stem}.urdf")


def _outdir(path: str, option: str) -> str:
    """Create the output folder, or say in one line why it cannot be."""
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as exc:
        raise ModelError(f"{option} {path}: cannot create the folder: {exc.strerror}") from None
    return path


def _load_quiet(spec: str, tip, notes: list):
    """Load an arm, turning physical-consistency warnings into printed notes."""
    import manipdyn as md

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", md.PhysicalConsistencyWarning)
        arm = md.load(spec, tip=tip) if tip else md.load(spec)
    for w in caught:
        if issubclass(w.category, md.PhysicalConsistencyWarning):
            notes.append(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return arm


def _cmd_check(args) -> int:
    import manipdyn as md

    specs = list(args.models)
    if args.all:
        specs = md.models() + specs
    specs = list(dict.fromkeys(specs))  # each arm once, in order
    if not specs:
        print("manipdyn check: error: name at least one model or file, or pass --all", file=sys.stderr)
        return EXIT_USAGE
    if args.samples < 1:
        print(f"manipdyn check: error: --samples must be >= 1, got {args.samples}", file=sys.stderr)
        return EXIT_USAGE
    if args.urdf_out:
        _outdir(args.urdf_out, "--urdf-out")
    seen: dict = {}
    show_progress = args.progress or (args.progress is None and sys.stderr.isatty())
    results, worst = [], EXIT_OK
    for spec in specs:
        notes: list[str] = []
        arm = _load_quiet(spec, args.tip, notes)
        urdf_path = None
        if args.urdf_out:
            urdf_path = _urdf_target(args.urdf_out, arm, seen, "--urdf-out")
            arm.write_urdf(urdf_path)
        report = _crosscheck(md, arm, args, _Progress(arm.name or spec, show_progress))
        timing = _timings(arm, calls=args.timing_calls) if args.timing_calls > 0 else {}
        if not report.ok:
            worst = EXIT_DISAGREE
        results.append({"model": spec, "notes": notes, "urdf": urdf_path,
                        "timing": timing, "report": report})
        if not args.json:
            print(report)
            for n in notes:
                print(f"  note: {n}")
            if timing:
                p, l = timing["pinocchio"], timing["lagrange"]
                print(f"  per call (median, us)   {'pinocchio':>10} {'lagrange':>10}")
                for key, label in (("inverse_dynamics_us", "inverse dynamics"),
                                   ("mass_matrix_us", "mass matrix"),
                                   ("forward_dynamics_us", "forward dynamics")):
                    print(f"  {label:<22} {p[key]:10.1f} {l[key]:10.1f}")
            if urdf_path:
                print(f"  URDF written to {urdf_path}")
            print()
    if args.json:
        print(json.dumps([{**r, "report": r["report"].to_dict()} for r in results], indent=2))
    else:
        bad = [r["model"] for r in results if not r["report"].ok]
        print(f"{len(results) - len(bad)}/{len(results)} arms agree"
              + (f"; DISAGREEMENT: {', '.join(bad)}" if bad else ""))
    return worst


def _crosscheck(md, arm, args, progress):
    """``md.crosscheck`` here, or spread over Dask workers with ``--scheduler``/``--workers``."""
    from .scale import MissingExtraError

    scheduler = args.scheduler
    if scheduler is None and args.workers is not None:
        scheduler = "local"
    if args.workers is not None and args.workers < 1:
        raise ModelError(f"--workers: must be >= 1, got {args.workers}")
    try:
        return md.crosscheck(arm, samples=args.samples, seed=args.seed, progress=progress,
                             scheduler=scheduler, workers=args.workers)
    except MissingExtraError as exc:
        raise ModelError(str(exc)) from None


def _cmd_urdf(args) -> int:
    import manipdyn as md

    specs = list(args.models)
    if args.all:
        specs = md.models() + specs
    if not specs:
        print("manipdyn urdf: error: name at least one model or pass --all", file=sys.stderr)
        return EXIT_USAGE
    _outdir(args.outdir, "OUTDIR")
    seen: dict = {}
    for spec in dict.fromkeys(specs):  # each spec once, in order
        arm = _load_quiet(spec, None, [])
        path = _urdf_target(args.outdir, arm, seen, "OUTDIR")
        arm.write_urdf(path)
        print(f"wrote {path}")
    return EXIT_OK


def _cmd_models(args) -> int:
    import manipdyn as md

    for name in md.models():
        notes: list[str] = []
        arm = _load_quiet(name, None, notes)
        kinds = arm.joint_letters
        verdict = "consistent" if not notes else f"{len(notes)} inconsistent link(s)"
        print(f"{name:<12} {arm.n} DOF {kinds:<8} {arm.convention:<9} {verdict}")
    return EXIT_OK


def _module_exists(modname: str) -> bool:
    """True if ``modname`` can be imported; a missing dependency inside it still raises."""
    try:
        return importlib.util.find_spec(modname) is not None
    except ModuleNotFoundError as exc:
        if exc.name and modname.startswith(exc.name):
            return False
        raise


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="manipdyn",
        description="Serial-arm dynamics two independent ways (Pinocchio and the trace-form "
                    "Lagrange-Euler equations), cross-checked.",
        epilog="Exit codes: 0 agree, 1 a quantity disagrees, 2 usage or model error, 3 internal error.",
    )
    p.add_argument("--debug", action="store_true", help="show Python tracebacks on errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    c = sub.add_parser("check", help="cross-check both engines on arms",
                       description="For each arm: build the URDF, load both engines, compare D, h, g, "
                                   "tau, forward dynamics and FK on random states, and time both engines.")
    c.add_argument("models", nargs="*", metavar="MODEL_OR_FILE",
                   help="bundled model name, .toml model file, or .urdf file")
    c.add_argument("--all", action="store_true", help="check every bundled model")
    c.add_argument("--samples", type=int, default=1000, help="random states per arm (default 1000)")
    c.add_argument("--seed", type=int, default=0, help="seed of the random states (default 0)")
    c.add_argument("--tip", default=None, help="URDF files: the tip link of the chain to keep")
    c.add_argument("--json", action="store_true", help="print one JSON document instead of tables")
    c.add_argument("--urdf-out", metavar="DIR", default=None, help="also write each arm's URDF into DIR")
    c.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="spread the states over this Dask cluster ('local': a cluster of this "
                        "machine's cores); the report is the same as a local run's")
    c.add_argument("--workers", type=int, default=None,
                   help="with --scheduler local (implied): worker processes (default one per core)")
    c.add_argument("--timing-calls", type=int, default=200,
                   help="calls per engine for the per-call timing (0 to skip; default 200)")
    prog = c.add_mutually_exclusive_group()
    prog.add_argument("--progress", dest="progress", action="store_true", default=None,
                      help="always show the progress bar (default: only on a terminal)")
    prog.add_argument("--no-progress", dest="progress", action="store_false")
    c.set_defaults(func=_cmd_check)

    u = sub.add_parser("urdf", help="write the URDF of arms", description="Write <name>.urdf for each arm into OUTDIR.")
    u.add_argument("models", nargs="*", metavar="MODEL_OR_FILE")
    u.add_argument("--all", action="store_true", help="every bundled model")
    u.add_argument("outdir", metavar="OUTDIR")
    u.set_defaults(func=_cmd_urdf)

    m = sub.add_parser("models", help="list the bundled arm models")
    m.set_defaults(func=_cmd_models)

    # Subcommands that live beside their feature: each module exposes
    # register_cli(subparsers), which adds a parser with set_defaults(func=...).
    for modname in _PLUGIN_MODULES:
        if _module_exists(modname):
            importlib.import_module(modname).register_cli(sub)
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_USAGE
    try:
        return args.func(args)
    except BrokenPipeError:
        # the reader went away (e.g. `manipdyn check ... | head`): not an error of ours
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return EXIT_OK
    except ModelError as exc:
        print(f"manipdyn {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:
        print(f"manipdyn {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("manipdyn: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # never a bare traceback for users
        if args.debug:
            raise
        print(f"manipdyn {args.command}: internal error: {type(exc).__name__}: {exc} "
              "(rerun with --debug for the traceback)", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
