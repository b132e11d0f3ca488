"""The ``manipdyn`` command line: every subcommand registered in one place.

Layer 7 (CLI, the top).  May import: every package below; nothing imports it but
``manipdyn.__main__`` and the console script.  Each subcommand is a module of this package with
``register(subparsers)`` (adds its parser, ``set_defaults(func=run)``) and
``run(args) -> int``; :data:`COMMANDS` lists them in ``--help`` order.

Exit codes: 0 success (engines agree), 1 some quantity disagrees or a checked
condition fails, 2 usage or model error (one line on stderr, no traceback;
a singular mass matrix and dynamics that overflow are model errors),
3 an unexpected internal error, a bug (one line; ``--debug`` shows the traceback).
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import warnings

from .._support.errors import MissingExtraError, ModelError, SingularMassMatrixError, StateError
from .._support.deps import missing_core
from . import (bench, check, codegen, compare, excite, identify, mjcf, models, montecarlo, observe, replay, synthesize, track,
               urdf, validate)
from .._support.text import EscapingWriter
from .._support.threads import blas_threads
from .common import EXIT_INTERNAL, EXIT_OK, EXIT_USAGE, one_line

__all__ = ["main", "build_parser", "COMMANDS"]

#: the subcommands, in the order ``manipdyn --help`` lists them
COMMANDS = (check, urdf, mjcf, models, compare, track, montecarlo, excite, synthesize, identify, validate, observe, replay,
            bench, codegen)


def _version() -> str:
    """The version of the manipdyn package that is running."""
    from .. import __version__

    return __version__


class _Parser(argparse.ArgumentParser):
    """argparse, with a usage error as one line (the command's name, the error, where the help
    is) instead of the whole usage block: exit 2, as every usage error."""

    def error(self, message):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


class _CommandParser(_Parser):
    """A subcommand's parser: options may stand between the positional arguments
    (``manipdyn mjcf erd:panda --tip panda_hand OUT``), as argparse's intermixed parsing reads them."""

    _inside = False

    def parse_known_args(self, args=None, namespace=None):
        if self._inside:        # the intermixed parse's own two passes
            return super().parse_known_args(args, namespace)
        self._inside = True
        try:
            return self.parse_known_intermixed_args(args, namespace)
        finally:
            self._inside = False


def build_parser() -> argparse.ArgumentParser:
    """The ``manipdyn`` argument parser with every subcommand of :data:`COMMANDS`."""
    p = _Parser(
        prog="manipdyn",
        description="Serial-arm dynamics two independent ways (Pinocchio and the trace-form "
                    "Lagrange-Euler equations), cross-checked.",
        epilog="Exit codes: 0 agree, 1 a quantity disagrees, 2 usage or model error, 3 internal error.",
    )
    p.add_argument("--debug", action="store_true", help="show Python tracebacks on errors")
    p.add_argument("--version", action="version", version=f"manipdyn {_version()}")
    p.add_argument("--blas-threads", type=int, default=1, metavar="N",
                   help="BLAS threads of this process (default 1: manipdyn's matrices are small, and more "
                        "threads only slow it on a shared machine; 0 leaves the BLAS library's own "
                        "choice; needs threadpoolctl, otherwise ignored)")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_CommandParser)
    for command in COMMANDS:
        command.register(sub)
    return p


def _joined_negative_values(argv):
    """``--t-range -5:-1`` as ``--t-range=-5:-1``, and ``--opt -inf`` as ``--opt=-inf``: argparse
    takes a value that starts with '-' (and is not a plain negative number) for an option and
    says "expected one argument" instead of the option's own check of the value."""
    out, k = [], 0
    while k < len(argv):
        a = argv[k]
        nxt = argv[k + 1] if k + 1 < len(argv) else ""
        if (a in _NEGATIVE_OK and re.fullmatch(r"-[0-9.eE+-]*:[0-9.eE+-]*", nxt)) or (
                a.startswith("--") and "=" not in a and re.fullmatch(r"-(inf|infinity|nan)", nxt, re.IGNORECASE)):
            out.append(f"{a}={argv[k + 1]}")
            k += 2
        else:
            out.append(a)
            k += 1
    return out


#: options whose value may start with '-' (a window before t = 0)
_NEGATIVE_OK = ("--t-range",)


def main(argv=None) -> int:
    """Run one ``manipdyn`` command; returns its exit code (module docstring).

    Warnings raised while it runs (a model's notes, numpy's overflow warnings) are shown
    after it, one line each, and not at all when it exits 2: an error is one line.
    """
    argv = _joined_negative_values([str(a) for a in (sys.argv[1:] if argv is None else argv)])
    with warnings.catch_warnings(record=True) as caught:
        code = _main(argv)
    if code not in (EXIT_USAGE, 130):
        shown = set()
        for w in caught:
            line = one_line(" ".join(str(w.message).split()))
            if line not in shown:
                shown.add(line)
                print(f"manipdyn: warning: {w.category.__name__}: {line}", file=sys.stderr)
    return code


def _main(argv) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = list(argv)          # the command line as typed, for the reports that show it
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_USAGE
    if args.blas_threads < 0:
        print(f"manipdyn: error: --blas-threads: expected >= 0, got {args.blas_threads}", file=sys.stderr)
        return EXIT_USAGE
    real = sys.stdout
    sys.stdout = EscapingWriter(real)       # no raw control character from a name reaches the terminal
    try:
        with blas_threads(args.blas_threads or None):
            return args.func(args)
    except BrokenPipeError:
        # the reader went away (e.g. `manipdyn check ... | head`): not an error of ours
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return EXIT_OK
    except MissingExtraError as exc:
        # the message gives the install command, in command-line terms
        print(f"manipdyn {args.command}: error: {one_line(exc.cli_message)}", file=sys.stderr)
        return EXIT_USAGE
    except (ModelError, StateError, SingularMassMatrixError) as exc:
        # a model problem (a singular mass matrix, dynamics that overflow on the
        # states the command drew, a malformed file): the input's fault, not ours
        print(f"manipdyn {args.command}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:
        print(f"manipdyn {args.command}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("manipdyn: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # never a bare traceback for users
        if args.debug:
            raise
        if missing_core(exc) is not None:      # a core dependency imported late: not a bug, an install
            print(missing_core(exc).replace("manipdyn:", f"manipdyn {args.command}: error:", 1), file=sys.stderr)
            return EXIT_USAGE
        print(f"manipdyn {args.command}: internal error: {type(exc).__name__}: {one_line(exc)} "
              "(rerun with --debug for the traceback)", file=sys.stderr)
        return EXIT_INTERNAL
    finally:
        if isinstance(sys.stdout, EscapingWriter):
            sys.stdout = real


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
