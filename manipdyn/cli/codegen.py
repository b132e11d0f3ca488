"""``manipdyn codegen``: the arm's dynamics as a C99 header and source.

Layer 7 (CLI, the top).  A thin shell over :func:`manipdyn.codegen`.
"""

from __future__ import annotations

import os

from .._support.errors import ModelError
from ..engines.c import codegen
from ..engines.c.source import check_arm, codegen_targets
from .common import EXIT_OK, TIP_HELP, check_outputs, creatable_folder, load_all

__all__ = ["register", "run"]


def run(args) -> int:
    (_, arm, notes), = load_all([args.model], args.tip)
    # the outputs, checked before the work: never onto the model (a link gen/P.h -> model.toml),
    # never a folder, FIFO or device; the C's size is capped before its graphs are built
    check_arm(arm)
    try:
        hpath, cpath = codegen_targets(arm, args.output, prefix=args.prefix)
    except ModelError as exc:
        if str(exc).startswith("prefix:"):
            raise ModelError(f"--{exc}") from None
        raise ModelError(f"-o {args.output}: {exc}") from None
    if os.path.isdir(args.output):
        check_outputs([("-o", hpath), ("-o", cpath)], inputs=[("the model", args.model)])
    else:
        creatable_folder(args.output, "-o")
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
                              "2 usage or model error (a model the C cannot express is refused by name; an arm whose C "
                              "would exceed manipdyn.limits.MAX_CODEGEN_OPERATIONS; an output that is the model, "
                              "a folder, FIFO or device; a failed test-compile writes nothing).")
    c.add_argument("model", metavar="MODEL",
                   help="bundled model name, .toml model file, .urdf file, identified model or erd:NAME")
    c.add_argument("-o", "--output", required=True, metavar="DIR", help="folder to write P.h and P.c into")
    c.add_argument("--prefix", default=None, metavar="P",
                   help="prefix of the file names and C functions (default: the model's name made a C identifier)")
    c.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    c.set_defaults(func=run)
