"""``manipdyn validate MODEL [MODEL ...] LOG [LOG ...] [--logs RUNS.toml] [--json] [--plot FIG.png]
[--predictions OUT.csv] [--report FILE.html]``.

Layer 7 (CLI, the top).  Parses, calls :func:`manipdyn.identification.validate` (same options, same
defaults), prints.  MODEL is anything ``manipdyn`` loads or a base model JSON from
``identify``; a LOG is a .csv, .mcap or .bag file or a bag directory (without any, the last
argument is the log).  Several logs are read each on its own and scored together; several
models side by side, the best per joint marked.  With a model from ``identify``: how often its
95 % prediction band holds the measured torque and the joints that leave the states it was
fitted on.  The data notes are printed first, as ``identify`` prints them.

Exit codes: 0 scored; 2 usage, model or data error (one line on stderr).
"""

from __future__ import annotations

import json
import os

from .._support.errors import ModelError
from .argblocks import add_command, add_models_and_logs, add_outputs
from .common import EXIT_OK, check_outputs, check_report_target, cli_message, command_line, usage_error
from .logopts import library_options

__all__ = ["register", "run", "split_inputs", "load_model"]

#: what a log file's name ends with (a directory is a ROS 2 bag)
LOG_SUFFIXES = (".csv", ".mcap", ".bag", ".db3", ".txt", ".tsv")


def register(subparsers) -> None:
    """Add ``manipdyn validate`` to the command line."""
    p = add_command(
        subparsers, "validate", "score a model's torque predictions on (held-out) joint data",
        "Predict the joint torques of the logs with each MODEL (a model, or a base model JSON from "
        "identify) and report per joint the RMS error, the RMS relative to the measured RMS, R^2 and "
        "the mean error; with a model from identify, how often its 95 % prediction band holds the "
        "measured torque and which joints leave the states it was fitted on (EXTRAPOLATES). Several "
        "models: one table, the best per joint marked. Exit codes: 0 scored, 2 usage, model or data "
        "error.", run)
    add_models_and_logs(p, "name, .toml, .urdf, base model .json")
    p.add_argument("--logs", metavar="RUNS.toml", default=None, help="[[log]] tables, as identify --logs reads them")
    add_outputs(p, "draw measured and predicted torque per joint (needs the plot extra)",
                "also write one self-contained HTML page (no scripts, nothing fetched): what was done, the "
                "verdict, per joint RMS, band coverage and extrapolation (flagged joints highlighted), the "
                "figure with the stretches beyond the fit shaded, the models side by side, the data notes "
                "(default: none)")
    p.add_argument("--predictions", metavar="OUT.csv", default=None,
                   help="write t, tau1..n (measured), pred1..n, lo1..n, hi1..n (the 95 %% band) and x1..n (1 where "
                        "the sample is beyond the fit data by the leverage of the joint's regressor row) per sample")
    p.add_argument("--compare-column", metavar="NAME[=LABEL]", default=None,
                   help="also score a torque the log itself holds, as one more model: NAME1..NAMEn columns in N m "
                        "at the joints, e.g. a UR log's controller target torque: --compare-column 'm=UR controller "
                        "target torque' (its label in the table; default 'logged torque NAME1..')")


def load_model(spec: str, tip=None):
    """``(model, label)`` of one MODEL argument (:func:`manipdyn.identification.results.scoring.load_scored_model`)."""
    from ..identification.results.scoring import load_scored_model

    return load_scored_model(spec, tip)


def split_inputs(inputs, runs_file=None):
    """``(models, logs)`` of the positional arguments: logs by their file kind (or a directory);
    without any and without ``runs_file``, the last argument is the log."""
    logs = [x for x in inputs if x.lower().endswith(LOG_SUFFIXES) or os.path.isdir(x)]
    models = [x for x in inputs if x not in logs]
    if not logs and runs_file is None and len(inputs) > 1:
        models, logs = list(inputs[:-1]), [inputs[-1]]
    if not models:
        raise ModelError("MODEL: give at least one model before the logs")
    if not logs and runs_file is None:
        raise ModelError("LOG: give at least one log, or --logs RUNS.toml")
    return models, logs + ([runs_file] if runs_file else [])


def run(args) -> int:
    from ..identification import validate

    try:
        models, logs = split_inputs(args.inputs, args.logs)
        if args.predictions and len(models) > 1:
            raise ModelError("--predictions: one MODEL at a time (the file holds one model's predictions)")
        check_report_target(args.report)
        check_outputs([("--plot", args.plot), ("--predictions", args.predictions), ("--report", args.report)],
                      [("MODEL", m) for m in models] + [("DATA", x) for x in logs], plots=("--plot",))
        opts = library_options(args, validate)
        res = validate(models, logs, **opts)
        if args.plot:
            res.plot(args.plot)
        if args.report:
            res.report_html(args.report, command=command_line(args), options=opts, model_files=models)
    except ModelError as exc:
        return usage_error("validate", cli_message(exc))
    except ConnectionError as exc:      # a scheduler that does not answer: not the output's fault
        return usage_error("validate", f"--scheduler: {exc}")
    except OSError as exc:
        return usage_error("validate", f"{exc.filename or args.predictions}: cannot write: {exc.strerror or exc}")
    if args.json:
        out = res.to_dict()
        out.update({"data": ", ".join(logs), "plot": args.plot, "predictions": args.predictions,
                    "report": args.report})
        print(json.dumps(out, indent=2, allow_nan=False))
    else:
        print(res.format())
        for path in (args.predictions, args.plot, args.report):
            if path:
                print(f"wrote {path}")
    return EXIT_OK
