"""``manipdyn codegen``: the arm's dynamics as a C99 header and source.

Layer 7 (CLI, the top).  A thin shell over :func:`manipdyn.codegen`.
"""

from __future__ import annotations

from ..engines.c import codegen
from .common import EXIT_OK, TIP_HELP, load_all

__all__ = ["register", "run"]


def run(args) -> int:
    (_, arm, notes), = load_all([args.model], args.tip)
    hpath, cpath, note = codegen(arm, args.output, prefix=args.prefix)
    print(f"wrote {hpath} and {cpath} ({arm.name or 'arm'}, {arm.n} joints){'; ' + note if note else ''}")
    for n in notes:                      # the model's notes, as check and track show them
        print(f"  note: {n}")
    return EXIT_OK


def register(sub) -> None:
    """Add ``manipdyn codegen``."""
    c = sub.add_parser("codegen", help="write the arm's dynamics as dependency-free C99",
                       description="Write DIR/P.h and DIR/P.c: inverse and forward dynamics, mass matrix, "
                                   "gravity, nonlinear effects, the derivatives of inverse dynamics and the "
                                   "regressor, with the model's numbers folded in (C99, <math.h> only, no "
                                   "allocation, reentrant).  With a C compiler present, the source is "
                                   "test-compiled with -std=c99 -Wall -Wextra -pedantic -Werror.",
                       epilog="Needs CasADi: pip install 'manipdyn[codegen]' (in a source checkout: pip install -e '.[codegen]').  Exit codes: 0 written; "
                              "2 usage or model error (a model the C cannot express is refused by name).")
    c.add_argument("model", metavar="MODEL",
                   help="bundled model name, .toml model file, .urdf file, identified model or erd:NAME")
    c.add_argument("-o", "--output", required=True, metavar="DIR", help="folder to write P.h and P.c into")
    c.add_argument("--prefix", default=None, metavar="P",
                   help="prefix of the file names and C functions (default: the model's name made a C identifier)")
    c.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    c.set_defaults(func=run)
