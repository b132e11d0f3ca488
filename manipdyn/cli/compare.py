"""``manipdyn compare A B``: are two descriptions the same arm?

Layer 7 (CLI, the top).
"""

from __future__ import annotations

import json

from ..check.compare import DYN_TOLERANCE, KIN_TOLERANCE, compare
from ..check.compare.report import display_names
from .common import EXIT_DISAGREE, EXIT_OK, TIP_HELP, load_arm, usage_error

__all__ = ["register", "run"]


def run(args) -> int:
    if args.samples < 1:
        return usage_error("compare", f"--samples must be >= 1, got {args.samples}")
    a, notes_a = load_arm(args.a, args.tip_a, "--tip-a")
    b, notes_b = load_arm(args.b, args.tip_b, "--tip-b")
    names = display_names(a.name, b.name, args.a, args.b)
    report = compare(a, b, samples=args.samples, seed=args.seed, names=names)
    load_notes = notes_a + notes_b          # each names its arm and link
    if args.json:
        d = report.to_dict()
        d["load_notes"] = load_notes
        print(json.dumps(d, indent=2))
    else:
        print(report)
        for note in load_notes:
            print(f"note: {note}")
    return EXIT_OK if report.same_arm else EXIT_DISAGREE


def register(subparsers) -> None:
    """Add ``manipdyn compare A B [--samples N] [--seed S] [--json] [--tip-a L] [--tip-b L]``."""
    p = subparsers.add_parser(
        "compare", help="are two descriptions the same arm? (e.g. a DH table and a URDF)",
        description="Align the forward kinematics of two arm descriptions (joint signs and offsets, "
                    "base and tool transforms, in closed form) and compare their dynamics (D, h, g, "
                    "rotor inertia) at matched states. Two verdicts: kinematics the same / the same "
                    "up to joint signs or offsets / different (tolerance "
                    f"{KIN_TOLERANCE:g} m), and dynamics the same / different (tolerance "
                    f"{DYN_TOLERANCE:g} relative, with the link most responsible). Exit 0 when both "
                    "are the same (one file can replace the other with the same joint vector), "
                    "1 when not (including a different number or type of joints), 2 on a usage or "
                    "model error.")
    p.add_argument("a", metavar="A", help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd)")
    p.add_argument("b", metavar="B", help="the other description (same forms)")
    p.add_argument("--samples", type=int, default=200, help="random states of B (default 200)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random states (default 0)")
    p.add_argument("--json", action="store_true", help="print one JSON document")
    p.add_argument("--tip-a", default=None, metavar="LINK", help="the --tip of A: " + TIP_HELP)
    p.add_argument("--tip-b", default=None, metavar="LINK", help="the --tip of B (one per side)")
    p.set_defaults(func=run)
