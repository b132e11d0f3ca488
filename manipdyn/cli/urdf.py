"""``manipdyn urdf``: write the URDF of arms.

Layer: CLI.
"""

from __future__ import annotations

from ..io import write_urdf
from ..loading import load_with_notes, models
from .common import EXIT_OK, output_folder, urdf_target, usage_error

__all__ = ["register", "run"]


def run(args) -> int:
    specs = list(args.models)
    if args.all:
        specs = models() + specs
    if not specs:
        return usage_error("urdf", "name at least one model or pass --all")
    output_folder(args.outdir, "OUTDIR")
    seen: dict = {}
    for spec in dict.fromkeys(specs):  # each spec once, in order
        arm, _ = load_with_notes(spec)
        path = urdf_target(args.outdir, arm, seen, "OUTDIR")
        write_urdf(arm, path)
        print(f"wrote {path}")
    return EXIT_OK


def register(sub) -> None:
    """Add ``manipdyn urdf``."""
    u = sub.add_parser("urdf", help="write the URDF of arms", description="Write <name>.urdf for each arm into OUTDIR.")
    u.add_argument("models", nargs="*", metavar="MODEL_OR_FILE")
    u.add_argument("--all", action="store_true", help="every bundled model")
    u.add_argument("outdir", metavar="OUTDIR")
    u.set_defaults(func=run)
