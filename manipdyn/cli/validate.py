"""``manipdyn validate MODEL|BASE.json DATA [--json] [--plot FIG.png]``: score a model on data.

Layer 7 (CLI, the top).

MODEL is anything ``manipdyn`` loads (a bundled name, a .toml model file, a URDF) or a
base model JSON written by ``manipdyn identify``.  DATA is read as ``identify`` reads it.
Per joint: RMS error, RMS relative to the measured RMS, R^2 and the mean error
(:mod:`manipdyn.identification.validation`).

Exit codes: 0 scored; 2 usage, model or data error (one line on stderr).
"""

from __future__ import annotations

import os

import json

from .._support.errors import ModelError
from .logopts import DATA_HELP, log_options_from_args, register_log_options
from .common import EXIT_OK, TIP_HELP, check_outputs, load_arm, usage_error

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add ``manipdyn validate`` to the command line."""
    p = subparsers.add_parser(
        "validate", help="score a model's torque predictions on (held-out) joint data",
        description="Predict the joint torques of DATA with MODEL (a model, or a base model JSON "
                    "from identify) and report per joint the RMS error, the RMS relative to the "
                    "measured RMS, R^2 and the mean error. Exit codes: 0 scored, 2 usage, model or "
                    "data error.")
    p.add_argument("model", metavar="MODEL|BASE.json", help="model name, .toml, .urdf, or a base model JSON")
    p.add_argument("data", metavar="DATA", help=DATA_HELP)
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    p.add_argument("--plot", metavar="FIG.png", default=None,
                   help="draw measured and predicted torque per joint (needs the plot extra)")
    register_log_options(p)
    p.set_defaults(func=run)


def load_model(spec: str, tip=None):
    """An arm or a base model: ``(model, label)``."""
    if spec.lower().endswith(".json"):
        from ..identification.basemodel import load_base_model

        if tip is not None:
            raise ModelError(f"--tip: a base model ({spec}) carries its own chain (the identification's "
                             "prior); --tip is for a tree URDF given as MODEL")
        m = load_base_model(spec)
        # the file first: "panda (base model)" read as the bundled arm
        return m, f"{os.path.basename(spec)} (base parameters identified from {m.name})"
    arm, _ = load_arm(spec, tip)
    return arm, arm.name


def run(args) -> int:
    from ..identification import read_log
    from ..identification.validation import plot_validation, validate

    try:
        check_outputs([("--plot", args.plot)], [("MODEL", args.model), ("DATA", args.data)], plots=("--plot",))
        model, label = load_model(args.model, args.tip)
        arm = getattr(model, "arm", model)
        data = read_log(args.data, model.n, transmission=getattr(arm, "transmission", None),
                        **log_options_from_args(args, list(getattr(arm, "joint_names", None) or []) or None))
        res = validate(model, data, name=label)
        if args.plot:
            units = ["N" if t == "prismatic" else "N m"
                     for t in getattr(getattr(model, "arm", model), "joint_types", ["revolute"] * model.n)]
            plot_validation(res, args.plot, units=units)
    except ModelError as exc:
        return usage_error("validate", str(exc))
    if args.json:
        out = res.to_dict()
        out.update({"data": args.data, "plot": args.plot})
        print(json.dumps(out, indent=2, allow_nan=False))
    else:
        print(res.format())
        if args.plot:
            print(f"wrote {args.plot}")
    return EXIT_OK
