"""``manipdyn models``: list the bundled arms and their physical-consistency verdicts.

Layer: CLI.
"""

from __future__ import annotations

from ..loading import load_with_notes, models
from .common import EXIT_OK

__all__ = ["register", "run"]


def run(args) -> int:
    for name in models():
        arm, notes = load_with_notes(name)
        kinds = arm.joint_letters
        verdict = "consistent" if not notes else f"{len(notes)} inconsistent link(s)"
        print(f"{name:<12} {arm.n} DOF {kinds:<8} {arm.convention:<9} {verdict}")
    return EXIT_OK


def register(sub) -> None:
    """Add ``manipdyn models``."""
    m = sub.add_parser("models", help="list the bundled arm models")
    m.set_defaults(func=run)
