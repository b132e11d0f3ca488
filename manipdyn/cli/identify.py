"""``manipdyn identify MODEL LOG [LOG ...] [--logs RUNS.toml] -o OUT.toml|OUT.urdf|OUT.json``.

Layer 7 (CLI, the top).  Parses, calls :func:`manipdyn.identification.identify` (the options are its
keyword arguments, under the same names and defaults), prints.  ``--payload``: identify a
payload carried by MODEL instead (:mod:`.identify_payload`).

Exit codes: 0 a model written; 1 only the base model could be written (the parameters are
no physical arm); 2 usage, model or data error (one line on stderr).
"""

from __future__ import annotations

import inspect
import json
import sys

from .._support.errors import ModelError
from .common import EXIT_OK, TIP_HELP, cli_message, usage_error
from .logopts import DATA_HELP, log_options_from_args, register_log_options

__all__ = ["register", "run"]

_H = {"--method": "ols, wls (weighted by per-joint noise), consistent (J_i >= 0; default)",
      "--friction": "identify viscous and Coulomb friction",
      "--friction-terms": "identify these friction terms instead: some of viscous, coulomb, asymmetric, offset, "
                          "stribeck, sigmoid (the shapes of the last two by variable projection)",
      "--friction-side": "with --friction-terms: the law acts on the joint or the motor velocities",
      "--smoothing": "with --friction-terms: Coulomb sign as tanh(v / V) (default 0.01 rad/s; 0 = sharp)",
      "--stribeck-velocity": "with ...,stribeck: the search's start, rad/s on the law's side (default 0.1 |R_kk|)",
      "--sigmoid-alpha": "with ...,sigmoid: the search's start, s/rad on the law's side (default 10 / |R_kk|)",
      "--armature": "identify armature (reflected rotor inertia)",
      "--mass-bound": "consistent: each link's mass within +-F (fraction) of the prior's (default 0.5)",
      "--com-bound": "consistent: each COM within +-M metres of the prior's, per axis (default 0.1)",
      "--total-mass-bound": "consistent: total mass within +-F (fraction) of the prior's (default 0.25)",
      "--no-bounds": "consistent: no plausibility bounds, only J_i >= 0",
      "--prior-weight": "consistent: entropic pull towards the prior (0: the data alone; auto: by 5-fold "
                        "blocked cross-validation)",
      "--bootstrap": "also refit on N block-resampled copies and report each base parameter's spread",
      "--scheduler": "--bootstrap on Dask: 'local' or tcp://HOST:PORT (default: in this process)",
      "--identify-torque-constants": "k_t per motor from current logs (i1..in): the scale from a run with a "
                                     "payload (--logs) or from the model's torque_constant; written to [transmission]",
      "--torque-constant-reference": "motors (1-based, e.g. 1,2) whose model k_t fixes the scale (default all)",
      "--base-json": "also write the base model (base parameters, standard deviations) here"}


def register(subparsers) -> None:
    """Add ``manipdyn identify`` to the command line."""
    from ..identification import METHODS

    p = subparsers.add_parser("identify", help="identify inertial parameters from joint data", description=(
        "Identify the arm's base parameters from logged joint positions and torques (several logs: each read on "
        "its own) and write the model closest to the prior. Exit codes: 0 model written, 1 only a base model "
        "(JSON) written, 2 usage, model or data error."))
    p.add_argument("model", metavar="MODEL", help="prior: bundled name, .toml model file or URDF")
    p.add_argument("data", metavar="LOG", nargs="*", help=DATA_HELP)
    p.add_argument("--logs", metavar="RUNS.toml", default=None, help="[[log]] tables: path, t_range, rate, columns, "
                   "payload = {mass, com, inertia} (README: several logs)")
    p.add_argument("-o", "--output", default=None, metavar="OUT.toml|OUT.urdf|OUT.json",
                   help="model file to write (.json: the base model only); required unless --payload")
    p.add_argument("--method", choices=METHODS, default="consistent", help=_H["--method"])
    p.add_argument("--payload", action="store_true", help="identify only a rigid payload carried by MODEL")
    p.add_argument("--payload-link", metavar="NAME", default=None, help="with --payload: the link carrying it")
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    for flag in ("--friction", "--armature", "--no-bounds", "--identify-torque-constants"):
        p.add_argument(flag, action="store_true", help=_H[flag])
    for flag, kind, meta in (("--friction-terms", str, "T1,T2"), ("--smoothing", float, "V"),
                             ("--stribeck-velocity", float, "V"), ("--sigmoid-alpha", float, "A"),
                             ("--mass-bound", float, "F"), ("--com-bound", float, "M"),
                             ("--total-mass-bound", float, "F"), ("--scheduler", str, "ADDR"),
                             ("--torque-constant-reference", str, "K1,K2"), ("--base-json", str, "FILE.json")):
        p.add_argument(flag, type=kind, default=None, metavar=meta, help=_H[flag])
    p.add_argument("--friction-side", choices=("joint", "motor"), default="joint", help=_H["--friction-side"])
    p.add_argument("--prior-weight", default=0.0, metavar="W|auto", help=_H["--prior-weight"])
    p.add_argument("--bootstrap", type=int, default=0, metavar="N", help=_H["--bootstrap"])
    p.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    register_log_options(p)
    p.set_defaults(func=run)


def library_options(args, function) -> dict:
    """The keyword arguments of ``function`` that ``args`` holds (the log options read and checked)."""
    names = inspect.signature(function).parameters
    out = {k: v for k, v in vars(args).items() if k in names and k not in ("prior", "logs", "models")}
    out["t_range"] = log_options_from_args(args)["t_range"]
    return out


def run(args) -> int:
    from ..identification import identify

    if args.payload:
        from .identify_payload import run_payload

        return run_payload(args)
    try:
        if args.payload_link is not None:
            raise ModelError("--payload-link: only with --payload")
        if args.output is None:
            raise ModelError("-o/--output: required (the model file to write), unless --payload")
        if not args.output.lower().endswith((".toml", ".urdf", ".json")):
            raise ModelError(f"-o: expected a file name ending in .toml, .urdf or .json, got {args.output!r}")
        logs = list(args.data) + ([args.logs] if args.logs else [])
        if not logs:
            raise ModelError("LOG: give at least one log, or --logs RUNS.toml")
        opts = library_options(args, identify)
        if args.torque_constant_reference is not None:
            try:
                opts["torque_constant_reference"] = [int(k) for k in args.torque_constant_reference.split(",")]
            except ValueError:
                raise ModelError(f"--torque-constant-reference: expected motor numbers like 1,2, got "
                                 f"{args.torque_constant_reference!r}") from None
        result = identify(args.model, logs, **opts)
    except ModelError as exc:
        return usage_error("identify", cli_message(exc))
    except OSError as exc:
        return usage_error("identify", f"{exc.filename or args.output}: cannot write: {exc.strerror or exc}")
    print(json.dumps(result.report(), indent=2, allow_nan=False, default=str) if args.json else result.format())
    if result.exit_code != EXIT_OK:
        print(f"manipdyn identify: the {args.method} parameters are not a physical arm, so no model file was "
              f"written, only the base model {result.base_model}: {result.fit.arm_error or 'a J_i is not >= 0'}; "
              "--method consistent always gives a physical arm", file=sys.stderr)
    return result.exit_code
