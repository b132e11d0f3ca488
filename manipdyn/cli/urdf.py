"""``manipdyn urdf``: write the URDF of arms.

Layer 7 (CLI, the top).
"""

from __future__ import annotations

import os

from .._support.errors import ModelError
from ..formats.save import write_urdf
from ..formats.loading import models
from .common import EXIT_OK, TIP_HELP, is_urdf, load_all, output_folder, urdf_target, usage_error

__all__ = ["register", "run"]


def run(args) -> int:
    specs = list(args.models)
    if args.all:
        specs = models() + specs
    if not specs:
        if args.outdir in models() or is_urdf(args.outdir) or args.outdir.lower().endswith(".toml") \
                or args.outdir.startswith("erd:"):
            return usage_error("urdf", f"missing OUTDIR: {args.outdir!r} is a model, not the folder to "
                                       "write into; usage: manipdyn urdf MODEL_OR_FILE ... OUTDIR")
        return usage_error("urdf", "name at least one model or pass --all")
    output_folder(args.outdir, "OUTDIR")
    loaded = load_all(dict.fromkeys(specs), args.tip)   # each spec once, all loaded before writing
    seen: dict = {}
    paths = [urdf_target(args.outdir, arm, seen, "OUTDIR", specs) for _spec, arm, _notes in loaded]
    for (spec, arm, _notes), path in zip(loaded, paths):
        try:
            write_urdf(arm, path)
        except OSError as exc:
            raise ModelError(f"OUTDIR {args.outdir}: cannot write {os.path.basename(path)} ({exc.strerror})") from None
        print(f"wrote {path}")
    return EXIT_OK


def register(sub) -> None:
    """Add ``manipdyn urdf``."""
    u = sub.add_parser("urdf", help="write the URDF of arms",
                       usage="manipdyn urdf [-h] [--all] [--tip LINK] [MODEL_OR_FILE ...] OUTDIR  (options first)",
                       description="Write <name>.urdf for each arm into OUTDIR (created if needed). "
                                   "The URDF carries the arm's joint limits and says in a comment which "
                                   "values are manipdyn's defaults. Exit 0 written, 2 usage or model error.")
    u.add_argument("models", nargs="*", metavar="MODEL_OR_FILE",
                   help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd) (several allowed)")
    u.add_argument("outdir", metavar="OUTDIR", help="the folder to write the .urdf files into")
    u.add_argument("--all", action="store_true", help="every bundled model")
    u.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    u.set_defaults(func=run)
