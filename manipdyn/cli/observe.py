"""``manipdyn observe MODEL LOG... [--gain K] [--false-alarms RATE] [--calibrate LOG...] [--fit-data LOG...]
[--threshold N_M...]
[--velocity-cutoff HZ] [--json] [--plot FILE.png] [--report FILE.html] [--predictions FILE.csv] [--save-model OUT.toml]``.

Layer 7 (CLI, the top).  Parses, calls :func:`manipdyn.control.collision.observe` (the momentum
observer against thresholds for a stated false-alarm rate), prints the thresholds and the events.
The logs are read as ``validate`` reads them (the same options), every sample kept.

Exit codes: 0 observed, no event; 1 observed, some event (the log is not collision-free at these
thresholds); 2 usage, model or data error, or no thresholds to be had (one line on stderr).
"""

from __future__ import annotations

import json

from .._support.errors import ModelError
from .argblocks import add_command, add_outputs
from .common import (EXIT_DISAGREE, EXIT_OK, check_outputs, check_report_target, cli_message,
                     command_line, load_arm, usage_error)
from .logopts import DATA_HELP, log_options_from_args, model_joint_names

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add ``manipdyn observe`` to the command line."""
    p = add_command(
        subparsers, "observe", run=run, help="collision detection: the momentum observer against thresholds with a false-alarm rate",
        description="Run the generalized-momentum observer of MODEL on the logs and report the collision events: "
                    "crossings of a per-joint threshold that last, their joints, the last link touched and the "
                    "force at the tool. The thresholds come from --threshold, from --calibrate (collision-free logs "
                    "the model was not fitted on, for --false-alarms events per hour), or from the model's trust "
                    "record (manipdyn identify writes them there, from the band's hold-outs; --save-model too); with none "
                    "of these, observe refuses. Exit codes: 0 no "
                    "event, 1 some event, 2 usage, model or data error.")
    p.add_argument("model", metavar="MODEL", help="bundled model name, .toml model file, .urdf file")
    p.add_argument("logs", metavar="LOG", nargs="*", help="the logs to watch. A log: " + DATA_HELP)
    p.add_argument("--gain", type=float, default=None, metavar="K",
                   help="the observer's gain, 1/s: the residual follows the external torque with time constant 1/K "
                        "(default: the model's thresholds' gain; with --calibrate or --fit-data, chosen on those "
                        "data among 10, 20, 30, 50, 100 for the smallest torque detected within 20 ms; with "
                        "--threshold, 100)")
    p.add_argument("--velocity-cutoff", type=float, default=None, metavar="HZ",
                   help="the cut-off, Hz, of the causal first-order low-pass on the observer's residual, against the "
                        "measured velocity's noise (0: none; library default 20); thresholds are only used with the cut-off they were calibrated with (default: the "
                        "model's thresholds' own, else the library's default)")
    p.add_argument("--false-alarms", type=float, default=1.0, metavar="RATE",
                   help="false events per hour the thresholds allow, all joints together (default 1)")
    p.add_argument("--calibrate", nargs="+", metavar="LOG", default=None,
                   help="collision-free logs the model was NOT fitted on: the thresholds are read off them")
    p.add_argument("--fit-data", metavar="LOG", nargs="+", default=None,
                   help="the logs MODEL was identified from, all of them (its trust record checks the sha256): "
                        "thresholds from the prediction band's hold-outs (held-out trajectories, else blocks), each "
                        "watched by the observer of a refit on the others; identify writes these by default, so "
                        "this redoes it (another gain, or a model identified with --no-thresholds)")
    p.add_argument("--calibrate-t-range", metavar="T0:T1", default=None,
                   help="the window of the --calibrate logs, in place of --t-range (one file cut into a calibration "
                        "window and a watched one)")
    p.add_argument("--threshold", nargs="+", type=float, metavar="N_M", default=None,
                   help="the thresholds themselves, N m per joint (one number: every joint)")
    p.add_argument("--min-duration", type=float, default=0.005, metavar="S",
                   help="a crossing is an event when it lasts this long, s (default 0.005)")
    p.add_argument("--hysteresis", type=float, default=0.5, metavar="FRACTION",
                   help="an event ends when every joint is below this fraction of its threshold (default 0.5)")
    p.add_argument("--save-model", metavar="OUT.toml", default=None,
                   help="write MODEL with the thresholds in its trust record, so later runs need no --calibrate")
    add_outputs(p, "draw the residuals against the thresholds, events shaded (first log; needs the plot extra)",
                "also write one self-contained HTML page: thresholds, events, the figure per log", "FILE.png")
    p.add_argument("--predictions", metavar="FILE.csv", default=None,
                   help="write per sample: log, t, r1..n (observer), d1..n (direct residual), T1..n, event")


def run(args) -> int:
    from ..control.collision import observe
    from ..control.collision.observe import resolve_thresholds, with_thresholds

    try:
        if not args.logs and args.save_model is None:
            raise ModelError("LOG: give at least one log to watch (or --save-model with --calibrate)")
        if args.save_model is not None and args.calibrate is None and args.fit_data is None:
            raise ModelError("--save-model: only with --calibrate or --fit-data (the thresholds it stores come from "
                             "those logs)")
        if args.save_model is not None and not str(args.save_model).endswith(".toml"):
            raise ModelError(f"--save-model: expected a model file name ending in .toml, got {args.save_model!r}")
        check_report_target(args.report)
        inputs = [("MODEL", args.model)] + [("LOG", x) for x in args.logs] + [("--calibrate", x)
                                                                             for x in (args.calibrate or [])]
        inputs += [("--fit-data", x) for x in (args.fit_data or [])]
        check_outputs([("--plot", args.plot), ("--report", args.report), ("--predictions", args.predictions),
                       ("--save-model", args.save_model)], inputs, plots=("--plot",))
        arm, _notes = load_arm(args.model, args.tip)
        opts = log_options_from_args(args, model_joint_names(arm))
        if opts.get("decimate") is None:
            opts["decimate"] = False            # the observer runs at the log's rate
        gain = args.gain            # None: the thresholds' own, or chosen on --calibrate / --fit-data
        cal_opts = opts
        if args.calibrate_t_range is not None:
            from ..formats.logs.read import as_t_range

            cal_opts = dict(opts, t_range=as_t_range(args.calibrate_t_range, "--calibrate-t-range"))
        thr = resolve_thresholds(arm, gain, args.false_alarms, args.calibrate, args.threshold, args.min_duration,
                                 args.hysteresis, cal_opts, args.fit_data, args.velocity_cutoff)
        res = None
        if args.logs:
            res = observe(arm, args.logs, thr.gain, false_alarms=args.false_alarms, threshold=thr,
                          min_duration=args.min_duration, hysteresis=args.hysteresis,
                          velocity_cutoff=thr.velocity_cutoff, **opts)
            res.thresholds = thr
            if args.plot:
                res.plot(args.plot)
            if args.predictions:
                res.write_predictions(args.predictions)
            if args.report:
                res.report_html(args.report, command=command_line(args))
        if args.save_model is not None:
            from ..formats.save import save

            save(with_thresholds(arm, thr), args.save_model)
    except ModelError as exc:
        return usage_error("observe", cli_message(exc))
    except OSError as exc:
        return usage_error("observe", f"{exc.filename or ''}: cannot read or write: {exc.strerror or exc}")
    events = len(res.events) if res is not None else 0
    if args.json:
        out = res.to_dict() if res is not None else {"threshold": [float(x) for x in thr.threshold],
                                                     "gain": thr.gain, "velocity_cutoff": thr.velocity_cutoff,
                                                     "threshold_source": thr.source}
        out.update({"plot": args.plot, "report": args.report, "predictions": args.predictions,
                    "saved_model": args.save_model})
        print(json.dumps(out, indent=2, allow_nan=False))
    else:
        if res is not None:
            print(res.format())
        else:
            print("thresholds, N m: " + " ".join(f"{x:.4g}" for x in thr.threshold) + f" ({thr.source})")
        for path in (args.predictions, args.plot, args.report, args.save_model):
            if path:
                print(f"wrote {path}")
    return EXIT_DISAGREE if events else EXIT_OK
