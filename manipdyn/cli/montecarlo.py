"""``manipdyn montecarlo``: a seeded robustness study of the tracking controllers.

Layer 7 (CLI, the top).

    manipdyn montecarlo MODEL [--tip LINK] --runs N [--controllers pd,pdg,ct,adaptive,lqr]
                        [--seed S] [--scheduler tcp://HOST:PORT] [--json] [--plot FILE.png]
                        [--plants-from IDENTIFIED.json] [--report FILE.html]
                        [--simulator manipdyn|mujoco] [--mujoco-plant model|file]

Exit codes: 0 the study completed (diverged runs are results, not failures),
2 usage or model error, or a missing extra, or no scheduler at the address
(one line on stderr), 3 internal error.
"""

from __future__ import annotations

import argparse
import json
import math

from ..control.demo import CONTROLLERS, DEFAULT_BANDWIDTH
from .._support.errors import ModelError
from ..control.montecarlo import DISTRIBUTIONS_HELP, Distributions, check_study_size, load_identified, run as run_study, study
from ..check.scale import check_scheduler
from ..control.montecarlo.plot import plot_report
from .common import (EXIT_OK, TIP_HELP, Progress, add_progress_options, check_outputs, check_report_target,
                     command_line, load_arm, progress_wanted, require_numbers)

__all__ = ["register", "run"]


def _finite(args, name: str, low: float, strict: bool = False) -> float:
    v = getattr(args, name)
    if not math.isfinite(v) or (v <= low if strict else v < low):
        raise ModelError(f"--{name.replace('_', '-')}: must be a finite number {'>' if strict else '>='} "
                         f"{low:g}, got {v}")
    return v


def run(args) -> int:
    require_numbers(args, "runs", "seed", "workers", "chunk_size", "duration", "dt", "bandwidth", "tau_max",
                    *(field for field, _, _ in _DISTRIBUTION_OPTIONS))
    if not isinstance(args.controllers, str) or not isinstance(args.scheduler, (str, type(None))):
        raise ModelError("--controllers, --scheduler: expected text")
    if args.runs < 1:
        raise ModelError(f"--runs: must be >= 1, got {args.runs}")
    if args.seed < 0:
        raise ModelError(f"--seed: must be >= 0, got {args.seed}")
    keys = [k.strip().lower() for k in args.controllers.split(",") if k.strip()]  # names in any case
    bad = [k for k in keys if k not in CONTROLLERS]
    if not keys or bad or len(set(keys)) != len(keys):
        raise ModelError(f"--controllers: expected distinct names among {','.join(CONTROLLERS)}, "
                         f"got {args.controllers!r}")
    if args.chunk_size is not None and args.chunk_size < 1:
        raise ModelError(f"--chunk-size: must be >= 1 run, got {args.chunk_size}")
    for name in ("duration", "dt", "bandwidth"):
        _finite(args, name, 0.0, strict=True)
    if args.dt > args.duration:
        raise ModelError(f"--dt: must be at most --duration, got {args.dt}")
    if args.workers is not None and args.workers < 1:
        raise ModelError(f"--workers: must be >= 1, got {args.workers}")
    check_scheduler(args.scheduler, "--scheduler")
    if args.simulator != "mujoco" and args.mujoco_plant is not None:
        raise ModelError("--mujoco-plant: only with --simulator mujoco")
    check_study_size(args.runs, len(keys), args.duration, args.dt, args.bandwidth, cli=True)
    # fail before a long run, not after it
    check_report_target(args.report)
    check_outputs([("--plot", args.plot), ("--report", args.report)],
                  [("MODEL", args.model), ("--plants-from", args.plants_from)],
                  plots=("--plot",))
    if args.plants_from is not None:
        given = [f"--{f.replace('_', '-')}" for f in _REPLACED_BY_PLANTS if f in getattr(args, "given", ())]
        if given:
            raise ModelError(f"{', '.join(given)}: not with --plants-from (the identification's distribution "
                             "replaces the payload, link and friction draws)")
        for f in _REPLACED_BY_PLANTS:
            setattr(args, f, 0.0)
    try:
        dist = Distributions(**{field: getattr(args, field) for field, _, _ in _DISTRIBUTION_OPTIONS})
    except ValueError as exc:
        raise ModelError(f"distributions: {exc}") from None
    tau_max = None
    if args.tau_max is not None:
        if not (args.tau_max > 0):
            raise ModelError(f"--tau-max: must be > 0 N m, got {args.tau_max}")
        tau_max = args.tau_max

    plants = None
    if args.plants_from is not None:
        if not isinstance(args.plants_from, str):
            raise ModelError("--plants-from: expected a file name")
        plants = load_identified(args.plants_from)
    arm, notes = load_arm(args.model, args.tip)     # the model's notes are shown, as check and track show them
    try:
        s = study(arm, args.runs, seed=args.seed, controllers=keys, duration=args.duration, dt=args.dt,
                  distributions=dist, tau_max=tau_max, bandwidth=args.bandwidth, plants=plants,
                  simulator=args.simulator, mujoco_plant=args.mujoco_plant or "model")
    except ValueError as exc:
        raise ModelError(str(exc)) from None
    show = progress_wanted(args)
    report = run_study(s, scheduler=args.scheduler, workers=args.workers, chunk_size=args.chunk_size,
                       progress=Progress(arm.name or args.model, show, unit="runs"))
    if args.json:
        print(json.dumps({**json.loads(report.to_json()), "notes": list(notes)}, indent=2))
    else:
        print(report)
        for n in notes:
            print(f"  note: {n}")
    if args.plot:
        plot_report(report, args.plot)
        if not args.json:
            print(f"figure written to {args.plot}")
    if args.report:
        report.report_html(args.report, command=command_line(args), plants_file=args.plants_from, notes=notes)
        if not args.json:
            print(f"report written to {args.report}")
    return EXIT_OK


#: the options of the plant distributions: (Distributions field, metavar, what it draws)
_DISTRIBUTION_OPTIONS = (
    ("payload_mass", "KG", "payload mass uniform in [0, KG]"),
    ("link_scale", "F", "link mass/inertia factor uniform in [1-F, 1+F]"),
    ("friction_viscous", "NMS", "added viscous friction uniform in [0, NMS]"),
    ("friction_coulomb", "NM", "added Coulomb friction uniform in [0, NM]"),
    ("q0_offset", "RAD", "standard deviation of the initial position offset"),
    ("torque_noise", "NM", "standard deviation of the applied-torque noise"),
    ("payload_rel", "F", "payload mass bound: the mass whose torque first reaches F tau_j on a joint"),
    ("friction_viscous_rel", "F", "added viscous friction uniform in [0, F tau_j / qd_j] per joint"),
    ("friction_coulomb_rel", "F", "added Coulomb friction uniform in [0, F tau_j] per joint"),
    ("torque_noise_rel", "F", "standard deviation of the applied-torque noise, F tau_j per joint"),
)
#: the draws an identification's distribution replaces (``--plants-from``)
_REPLACED_BY_PLANTS = ("payload_mass", "link_scale", "friction_viscous", "friction_coulomb", "payload_rel",
                       "friction_viscous_rel", "friction_coulomb_rel")
#: absolute figures: given (even 0), their sized counterpart defaults to 0 (Distributions)
_ABSOLUTE = ("payload_mass", "friction_viscous", "friction_coulomb", "torque_noise")


class _Given(argparse.Action):
    """Store the value and remember, in ``args.given``, that the option was on the command line."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)
        namespace.given = set(getattr(namespace, "given", ())) | {self.dest}


def register(subparsers) -> None:
    """Add ``manipdyn montecarlo``."""
    d = Distributions()
    p = subparsers.add_parser(
        "montecarlo", help="robustness study of the tracking controllers on varied plants",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Simulate the tracking controllers on the 'track' demo path, on many plants drawn "
                    "around the model (seeded per run: a run's plant depends only on --seed and its "
                    "index), and report per controller the distribution of tracking error and torque, "
                    "divergences and torque saturations, and the worst runs (replay one with "
                    "manipdyn.control.montecarlo's study.replay(run, controller), i.e. manipdyn.simulate). "
                    "Runs on every local core by default, or on a Dask cluster with --scheduler; "
                    "the results are bit-identical either way.",
        epilog=DISTRIBUTIONS_HELP + "\n\nExit codes: 0 study completed (divergences are results), "
               "2 usage or model error, 3 internal error.")
    p.add_argument("model", metavar="MODEL", help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd)")
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("--runs", type=int, default=100, help="runs (plants) per controller (default 100)")
    p.add_argument("--controllers", default=",".join(CONTROLLERS), metavar="LIST",
                   help="comma-separated subset of pd, pdg (PD + gravity), ct (computed torque), "
                        "adaptive (Slotine-Li), lqr (time-varying LQR along the path), in any case; "
                        "default all five")
    p.add_argument("--seed", type=int, default=0, help="study seed (default 0)")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="run on this Dask scheduler (default, or 'local': a local cluster on every core; "
                        "'sync': in this process)")
    p.add_argument("--workers", type=int, default=None, help="local worker processes (default: one per core)")
    p.add_argument("--chunk-size", type=int, default=None, metavar="RUNS",
                   help="runs per task (default: about 4 tasks per worker, at most 25)")
    p.add_argument("--duration", type=float, default=2.0, metavar="S", help="simulated seconds per run (default 2)")
    p.add_argument("--dt", type=float, default=1e-3, metavar="S", help="step and controller period (default 0.001)")
    p.add_argument("--bandwidth", type=float, default=DEFAULT_BANDWIDTH, metavar="RAD_S",
                   help=f"closed-loop bandwidth of the controllers (default {DEFAULT_BANDWIDTH:g})")
    p.add_argument("--tau-max", type=float, default=None, metavar="NM",
                   help="torque limit of every joint for every controller (default: the model's own, if any)")
    for field, metavar, what in _DISTRIBUTION_OPTIONS:
        default = getattr(d, field)
        replaced = field in _REPLACED_BY_PLANTS
        rel = {"payload_mass": "payload_rel"}.get(field, field + "_rel")
        said = (f"default {default:g}" if field not in _ABSOLUTE else
                f"absolute, default 0; given, even 0, --{rel.replace('_', '-')} then defaults to 0")
        # absolute figures and sized ones: None when not given, so that Distributions tells them apart
        none = field in _ABSOLUTE or field.endswith("_rel")
        p.add_argument("--" + field.replace("_", "-"), type=float, metavar=metavar, default=None if none else default,
                       action=_Given if replaced else "store",
                       help=f"{what} ({said}" + (", not with --plants-from)" if replaced else ")"))
    p.add_argument("--plants-from", metavar="IDENTIFIED.json", default=None,
                   help="draw every run's plant from this identification's uncertainty (a base model of "
                        "'manipdyn identify --base-json', method wls or consistent): Gaussian base "
                        "parameters (the block bootstrap's covariance when the file has enough refits), mapped to "
                        "full parameters; a draw that is no physical arm becomes the nearest one (J_i >= 0, "
                        "friction >= 0) in the metric of the covariance; "
                        "the payload, link and friction options then do not apply (default: the "
                        "hand-chosen distributions below)")
    p.add_argument("--simulator", choices=("manipdyn", "mujoco"), default="manipdyn",
                   help="who steps the plants: manipdyn's RK4 (default) or MuJoCo's RK4 on each drawn plant's "
                        "MJCF, one run at a time (the mujoco extra); the same seed draws the same plants")
    p.add_argument("--mujoco-plant", choices=("model", "file"), default=None,
                   help="with --simulator mujoco: 'model' (default) the plant manipdyn simulates (constraints "
                        "off, the drawn Coulomb friction as manipdyn's sharp sign at every Runge-Kutta stage), "
                        "or 'file' the MJCF as MuJoCo loads it (Coulomb as frictionloss, a soft constraint)")
    p.add_argument("--json", action="store_true", help="print one JSON document instead of tables")
    p.add_argument("--plot", metavar="FILE.png", default=None, help="write the CDFs per controller (needs matplotlib)")
    p.add_argument("--report", metavar="FILE.html", default=None,
                   help="also write one self-contained HTML page (no scripts, nothing fetched): what was run, the "
                        "verdict, the distributions per controller, divergences and causes, the worst runs, the "
                        "CDF figure (default: none)")
    add_progress_options(p, "the progress bar")
    p.set_defaults(func=run)
