"""``manipdyn replay MODEL [MODEL ...] LOG [LOG ...] [--horizon S ...] [--every K]
[--simulator manipdyn|mujoco] [--json] [--plot FIG.png] [--report FILE.html]``.

Layer 7 (CLI, the top).  Parses, calls :func:`manipdyn.control.replay.replay`, prints.  From
states along the log, each model is simulated forward with the logged torque; q and qd at each
horizon are compared with the log, per joint, the models side by side (as ``validate`` puts
them) beside the constant-velocity guess.  The log is read with ``validate``'s options.

Exit codes: 0 replayed; 2 usage, model or data error (one line on stderr).
"""

from __future__ import annotations

import json

from .._support.errors import ModelError
from .argblocks import add_command, add_models_and_logs, add_outputs
from .common import EXIT_OK, check_outputs, check_report_target, cli_message, command_line, usage_error
from .logopts import log_options_from_args
from .validate import split_inputs

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add ``manipdyn replay`` to the command line."""
    from ..control.replay import DEFAULT_EVERY, DEFAULT_HORIZONS

    p = add_command(
        subparsers, "replay", "how far each model's simulated motion drifts from a real log over a horizon",
        "From states along the log (every --every samples), simulate each MODEL forward for each "
        "horizon with the logged torque and compare q and qd at the horizon with the log: RMS per "
        "joint and pooled, the models side by side (the best per joint marked *), beside the "
        "constant-velocity guess q + H qd, which a model must beat to predict anything. Exit codes: "
        "0 replayed, 2 usage, model or data error.", run)
    add_models_and_logs(p)
    p.add_argument("--horizon", type=float, nargs="+", default=list(DEFAULT_HORIZONS), metavar="S",
                   help="horizons in s (default " + " ".join(f"{h:g}" for h in DEFAULT_HORIZONS) + ")")
    p.add_argument("--every", type=int, default=DEFAULT_EVERY, metavar="K",
                   help=f"a start state every K log samples (default {DEFAULT_EVERY})")
    p.add_argument("--simulator", choices=("manipdyn", "mujoco"), default="manipdyn",
                   help="who steps the models: manipdyn's RK4 (default) or MuJoCo's on each model's MJCF "
                        "(the mujoco extra)")
    p.add_argument("--mujoco-plant", choices=("model", "file"), default=None,
                   help="with --simulator mujoco: 'model' (default) the plant manipdyn simulates (constraints off, "
                        "the whole friction law), or 'file' the MJCF as MuJoCo loads it")
    add_outputs(p, "draw the q error against the horizon per joint (needs the plot extra)",
                "also write one self-contained HTML page (no scripts, nothing fetched): what was replayed, "
                "the verdict, the tables per horizon, the figure (default: none)")


def run(args) -> int:
    from ..control.replay import replay

    try:
        if args.simulator != "mujoco" and args.mujoco_plant is not None:
            raise ModelError("--mujoco-plant: only with --simulator mujoco")
        if len(args.inputs) < 2:
            raise ModelError("MODEL LOG: give at least one model, then at least one log")
        models, logs = split_inputs(args.inputs)
        check_report_target(args.report)
        check_outputs([("--plot", args.plot), ("--report", args.report)],
                      [("MODEL", m) for m in models] + [("LOG", x) for x in logs], plots=("--plot",))
        opts = log_options_from_args(args)     # joint_names None: a bag's joints by the first model's names
        res = replay(models, logs, horizons=args.horizon, every=args.every, simulator=args.simulator,
                     mujoco_plant=args.mujoco_plant or "model", tip=args.tip, **opts)
        if args.plot:
            res.plot(args.plot)
        if args.report:
            res.report_html(args.report, command=command_line(args))
    except ModelError as exc:
        return usage_error("replay", cli_message(exc))
    except OSError as exc:
        return usage_error("replay", f"{exc.filename or args.plot or args.report}: cannot write: {exc.strerror or exc}")
    if args.json:
        out = res.to_dict()
        out.update({"plot": args.plot, "report": args.report})
        print(json.dumps(out, indent=2, allow_nan=False))
    else:
        print(res.format())
        for path in (args.plot, args.report):
            if path:
                print(f"wrote {path}")
    return EXIT_OK
