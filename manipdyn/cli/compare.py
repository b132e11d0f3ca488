"""``manipdyn compare A B``: are two descriptions the same arm?

Layer: CLI.
"""

from __future__ import annotations

import json
import sys

from ..comparison import KIN_TOLERANCE, compare
from ..loading import load_with_notes

__all__ = ["register", "run"]


def run(args) -> int:
    if args.samples < 1:
        print(f"manipdyn compare: error: --samples must be >= 1, got {args.samples}", file=sys.stderr)
        return 2
    a, notes_a = load_with_notes(args.a, tip=args.tip_a)
    b, notes_b = load_with_notes(args.b, tip=args.tip_b)
    load_notes = notes_a + notes_b
    report = compare(a, b, samples=args.samples, seed=args.seed)
    if args.json:
        d = report.to_dict()
        d["load_notes"] = load_notes
        print(json.dumps(d, indent=2))
    else:
        print(report)
        for note in load_notes:
            print(f"note: {note}")
    return 0 if report.same_kinematics else 1


def register(subparsers) -> None:
    """Add ``manipdyn compare A B [--samples N] [--seed S] [--json]``."""
    p = subparsers.add_parser(
        "compare", help="are two descriptions the same arm? (e.g. a DH table and a URDF)",
        description="Align the forward kinematics of two arm descriptions (joint signs and offsets, "
                    "base and tool transforms, in closed form) and compare their dynamics at matched "
                    "states. Exit 0 when the kinematics agree within "
                    f"{KIN_TOLERANCE:g} m, 1 when they do not, 2 on a usage or model error.")
    p.add_argument("a", metavar="A", help="bundled model name, .toml model file, or .urdf file")
    p.add_argument("b", metavar="B", help="the other description")
    p.add_argument("--samples", type=int, default=200, help="random states of B (default 200)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random states (default 0)")
    p.add_argument("--json", action="store_true", help="print one JSON document")
    p.add_argument("--tip-a", default=None, metavar="LINK", help="A is a URDF: the tip link of its chain")
    p.add_argument("--tip-b", default=None, metavar="LINK", help="B is a URDF: the tip link of its chain")
    p.set_defaults(func=run)
