"""``manipdyn excite MODEL -o traj.csv``: an optimised excitation trajectory.

Layer 7 (CLI, the top).

Writes ``t,q1..qn,qd1..qdn,qdd1..qddn`` (SI units) and reports the condition
number of the stacked base regressor.  Exit codes: 0 written, 2 usage or
model error (one line on stderr).
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from .._support import limits
from .._support.errors import ModelError
from . import excite_ptp
from .common import (EXIT_OK, TIP_HELP, Progress, add_progress_options, check_outputs, load_arm,
                     progress_wanted, require_numbers, usage_error)

__all__ = ["register", "run"]

#: the series' period when neither --period nor the deprecated --duration is given, s
#: (``manipdyn.identification.excitation``'s ``duration`` default)
DEFAULT_PERIOD = 10.0


class _Given(argparse.Action):
    """Store the value and remember, in ``args.given``, that the option was on the command line."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)
        namespace.given = set(getattr(namespace, "given", ())) | {self.dest}


def register(subparsers) -> None:
    """Add ``manipdyn excite`` to the command line."""
    from ..identification.experiments.trajectory import DEFAULT_AMAX, DEFAULT_VMAX

    p = subparsers.add_parser(
        "excite", help="design an excitation trajectory for identification",
        description="Optimise a finite Fourier series per joint (Swevers et al. 1997) to minimise "
                    "the condition number of the stacked base regressor, within the model's joint "
                    "limits and the velocity and acceleration limits; write it as CSV "
                    "(t,q1..qn,qd1..qdn,qdd1..qddn), one period (--period) between a ramp in from rest "
                    "and a ramp out to it (--ramp): the file lasts ramp + period + ramp. With --ptp N: a point-to-point run "
                    "through N postures with rests instead, in the same file format. Exit codes: 0 written, 2 usage or model error.")
    p.add_argument("model", metavar="MODEL", help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd)")
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("-o", "--output", required=True, metavar="TRAJ.csv", help="CSV file to write")
    p.add_argument("--period", type=float, default=DEFAULT_PERIOD, metavar="S", action=_Given,
                   help="period of the Fourier series, s (default 10); the file covers one period and "
                        "the ramps in and out (--ramp), so it lasts ramp + period + ramp")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help="deprecated: the old name of --period (it set the period, not the file's length)")
    p.add_argument("--harmonics", type=int, default=5, metavar="K", help=f"harmonics per joint (default 5, at most {limits.MAX_HARMONICS})")
    p.add_argument("--rate", type=float, default=100.0, metavar="HZ", help=f"sample rate, Hz (default 100; --rate x --period at most {limits.MAX_EXCITATION_SAMPLES} samples)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the optimiser's start (default 0)")
    p.add_argument("--vmax", type=float, nargs="+", default=None, metavar="V",
                   help=f"velocity limit, one or n values (default {DEFAULT_VMAX['revolute']} rad/s, "
                        f"{DEFAULT_VMAX['prismatic']} m/s)")
    p.add_argument("--amax", type=float, nargs="+", default=None, metavar="A",
                   help=f"acceleration limit, one or n values (default {DEFAULT_AMAX['revolute']} rad/s^2, "
                        f"{DEFAULT_AMAX['prismatic']} m/s^2)")
    p.add_argument("--iterations", type=int, default=60, help="optimiser iterations (default 60)")
    p.add_argument("--ramp", default="auto", metavar="S",
                   help="seconds to ramp in from rest at the middle of the limits and back out to it, "
                        "velocity and acceleration limits kept (default auto: the shortest of a quarter, "
                        "half, one or two periods that keeps them; 0: the bare periodic series, which "
                        "starts moving)")
    p.add_argument("--friction", action="store_true", help="also excite friction parameters")
    excite_ptp.add_options(p)
    p.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    add_progress_options(p, "the progress bar")
    p.set_defaults(func=run)



#: largest --vmax / --amax: far beyond any arm (industrial joints turn under 10 rad/s), and
#: below the range where the Fourier coefficients they scale overflow
MAX_RATE_LIMIT = 1e6


def resolve_period(args) -> str:
    """``args.period`` from ``--period`` or the deprecated ``--duration`` (its old name; both
    is an error), the default otherwise; returns the option's name as the user wrote it,
    for the messages."""
    require_numbers(args, "period", "duration")
    if args.duration is not None and "period" in getattr(args, "given", ()):
        raise ModelError("--duration: deprecated name of --period; give --period only")
    if args.duration is not None:
        args.period = args.duration
        return "--duration"
    return "--period"


def check_options(args) -> None:
    """Every option checked, and ``-o`` writable, before the optimiser starts (it runs for
    minutes); a ModelError names the option and, for a cap, how to raise it."""
    opt = resolve_period(args)
    require_numbers(args, "iterations", "seed", "period", "rate", "harmonics")
    for name in ("vmax", "amax"):
        if getattr(args, name) is not None and not all(isinstance(v, float) for v in getattr(args, name)):
            raise ModelError(f"--{name}: expected numbers, got {getattr(args, name)!r:.60}")
    if not isinstance(args.output, str):
        raise ModelError(f"-o: expected a file path, got {args.output!r:.60}")
    if args.iterations < 0:
        raise ModelError(f"--iterations: expected >= 0, got {args.iterations}")
    if args.seed < 0:
        raise ModelError(f"--seed: expected an integer >= 0, got {args.seed}")
    for name, label, unit in (("period", opt, "s"), ("rate", "--rate", "Hz")):
        v = getattr(args, name)
        if not (math.isfinite(v) and v > 0):
            raise ModelError(f"{label}: expected a positive finite number in {unit}, got {v}")
    if args.harmonics < 1:
        raise ModelError(f"--harmonics: expected >= 1, got {args.harmonics}")
    limits.check_count(args.harmonics, "--harmonics", "the number of harmonics per joint",
                       "MAX_HARMONICS", cli=True)
    samples = args.period * args.rate
    limits.check_count(samples, f"--rate x {opt}", "the number of samples", "MAX_EXCITATION_SAMPLES",
                       cli=True)
    if round(samples) < 2:
        raise ModelError(f"--rate x {opt}: {args.rate:g} Hz over {args.period:g} s gives "
                         f"{round(samples)} sample(s); expected at least 2")
    if args.ramp != "auto":
        try:
            args.ramp = float(args.ramp)
        except (TypeError, ValueError):
            raise ModelError(f"--ramp: expected seconds >= 0 or 'auto', got {args.ramp!r:.40}") from None
        if not (math.isfinite(args.ramp) and args.ramp >= 0):
            raise ModelError(f"--ramp: expected seconds >= 0 or 'auto', got {args.ramp}")
        if 0 < args.ramp < 1.0 / args.rate:
            raise ModelError(f"--ramp: {args.ramp:g} s is shorter than one sample (1 / --rate = {1.0 / args.rate:g} "
                             "s); expected 0 (no ramp), 'auto', or at least one sample")
        limits.check_count((args.period + 2 * args.ramp) * args.rate, f"--rate x ({opt} + 2 --ramp)",
                           "the number of samples", "MAX_EXCITATION_SAMPLES", cli=True)
    for name in ("vmax", "amax"):
        for v in getattr(args, name) or ():
            if not (math.isfinite(v) and 0 < v <= MAX_RATE_LIMIT):
                raise ModelError(f"--{name}: expected positive limits of at most {MAX_RATE_LIMIT:g} "
                                 f"(rad/s, m/s, or per s^2), got {v}")
    check_outputs([("-o", args.output)], [("MODEL", args.model)])


def run(args) -> int:
    from ..identification import excitation

    if args.ptp is not None:             # the point-to-point design (excite_ptp.py)
        return excite_ptp.run(args)
    try:
        if args.rest is not None:
            raise ModelError("--rest: only with --ptp N (the point-to-point run's rests)")
        check_options(args)
        arm, notes = load_arm(args.model, args.tip)
        ex = excitation(arm, duration=args.period, harmonics=args.harmonics, rate=args.rate,
                        seed=args.seed, vmax=args.vmax, amax=args.amax, iterations=args.iterations,
                        friction=args.friction, ramp=args.ramp,
                        progress=Progress("optimising", progress_wanted(args), unit="iterations"))
        ex.to_csv(args.output)
    except ModelError as exc:
        return usage_error("excite", str(exc))
    except OSError as exc:
        return usage_error("excite", f"{args.output}: cannot write: {exc.strerror or exc}")
    out = {"model": args.model, "output": args.output, "n": arm.n, "samples": int(len(ex.t)),
           "duration": ex.duration, "period": ex.period, "ramp": ex.ramp, "harmonics": int(ex.a.shape[1]),
           "rate": args.rate,
           "n_base": ex.n_base, "condition_number": ex.condition_number,
           "max_abs_qd": [float(x) for x in abs(ex.qd).max(axis=0)],
           "max_abs_qdd": [float(x) for x in abs(ex.qdd).max(axis=0)], "notes": list(notes)}
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        ramp = (f" ({ex.ramp:g} s ramps from and to rest around a {ex.period:g} s period)" if ex.ramp
                else " (one period, no ramp: it starts moving)")
        print(f"wrote {args.output}: {out['samples']} samples over {ex.duration:g} s{ramp}, {out['harmonics']} "
              f"harmonics; {ex.n_base} base parameters, condition number {ex.condition_number:.4g}",
              file=sys.stdout)
        for n in notes:                  # the model's notes, as check and track show them
            print(f"  note: {n}")
    if args.duration is not None:        # the old name: say what it set, and what the file holds
        print(f"excite: --duration is deprecated: it set the series' period ({ex.period:g} s), not the file's "
              f"length ({ex.duration:g} s with the ramps); write --period {ex.period:g}", file=sys.stderr)
    return EXIT_OK
