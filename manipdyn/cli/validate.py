"""``manipdyn validate MODEL|BASE.json [MODEL2 ...] DATA [--json] [--plot FIG.png] [--predictions OUT.csv]``.

Layer 7 (CLI, the top).

MODEL is anything ``manipdyn`` loads (a bundled name, a .toml model file, a URDF) or a
base model JSON written by ``manipdyn identify``.  DATA is read as ``identify`` reads it.
Per joint: RMS error, RMS relative to the measured RMS, R^2 and the mean error
(:mod:`manipdyn.identification.validation`), the 95 % band's coverage and the joints
that leave the fitted range; several models: side by side, the best per joint marked
(:mod:`manipdyn.identification.comparison`).  The data notes are printed as ``identify``
prints them.

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
                    "measured RMS, R^2 and the mean error; with a model from identify, how often its 95 % "
                    "prediction band holds the measured torque and which joints leave the states it was "
                    "fitted on (EXTRAPOLATES). Several models: one table, the best per joint marked. "
                    "Exit codes: 0 scored, 2 usage, model or data error.")
    p.add_argument("model", metavar="MODEL|BASE.json", nargs="+",
                   help="model name, .toml, .urdf, or a base model JSON; several: scored side by side")
    p.add_argument("data", metavar="DATA", help=DATA_HELP)
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    p.add_argument("--plot", metavar="FIG.png", default=None,
                   help="draw measured and predicted torque per joint (needs the plot extra)")
    p.add_argument("--predictions", metavar="OUT.csv", default=None,
                   help="write t, tau1..n (measured), pred1..n, lo1..n, hi1..n (the 95 %% band) per sample")
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
    from ..identification.comparison import format_side_by_side, side_by_side_dict
    from ..identification.validation import plot_validation, validate, write_predictions

    try:
        if args.predictions and len(args.model) > 1:
            raise ModelError("--predictions: one MODEL at a time (the file holds one model's predictions)")
        check_outputs([("--plot", args.plot), ("--predictions", args.predictions)],
                      [*(("MODEL", m) for m in args.model), ("DATA", args.data)], plots=("--plot",))
        models = [load_model(spec, args.tip) for spec in args.model]
        model, label = models[0]
        arm = getattr(model, "arm", model)
        data = read_log(args.data, model.n, transmission=getattr(arm, "transmission", None),
                        **log_options_from_args(args, list(getattr(arm, "joint_names", None) or []) or None))
        results = [validate(m, data, name=lab) for m, lab in models]
        res = results[0]
        if args.predictions:
            write_predictions(res, args.predictions)
        if args.plot:
            units = ["N" if t == "prismatic" else "N m"
                     for t in getattr(getattr(model, "arm", model), "joint_types", ["revolute"] * model.n)]
            plot_validation(results, args.plot, units=units)
    except ModelError as exc:
        return usage_error("validate", str(exc))
    except OSError as exc:
        return usage_error("validate", f"{exc.filename or args.predictions}: cannot write: {exc.strerror or exc}")
    notes = list(getattr(data, "notes", []))
    if args.json:
        out = res.to_dict() if len(results) == 1 else side_by_side_dict(results)
        out.update({"data": args.data, "plot": args.plot, "predictions": args.predictions, "data_notes": notes})
        print(json.dumps(out, indent=2, allow_nan=False))
    else:
        for note in notes:
            print(f"data: {note}")
        print(res.format() if len(results) == 1 else format_side_by_side(results))
        for path in (args.predictions, args.plot):
            if path:
                print(f"wrote {path}")
    return EXIT_OK
