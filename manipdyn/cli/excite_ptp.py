"""``manipdyn excite MODEL --ptp N -o traj.csv``: a point-to-point run with rests.

Layer 7 (CLI, the top).

The options and the run of ``excite --ptp`` (:mod:`manipdyn.identification.experiments.ptp`);
:mod:`manipdyn.cli.excite` registers them beside the Fourier design's and hands the run here.  Writes the
file the Fourier design writes (``t,q1..qn,qd1..qdn,qdd1..qddn``).  Exit codes: 0 written,
2 usage or model error (one line on stderr).
"""

from __future__ import annotations

import json
import math
import sys

from .._support.errors import ModelError
from .common import EXIT_OK, check_outputs, load_arm, require_numbers, usage_error

__all__ = ["add_options", "run"]

#: the Fourier design's options and their defaults: refused with --ptp unless left as they are
_FOURIER_ONLY = (("harmonics", 5, "--harmonics"), ("iterations", 60, "--iterations"), ("ramp", "auto", "--ramp"),
                 ("friction", False, "--friction"), ("duration", None, "--duration"))


def add_options(p) -> None:
    """Add ``--ptp`` and ``--rest`` to ``excite``'s parser ``p``."""
    from ..identification.experiments.ptp import DEFAULT_REST, MAX_POSTURES

    p.add_argument("--ptp", type=int, default=None, metavar="N",
                   help="instead of the Fourier series: a point-to-point run through N postures (1 to "
                        f"{MAX_POSTURES}) spread over the joint limits (greedy maximin, seeded by --seed), "
                        "starting at rest at the middle of the limits and resting --rest s at each posture; "
                        "septic smoothstep moves within --vmax/--amax (--rate, --vmax, --amax, --seed apply; "
                        "--period, --harmonics, --iterations, --ramp, --friction do not)")
    p.add_argument("--rest", type=float, default=None, metavar="S",
                   help=f"with --ptp: seconds held at the start and at each posture (default {DEFAULT_REST:g}; "
                        "0: a stop of one sample)")


def check_options(args) -> None:
    """The --ptp run's options; a ModelError names the option."""
    from ..identification.experiments.ptp import DEFAULT_REST, MAX_POSTURES

    require_numbers(args, "ptp", "rest", "rate", "seed")
    if not 1 <= args.ptp <= MAX_POSTURES:
        raise ModelError(f"--ptp: expected a number of postures from 1 to {MAX_POSTURES}, got {args.ptp}")
    for name, default, label in _FOURIER_ONLY:
        if getattr(args, name) != default:
            raise ModelError(f"{label}: an option of the Fourier design, not of --ptp; leave it out")
    if "period" in getattr(args, "given", ()):
        raise ModelError("--period: an option of the Fourier design, not of --ptp; leave it out")
    if args.rest is None:
        args.rest = DEFAULT_REST
    if not (math.isfinite(args.rest) and args.rest >= 0):
        raise ModelError(f"--rest: expected seconds >= 0, got {args.rest}")
    if not (math.isfinite(args.rate) and args.rate > 0):
        raise ModelError(f"--rate: expected a positive finite number in Hz, got {args.rate}")
    if 0 < args.rest < 1.0 / args.rate:
        raise ModelError(f"--rest: {args.rest:g} s is shorter than one sample (1 / --rate = {1.0 / args.rate:g} s); "
                         "expected 0 (a stop of one sample) or at least one sample")
    if args.seed < 0:
        raise ModelError(f"--seed: expected an integer >= 0, got {args.seed}")
    for name in ("vmax", "amax"):
        vals = getattr(args, name)
        if vals is not None and not all(isinstance(v, float) and math.isfinite(v) and v > 0 for v in vals):
            raise ModelError(f"--{name}: expected positive finite limits (one or n values), got {vals!r:.60}")
    if not isinstance(args.output, str):
        raise ModelError(f"-o: expected a file path, got {args.output!r:.60}")
    check_outputs([("-o", args.output)], [("MODEL", args.model)])


def run(args) -> int:
    """``excite --ptp``: design, write, report."""
    from ..identification.experiments.ptp import condition_number, point_to_point

    try:
        check_options(args)
        arm, notes = load_arm(args.model, args.tip)
        try:
            run_ = point_to_point(arm, args.ptp, rest=args.rest, rate=args.rate, seed=args.seed,
                                  vmax=args.vmax, amax=args.amax)
        except ModelError as exc:                 # the library names its arguments: say the options
            msg = str(exc)
            for arg, opt in (("postures", "--ptp"), ("rest", "--rest"), ("rate", "--rate"), ("vmax", "--vmax"),
                             ("amax", "--amax")):
                if msg.startswith(arg + ":"):
                    msg = opt + msg[len(arg):]
                    break
            raise ModelError(msg) from None
        run_.to_csv(args.output)
        cond, n_base = condition_number(arm, run_)
    except ModelError as exc:
        return usage_error("excite", str(exc))
    except OSError as exc:
        return usage_error("excite", f"{args.output}: cannot write: {exc.strerror or exc}")
    rest_time = float(run_.at_rest.mean())
    out = {"model": args.model, "output": args.output, "n": arm.n, "design": "point-to-point",
           "samples": int(len(run_.t)), "duration": run_.duration, "postures": int(args.ptp), "rest": run_.rest,
           "rate": args.rate, "seed": args.seed, "fraction_at_rest": rest_time,
           "n_base": n_base, "condition_number": cond,
           "moves": [[float(a), float(b)] for a, b in run_.moves],
           "max_abs_qd": [float(x) for x in abs(run_.qd).max(axis=0)],
           "max_abs_qdd": [float(x) for x in abs(run_.qdd).max(axis=0)], "notes": list(notes)}
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        print(f"wrote {args.output}: {out['samples']} samples over {run_.duration:g} s, {args.ptp} posture{'s' if args.ptp != 1 else ''} "
              f"(seed {args.seed}) with {run_.rest:g} s rests, at rest {100 * rest_time:.0f} % of the time; {n_base} base parameters, "
              f"condition number {cond:.4g}",
              file=sys.stdout)
        for n in notes:
            print(f"  note: {n}")
    return EXIT_OK
