"""``manipdyn urdf``: write the URDF of arms (and the loop ``manipdyn mjcf`` shares).

Layer 7 (CLI, the top).
"""

from __future__ import annotations

import os
import warnings

from .._support.errors import ModelError, PhysicalConsistencyWarning
from ..formats.save import write_urdf
from ..formats.loading import models
from ..formats.urdf.writer import urdf_losses
from .common import EXIT_OK, TIP_HELP, is_urdf, load_all, output_folder, urdf_target, usage_error

__all__ = ["register", "run", "write_models"]


def write_models(args, command: str, ext: str, write, losses) -> int:
    """Load ``args.models`` (or ``--all``), write ``OUTDIR/<name>.<ext>`` with ``write(arm, path)``
    for each, and print what the format does not hold (``losses(arm)``, one line each)."""
    specs = list(args.models)
    if args.all:
        specs = models() + specs
    if not specs:
        if args.outdir in models() or is_urdf(args.outdir) or args.outdir.lower().endswith(".toml") \
                or args.outdir.startswith("erd:"):
            return usage_error(command, f"missing OUTDIR: {args.outdir!r} is a model, not the folder to "
                                        f"write into; usage: manipdyn {command} MODEL_OR_FILE ... OUTDIR")
        return usage_error(command, "name at least one model or pass --all")
    output_folder(args.outdir, "OUTDIR")
    loaded = load_all(dict.fromkeys(specs), args.tip)   # each spec once, all loaded before writing
    seen: dict = {}
    paths = [urdf_target(args.outdir, arm, seen, "OUTDIR", specs, ext) for _spec, arm, _notes in loaded]
    for (spec, arm, _notes), path in zip(loaded, paths):
        try:
            with warnings.catch_warnings():      # the losses printed below say it, once
                warnings.simplefilter("ignore", PhysicalConsistencyWarning)
                write(arm, path)
        except OSError as exc:
            raise ModelError(f"OUTDIR {args.outdir}: cannot write {os.path.basename(path)} ({exc.strerror})") from None
        print(f"wrote {path}")
        for line in losses(arm):
            print(f"  not held: {line}")
    return EXIT_OK


def run(args) -> int:
    return write_models(args, "urdf", "urdf", write_urdf, urdf_losses)


def add_model_arguments(u, ext: str) -> None:
    """MODEL_OR_FILE ..., OUTDIR, --all and --tip of ``manipdyn urdf`` and ``manipdyn mjcf``."""
    u.add_argument("models", nargs="*", metavar="MODEL_OR_FILE",
                   help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd) "
                        "(several allowed)")
    u.add_argument("outdir", metavar="OUTDIR", help=f"the folder to write the .{ext} files into (created if needed)")
    u.add_argument("--all", action="store_true", help="every bundled model")
    u.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)


def register(sub) -> None:
    """Add ``manipdyn urdf``."""
    u = sub.add_parser("urdf", help="write the URDF of arms",
                       usage="manipdyn urdf [-h] [--all] [--tip LINK] [MODEL_OR_FILE ...] OUTDIR  (options first)",
                       description="Write <name>.urdf for each arm into OUTDIR (created if needed). "
                                   "The URDF carries the arm's joint limits and says in a comment which "
                                   "values are manipdyn's defaults and what URDF cannot hold of the model "
                                   "(printed too, one 'not held:' line each). "
                                   "Exit 0 written, 2 usage or model error.")
    add_model_arguments(u, "urdf")
    u.set_defaults(func=run)
