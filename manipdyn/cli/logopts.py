"""The command-line options that say how to read a measurement log.

Layer 7 (CLI, the top).

A subcommand that reads logs calls :func:`register_log_options` on its
parser and passes ``**log_options_from_args(args)`` to
:func:`manipdyn.identification.read_log`.  A malformed option value raises
:class:`~manipdyn.ModelError` naming the option (the CLI turns it into exit 2).
"""

from __future__ import annotations

import math

from .._support.errors import ModelError
from ..formats.logs.read import as_t_range, model_joint_names

__all__ = ["register_log_options", "log_options_from_args", "model_joint_names", "library_options", "DATA_HELP"]


#: help of the DATA argument of identify and validate
DATA_HELP = ("the log: a CSV with header t,q1..qn,tau1..taun (optionally qd*, qdd*; motor side qm*, with "
             "taum* or currents i* read through the model's [transmission]; other names with --columns; "
             "no t column: --rate), or a ROS 2 bag / MCAP file with sensor_msgs/JointState (--topic)")


def register_log_options(parser) -> None:
    """Add the log-reading options (an argument group "reading the log") to ``parser``."""
    g = parser.add_argument_group("reading the log")
    g.add_argument("--columns", metavar="MAP", default=None,
                   help="header names of the signals, {i} = joint number, {i0} = index from 0: "
                        "e.g. 'q=Joint_{i},tau=Effort_{i},t=time' (signals t, q, qd, qdd, tau, qm, qdm, taum, i)")
    g.add_argument("--deg", action="store_true", help="positions, velocities, accelerations in degrees")
    g.add_argument("--rate", type=float, default=None, metavar="HZ",
                   help="sample rate when the log has no t column (replaces t when it has one)")
    g.add_argument("--time-scale", type=float, default=1.0, metavar="S",
                   help="seconds per unit of t, e.g. 1e-3 for milliseconds (default 1)")
    g.add_argument("--resample", type=float, default=None, metavar="HZ",
                   help="rate of the uniform grid (default: the log's median rate)")
    g.add_argument("--cutoff", type=float, default=None, metavar="HZ",
                   help="low-pass cut-off for the derivatives (default: chosen from the spectrum of q)")
    g.add_argument("--no-decimate", action="store_true",
                   help="keep every sample after filtering (default: decimate to 10-20 x the cut-off, >= 200 Hz)")
    g.add_argument("--t-range", metavar="T0:T1", default=None,
                   help="keep T0 <= t < T1 s (either may be empty), e.g. ':10' or '10:13.8'")
    g.add_argument("--extra-joints", action="store_true",
                   help="accept a CSV with columns for joints beyond the model's (q8 for a 7-joint model: a "
                        "gripper) and ignore them; by default such a log is refused (another arm, or --tip?)")
    g.add_argument("--topic", default=None, help="ROS bag: the sensor_msgs/msg/JointState topic")
    g.add_argument("--joint-names", metavar="A,B,...", default=None,
                   help="ROS bag: the model's joint names in order (default: the model's own)")


def _t_range(text):
    return as_t_range(text, "--t-range")


def log_options_from_args(args, joint_names=None) -> dict:
    """The keyword arguments of :func:`~manipdyn.identification.read_log` from parsed ``args``.

    ``joint_names``: the model's joint names, used when ``--joint-names`` is not given
    (a ROS bag needs them; a CSV file ignores them).
    """
    names = joint_names
    if args.joint_names:
        names = [x.strip() for x in args.joint_names.split(",") if x.strip()]
    for opt, v in (("--rate", args.rate), ("--resample", args.resample), ("--cutoff", args.cutoff),
                   ("--time-scale", args.time_scale)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise ModelError(f"{opt}: expected a finite number > 0, got {v}")
    return dict(joint_names=None if names is None else list(names), columns=args.columns, deg=bool(args.deg),
                rate=args.rate, time_scale=args.time_scale, resample=args.resample, cutoff=args.cutoff,
                decimate=False if args.no_decimate else None, topic=args.topic, t_range=_t_range(args.t_range),
                extra_joints=bool(getattr(args, "extra_joints", False)))


def library_options(args, function) -> dict:
    """The keyword arguments of the library ``function`` that ``args`` holds, by name (the
    pipelines take the command line's options under their ``dest``), the log options checked
    and ``--t-range`` read."""
    import inspect

    names = inspect.signature(function).parameters
    out = {k: v for k, v in vars(args).items() if k in names and k not in ("prior", "logs", "models")}
    opts = log_options_from_args(args)
    out["t_range"] = opts["t_range"]
    if "joint_names" in out:            # "A,B,C" as the list of names, never the string's letters
        out["joint_names"] = opts["joint_names"]
    return out
