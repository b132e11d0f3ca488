"""``manipdyn models``: list the bundled arms and their physical-consistency verdicts.

An arm whose Robotics Toolbox model differs (its model file's ``sources.toolbox``) gets a second
line saying how.

Layer 7 (CLI, the top).
"""

from __future__ import annotations

from ..formats.loading import load_with_notes, models
from .common import EXIT_OK

__all__ = ["register", "run"]


def run(args) -> int:
    if args.erd:
        from ..formats.erd import robots_dir, urdf_names

        root = robots_dir()
        for name in urdf_names():
            where = sorted(str(p.relative_to(root)) for p in root.rglob(f"{name}.urdf"))
            print(f"erd:{name:<32} {where[0]}" + (f" (and {len(where) - 1} more)" if len(where) > 1 else ""))
        return EXIT_OK
    for name in models():
        arm, notes = load_with_notes(name)
        kinds = arm.joint_letters
        verdict = "consistent" if not notes else f"{len(notes)} inconsistent link(s)"
        print(f"{name:<12} {arm.n} DOF {kinds:<8} {arm.convention:<9} {verdict}")
        toolbox = arm.sources.get("toolbox")     # where the Robotics Toolbox's model of this arm differs
        if toolbox:
            print(f"{'':<13}{toolbox.split(' For the Toolbox')[0].rstrip('.')} (sources.toolbox says how to get its convention)")
    return EXIT_OK


def register(sub) -> None:
    """Add ``manipdyn models``."""
    m = sub.add_parser("models", help="list the bundled arm models",
                       description="List the bundled arm models with their physical-consistency verdicts; "
                                   "with --erd, the URDFs of example-robot-data, each usable as erd:NAME "
                                   "wherever a model is expected (a tree needs --tip).")
    m.add_argument("--erd", action="store_true",
                   help="list the URDFs of example-robot-data (use them as erd:NAME)")
    m.set_defaults(func=run)
