"""``manipdyn identify MODEL LOG [LOG ...] [--logs RUNS.toml] -o OUT.toml|OUT.urdf|OUT.json [--report FILE.html]``.

Layer 7 (CLI, the top).  Parses, calls :func:`manipdyn.identification.identify` (the options
are its keyword arguments, under the same names and defaults), prints.  ``--payload``:
identify a payload carried by MODEL instead (:mod:`.identify_payload`).

Exit codes: 0 a model written; 1 only the base model could be written (the parameters are
no physical arm); 2 usage, model or data error (one line on stderr).
"""

from __future__ import annotations

import json
import sys

from .._support.errors import ModelError
from .common import (EXIT_OK, TIP_HELP, Progress, add_progress_options, cli_message, command_line,
                     progress_wanted, usage_error)
from .logopts import DATA_HELP, library_options, register_log_options

__all__ = ["register", "run"]

#: (flag, default, type or action, metavar, help): the options of the library's identify
OPTIONS = (
    ("--method", "consistent", None, None, "ols, wls (each joint by its noise), consistent (J_i >= 0; default)"),
    ("--friction", False, "store_true", None, "identify viscous and Coulomb friction"),
    ("--friction-terms", None, str, "T1,T2", "some of viscous, coulomb, asymmetric, offset, stribeck, sigmoid"),
    ("--friction-side", None, None, None, "with --friction(-terms): the law acts on the joint or motor velocities "
     "(default: motor when the torques were logged at the motors and the [transmission] couples joints, else joint)"),
    ("--smoothing", None, float, "V", "with --friction-terms: Coulomb as tanh(v / V) (default: the lowest blocked "
     "held-out error among the velocity's noise level on the log times 1/30 to 30, candidates and scores in the "
     "notes; 0 sharp)"),
    ("--stribeck-velocity", None, float, "V", "start of the Stribeck search, rad/s on the law's side "
     "(default 0.1 rad/s at the joint, scaled by the gear ratio on the motor side)"),
    ("--sigmoid-alpha", None, float, "A", "start of the sigmoid search, s/rad on the law's side "
     "(default 10 s/rad at the joint, scaled by the gear ratio on the motor side)"),
    ("--armature", False, "store_true", None, "identify armature (reflected rotor inertia)"),
    ("--mass-bound", None, float, "F", "consistent: each link's mass within +-F of the prior's (default 0.5)"),
    ("--com-bound", None, float, "M", "consistent: each COM within +-M m of the prior's, per axis (default 0.1)"),
    ("--total-mass-bound", None, float, "F", "consistent: total mass within +-F of the prior's (default 0.25)"),
    ("--no-bounds", False, "store_true", None, "consistent: no plausibility bounds, only J_i >= 0"),
    ("--prior-weight", None, None, "W|auto", "consistent: weight of the pull of each body towards the prior's "
     "(log-det divergence) and of the drive terms on their own scales; default auto: chosen on the hold-outs by "
     "torque and forward-dynamics (acceleration) error; 0: the data alone"),
    ("--bootstrap", 0, int, "N", "also refit on N block-resampled copies; each base parameter's spread (default 0, none)"),
    ("--scheduler", None, str, "ADDR", "--bootstrap on Dask: 'local' or tcp://HOST:PORT"),
    ("--band-folds", 5, int, "K", "refit on K-1 of K blocks in time and score the held-out one, for the 95 %% "
     "prediction band validate draws (model error and correlated noise; default 5, 0: none)"),
    ("--identify-torque-constants", False, "store_true", None, "k_t per motor from currents (i1..in), written "
     "to [transmission]; the scale from a payload run (--logs), the model's torque_constant, or else the "
     "prior's gravity torque (--scale-from-gravity)"),
    ("--torque-constant-reference", None, str, "K1,K2", "motors whose model k_t sets the scale (default all)"),
    ("--scale-from-gravity", None, str, "J1,J2", "with --identify-torque-constants and neither a payload run nor "
     "the model's torque_constant: the motors whose gravity torque in the prior sets the scale of the torque "
     "constants, i.e. trust the prior's masses and centres of mass of the links from the first of them to the tool "
     "(joint j carries links j..n); default: every motor whose prior gravity torque varies over the logs "
     "(a UR arm: 2,3)"),
    ("--base-json", None, str, "FILE.json", "also write the base model (base parameters, std) here"))


def register(subparsers) -> None:
    """Add ``manipdyn identify`` to the command line."""
    p = subparsers.add_parser("identify", help="identify inertial parameters from joint data", description=(
        "Identify the arm's base parameters from logged joint positions and torques (several logs: each read "
        "on its own) and write the model closest to the prior. Exit codes: 0 model written, 1 only a base "
        "model (JSON) written, 2 usage, model or data error."))
    p.add_argument("model", metavar="MODEL", help="prior: bundled name, .toml model file or URDF")
    p.add_argument("data", metavar="LOG", nargs="*", help=DATA_HELP)
    p.add_argument("--logs", metavar="RUNS.toml", default=None, help="[[log]] tables: path, t_range, rate, "
                   "columns, payload = {mass, com, inertia}")
    p.add_argument("-o", "--output", default=None, metavar="OUT.toml|OUT.urdf|OUT.json",
                   help="model file to write (.json: the base model only); required unless --payload")
    p.add_argument("--payload", action="store_true", help="identify only a rigid payload carried by MODEL")
    p.add_argument("--payload-link", metavar="NAME", default=None, help="with --payload: the link carrying it")
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    p.add_argument("--no-thresholds", action="store_true",
                   help="write no collision thresholds into the model's trust record (by default they are read off "
                        "the band's hold-outs, each watched by the momentum observer of its refit, at gain 100 1/s "
                        "and 1 false event per hour: manipdyn observe then needs no calibration logs)")
    p.add_argument("--velocity-cutoff", type=float, default=None, metavar="HZ",
                   help="the collision thresholds' observer low-passes its residual at this cut-off against the measured "
                        "velocity's noise, Hz (0: "
                        "none; default: the library's, manipdyn.control.collision.observer.DEFAULT_VELOCITY_CUTOFF); "
                        "recorded with them, and manipdyn observe uses the same")
    p.add_argument("--report", metavar="FILE.html", default=None,
                   help="also write one self-contained HTML page (no scripts, nothing fetched): what was done, "
                        "the verdict, per joint RMS in-sample and held out, the fit figure, the parameters with "
                        "their standard deviations and active bounds, the data notes (default: none)")
    from ..identification import METHODS

    choices = {"--method": METHODS, "--friction-side": ("joint", "motor")}
    for flag, default, kind, meta, text in OPTIONS:
        kw = {"action": kind} if kind == "store_true" else {"type": kind, "metavar": meta, "choices": choices.get(flag)}
        p.add_argument(flag, default=default, help=text, **{k: v for k, v in kw.items() if v is not None})
    register_log_options(p)
    add_progress_options(p, "each stage as it starts, and a bar over the bootstrap's refits")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..identification import identify
    from .preflight import check_identify

    try:
        check_identify(args)        # outputs and unbounded options, before any work
    except ModelError as exc:
        return usage_error("identify", str(exc))
    if args.payload:
        from .identify_payload import run_payload

        return run_payload(args)
    try:
        if args.payload_link is not None:
            raise ModelError("--payload-link: only with --payload")
        if args.output is None:
            raise ModelError("-o/--output: required (the model file to write), unless --payload")
        logs = list(args.data) + ([args.logs] if args.logs else [])
        if not logs:
            raise ModelError("LOG: give at least one log, or --logs RUNS.toml")
        opts = library_options(args, identify)
        if args.torque_constant_reference is not None:
            try:
                opts["torque_constant_reference"] = [int(k) for k in args.torque_constant_reference.split(",")]
            except ValueError:
                raise ModelError("--torque-constant-reference: expected motor numbers like 1,2, got "
                                 f"{args.torque_constant_reference!r}") from None
        if args.scale_from_gravity is not None:
            try:
                opts["scale_from_gravity"] = [int(k) for k in args.scale_from_gravity.split(",")]
            except ValueError:
                raise ModelError("--scale-from-gravity: expected motor numbers like 2,3, got "
                                 f"{args.scale_from_gravity!r}") from None
        opts["progress"] = stages(progress_wanted(args))
        result = identify(args.model, logs, **opts)
    except ModelError as exc:
        return usage_error("identify", cli_message(exc))
    except ConnectionError as exc:      # a scheduler that does not answer: not the output's fault
        return usage_error("identify", f"--scheduler: {exc}")
    except OSError as exc:
        return usage_error("identify", f"{exc.filename or args.output}: cannot write: {exc.strerror or exc}")
    thresholds = None if args.no_thresholds else collision_thresholds(result, logs, opts, args.velocity_cutoff)
    if args.report:
        try:
            result.report_html(args.report, command=command_line(args))
        except OSError as exc:
            return usage_error("identify", f"--report {args.report}: cannot write: {exc.strerror or exc}")
    if args.json:
        rep = result.report()
        if thresholds is not None:
            rep["collision_thresholds"] = thresholds
        print(json.dumps(rep, indent=2, allow_nan=False, default=str))
    else:
        print(result.format())
        if thresholds is not None:
            print(thresholds["line"])
    if args.report and not args.json:
        print(f"wrote {args.report} (the report)")
    if result.exit_code != EXIT_OK:
        print(f"manipdyn identify: the {args.method} parameters are not a physical arm, so no model file was "
              f"written, only the base model {result.base_model}: {result.fit.arm_error or 'a J_i is not >= 0'}; "
              "--method consistent always gives a physical arm", file=sys.stderr)
    return result.exit_code


def collision_thresholds(result, logs, opts, velocity_cutoff=None) -> dict | None:
    """The collision thresholds of the band's hold-outs
    (:func:`manipdyn.control.collision.holdouts.identified_thresholds`) written into the model file's trust record (key ``collision``), at the default gain and rate; ``{"line": ...}``
    (one line on what they came from and their values, or why there are none) plus the record; None when no model
    file was written."""
    from ..control.collision.holdouts import identified_thresholds
    from ..control.collision.observe import TRUST_KEY

    out = getattr(result, "output", None)
    if result.arm is None or out is None or str(out).lower().endswith(".json"):
        return None
    try:
        thr = identified_thresholds(result, logs, velocity_cutoff=velocity_cutoff, **opts)
    except ModelError as exc:
        return {"line": f"collision thresholds: none written ({cli_message(exc)})", "error": cli_message(exc)}
    result.provenance[TRUST_KEY] = thr.to_dict()
    result.rename(result.name)          # the arm's trust record from the provenance, now with the thresholds
    result.save(out)
    values = ", ".join(f"{x:.3g}" for x in thr.threshold)
    vel = f" (the residual low-passed at {thr.velocity_cutoff:g} Hz)" if thr.velocity_cutoff > 0 else ""
    line = (f"collision thresholds (gain {thr.gain:g} 1/s, {thr.false_alarms_per_hour:g} false event per hour): "
            f"[{values}] N m{vel}, from {thr.source}; in {out}'s trust record")
    return {"line": line, **thr.to_dict()}


def stages(enabled: bool):
    """The ``progress`` of :func:`manipdyn.identification.identify` drawn on stderr: one line per
    stage with the time since the start, and a bar over the bootstrap's refits; None when off."""
    if not enabled:
        return None
    lines, bars = Progress("identify", True), {}

    def tell(stage, done=None, total=None):
        if done is None:
            lines.stage(f"identify: {stage}")
        else:
            bars.setdefault(stage, Progress(stage, True, unit="refits"))(done, total)
    return tell
