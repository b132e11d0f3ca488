"""What every ``manipdyn`` subcommand shares: exit codes, progress bars, output folders.

Layer 7 (CLI, the top).
"""

from __future__ import annotations

import os
import re
import sys

from .._support.errors import ModelError, TipError
from .._support.progress import Progress
from ..formats.loading import load_with_notes
from .outputs import check_output_file, check_outputs, check_plot_target, check_report_target, with_runs

__all__ = ["check_outputs", "check_plot_target", "check_report_target", "command_line", "check_output_file", "require_numbers", "add_progress_options", "progress_wanted", "EXIT_OK", "EXIT_DISAGREE", "EXIT_USAGE", "EXIT_INTERNAL", "Progress", "output_folder",
           "urdf_target", "usage_error", "one_line", "with_runs", "cli_message", "load_arm", "load_all", "is_urdf", "TIP_HELP"]

#: help of every ``--tip`` option
TIP_HELP = ("tree URDFs (an arm with a gripper): the link that ends the chain to use; "
            "without it, a tree URDF is refused with the list of candidate leaf links")

#: exit codes of every subcommand: 0 success / agreement, 1 a quantity
#: disagrees or a checked condition fails, 2 usage or model error, 3 a bug
EXIT_OK, EXIT_DISAGREE, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 3


def cli_message(exc) -> str:
    """A library error in command-line terms: option names as ``--flags``, a tip as ``--tip``."""
    if isinstance(exc, TipError):
        return str(exc.for_option("--tip"))
    if hasattr(exc, "cli_message"):
        return exc.cli_message()
    return str(exc)


def one_line(text) -> str:
    """``text`` as one printable line: control characters (newline, ESC, NUL, form feed, ...),
    bidirectional overrides and other invisible format characters from a name or a path are
    shown escaped (``\\n``, ``\\x1b``, ``\\u202e``; :func:`manipdyn._support.text.visible`), a tab as a space."""
    from .._support.text import visible

    return visible(str(text).replace("\t", " "))


def usage_error(command: str, message: str) -> int:
    """Print ``manipdyn COMMAND: error: MESSAGE`` on stderr and return :data:`EXIT_USAGE`."""
    print(f"manipdyn {command}: error: {one_line(message)}", file=sys.stderr)
    return EXIT_USAGE


def urdf_target(outdir: str, arm, seen: dict, option: str, inputs=(), ext: str = "urdf", check: bool = True) -> str:
    """``outdir/<name>.urdf`` (``.<ext>``) for an arm, with the name made a safe file name.

    Refuses two arms that would write the same file, and a file that is one of
    ``inputs`` (the model files read: :func:`check_outputs`).
    """
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", arm.name or "arm").strip("._") or "arm"
    if stem in seen:
        raise ModelError(f"{option}: {seen[stem]!r} and {arm.name!r} would both be written to {stem}.{ext}")
    seen[stem] = arm.name
    path = os.path.join(outdir, f"{stem}.{ext}")
    if check:            # (a folder still to be created holds no input and no link)
        check_outputs([(option, path)], [("MODEL_OR_FILE", s) for s in inputs])
    return path


def creatable_folder(path: str, option: str) -> None:
    """Refuse, in one line, a folder that does not exist and cannot be created (its nearest existing
    parent not writable): checked before any work, creating nothing."""
    parent = os.path.dirname(os.path.abspath(path))
    while not os.path.isdir(parent) and os.path.dirname(parent) != parent:
        parent = os.path.dirname(parent)
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ModelError(f"{option} {path}: cannot create the folder (no write access to {parent})")


def output_folder(path: str, option: str) -> str:
    """Create the output folder and make sure files can be written in it, or say in one
    line why not (before any work starts)."""
    import tempfile

    try:
        os.makedirs(path, exist_ok=True)
    except OSError as exc:
        raise ModelError(f"{option} {path}: cannot create the folder: {exc.strerror}") from None
    if not os.path.isdir(path):
        raise ModelError(f"{option} {path}: not a folder")
    try:
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        raise ModelError(f"{option} {path}: cannot write files in this folder ({exc.strerror})") from None
    return path


def is_urdf(spec: str) -> bool:
    """True when ``spec`` names a URDF file (by its extension) or an example-robot-data URDF (``erd:NAME``)."""
    return str(spec).lower().endswith((".urdf", ".xml")) or str(spec).startswith("erd:")


def load_arm(spec: str, tip: str | None = None, option: str = "--tip"):
    """``(arm, notes)`` of :func:`manipdyn.load_with_notes`; a tip error names ``option``."""
    try:
        return load_with_notes(spec, tip=tip)
    except TipError as exc:
        raise exc.for_option(option) from None


def load_all(specs, tip: str | None = None, option: str = "--tip") -> list:
    """Load every model before any work starts: ``[(spec, arm, notes)]``.

    A misspelled name or a bad file fails here, in one line, before the
    first arm is run.  ``tip`` applies to the URDF files among ``specs``;
    given with no URDF file among them it is a usage error.
    """
    specs = list(specs)
    if tip is not None and not any(is_urdf(s) for s in specs):
        raise ModelError(f"{option}: only meaningful for a URDF file, and none of "
                         f"{', '.join(map(repr, specs))} is one")
    return [(s, *load_arm(s, tip if is_urdf(s) else None, option)) for s in specs]


def add_progress_options(parser, what: str = "the progress bar") -> None:
    """``--progress`` / ``--no-progress``: show ``what`` on stderr always / never
    (default: only when stderr is a terminal; read it with :func:`progress_wanted`)."""
    prog = parser.add_mutually_exclusive_group()
    prog.add_argument("--progress", dest="progress", action="store_true", default=None,
                      help=f"always show {what} on stderr (default: only on a terminal)")
    prog.add_argument("--no-progress", dest="progress", action="store_false",
                      help=f"never show {what} (for logs and scripts)")


def progress_wanted(args) -> bool:
    """Whether to draw progress bars: ``--progress``, ``--no-progress``, or stderr is a terminal."""
    return args.progress if args.progress is not None else sys.stderr.isatty()


def require_numbers(args, *names: str) -> None:
    """Refuse an option whose value is not a number: argparse turns ``--opt=--`` into ``[]``
    (it drops the ``--``), which no ``type=float`` sees."""
    for name in names:
        v = getattr(args, name)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
            raise ModelError(f"--{name.replace('_', '-')}: expected a number, got {v!r:.60}")


def command_line(args) -> str:
    """The command as typed (``manipdyn COMMAND ARG ...``, shell-quoted), from the argv :func:`main` kept."""
    import shlex

    argv = getattr(args, "argv", None)
    return "manipdyn " + shlex.join(argv) if argv else f"manipdyn {getattr(args, 'command', '')}".strip()
