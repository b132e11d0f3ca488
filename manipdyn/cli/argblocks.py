"""The argument blocks several subcommands share, each written once.

Layer 7 (CLI, the top).  ``validate``, ``replay`` and ``observe`` score a model on logs and share
their outputs (:func:`add_outputs`) and, but for ``observe``, their MODEL|LOG positionals
(:func:`add_models_and_logs`); ``urdf`` and ``mjcf`` write model files the same way
(:func:`add_writer_command`).
"""

from __future__ import annotations

from .common import TIP_HELP
from .logopts import DATA_HELP, register_log_options

__all__ = ["add_command", "add_models_and_logs", "add_outputs", "add_writer_command"]


def add_command(subparsers, name: str, help: str, description: str, run):
    """The parser of subcommand ``name`` (its one-line ``help`` and its ``description``), ``run``
    its function, with the log-reading options (:func:`~.logopts.register_log_options`, their own
    group in ``--help``): the commands that read logs."""
    p = subparsers.add_parser(name, help=help, description=description)
    register_log_options(p)
    p.set_defaults(func=run)
    return p


def add_models_and_logs(p, kinds: str = "name, .toml, .urdf") -> None:
    """The positionals ``MODEL|LOG ...``: the models (``kinds``), then the logs."""
    p.add_argument("inputs", metavar="MODEL|LOG", nargs="+",
                   help=f"the models ({kinds}), then the logs (.csv, .mcap, .bag, a bag folder; without any, the "
                        "last argument is the log). A log: " + DATA_HELP)


def add_outputs(p, plot: str, report: str, plot_metavar: str = "FIG.png") -> None:
    """``--tip``, ``--json``, ``--plot`` (what it draws: ``plot``), ``--report`` (what the page holds:
    ``report``): what every command scoring a model on logs offers."""
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    p.add_argument("--plot", metavar=plot_metavar, default=None, help=plot)
    p.add_argument("--report", metavar="FILE.html", default=None, help=report)


def add_writer_command(sub, name: str, help: str, description: str, ext: str, run, as_published: str):
    """``manipdyn urdf`` / ``manipdyn mjcf``: MODEL_OR_FILE ..., OUTDIR (the ``.ext`` files go there),
    ``--all``, ``--tip``, ``--as-published`` (``as_published``: what it keeps)."""
    u = sub.add_parser(name, help=help, description=description)
    u.add_argument("models", nargs="*", metavar="MODEL_OR_FILE",
                   help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd) "
                        "(several allowed)")
    u.add_argument("outdir", metavar="OUTDIR", help=f"the folder to write the .{ext} files into (created if needed)")
    u.add_argument("--all", action="store_true", help="every bundled model")
    u.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    u.add_argument("--as-published", action="store_true",
                   help="write every body as the model has it, even one " + as_published + " (default: such "
                        "bodies are completed with the model's base parameters)")
    u.set_defaults(func=run)
    return u

