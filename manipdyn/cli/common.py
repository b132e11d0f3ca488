"""What every ``manipdyn`` subcommand shares: exit codes, progress bars, output folders.

Layer 7 (CLI, the top).
"""

from __future__ import annotations

import os
import re
import sys

from .._support.figures import pyplot
from .._support.errors import ModelError, TipError
from .._support.progress import Progress
from ..formats.loading import load_with_notes

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
    shown escaped (``\\n``, ``\\x1b``, ``\\u202e``), never sent raw to the terminal."""
    import unicodedata

    out = []
    for ch in str(text):
        if ch == "\t":
            out.append(" ")
        elif unicodedata.category(ch) in ("Cc", "Cf", "Zl", "Zp", "Cs"):
            o = ord(ch)
            out.append({"\n": "\\n", "\r": "\\r"}.get(ch) or (f"\\x{o:02x}" if o < 0x100 else f"\\u{o:04x}"
                                                          if o <= 0xFFFF else f"\\U{o:08x}"))
        else:
            out.append(ch)
    return "".join(out)


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


def check_output_file(path: str, option: str) -> None:
    """Before a long run: ``path`` must be a file that can be written (atomically) in an
    existing, writable folder; a ModelError naming ``option`` says why not."""
    folder = os.path.dirname(os.path.abspath(path))
    if not path or os.path.isdir(path):
        raise ModelError(f"{option} {path!r}: expected a file path, got a folder")
    if not os.path.isdir(folder):
        raise ModelError(f"{option} {path}: the folder {folder} does not exist (create it first)")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ModelError(f"{option} {path}: cannot write files in the folder {folder}")
    if os.path.lexists(path) and not os.path.isfile(path):
        raise ModelError(f"{option} {path}: exists and is not a regular file (a device, FIFO or socket)")


def check_plot_target(path: str, option: str = "--plot") -> None:
    """Before a long run: ``--plot`` must be a writable file path whose extension is an image
    format matplotlib writes, and matplotlib importable."""
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path) or not os.path.isdir(folder) or not os.access(folder, os.W_OK):
        raise ModelError(f"{option} {path}: expected a writable file path (its folder must exist)")
    pyplot()  # matplotlib installed?
    from matplotlib.backend_bases import FigureCanvasBase

    kinds = FigureCanvasBase.get_supported_filetypes()
    ext = os.path.splitext(path)[1].lower().lstrip(".")
    if ext not in kinds:
        raise ModelError(f"{option} {path}: expected an image file name ending in one of "
                         f"{', '.join('.' + k for k in sorted(kinds))} (the extension gives the format)")


def with_runs(inputs) -> list:
    """``inputs`` (``(label, path)`` pairs) and, for each RUNS.toml among them (a ``--logs`` file,
    or a ``.toml`` data argument), the logs its ``[[log]]`` tables list: outputs must not
    overwrite those either.  A RUNS file that cannot be read is left to the command (its error
    names the key)."""
    out = list(inputs)
    for label, path in inputs:
        if (isinstance(path, str) and path.lower().endswith(".toml") and os.path.isfile(path)
                and (label == "--logs" or label in ("DATA", "LOG"))):
            from ..identification.inputs.runs import read_runs_file

            try:
                specs = read_runs_file(path)
            except ModelError:
                continue
            out += [(f"[[log]] {k + 1} of {path}", spec.path) for k, spec in enumerate(specs)]
    return out


def check_outputs(outputs, inputs=(), plots=()) -> None:
    """Check every output of a command before its work starts, in one call.

    ``outputs``: ``(option, path)`` pairs (path None: not asked for); ``inputs``: ``(label,
    path)`` pairs of what the command reads (a bundled model's name, which is no file, is
    skipped); ``plots``: the options among ``outputs`` that are figures.  Refused, with a
    ModelError naming the option: a path that is, or resolves to (symbolic links, hard
    links), an input or a file inside an input folder (a ROS bag); two outputs that are the
    same file; a path that cannot be written (:func:`check_output_file`, :func:`check_plot_target`).
    """
    from .._support.files import overwrites

    inputs = with_runs(inputs)
    outputs = [(o, p) for o, p in outputs if p is not None]
    for k, (option, path) in enumerate(outputs):
        if not isinstance(path, str) or not path:
            raise ModelError(f"{option}: expected a file path, got {path!r}")
        for label, source in inputs:
            if source is not None and os.path.exists(source) and overwrites(path, source):
                raise ModelError(f"{option} {path}: would overwrite {label} {source}; write the output "
                                 "to another file")
        for other, opath in outputs[:k]:
            if overwrites(path, opath) or os.path.realpath(path) == os.path.realpath(opath):
                raise ModelError(f"{option} {path}: the same file as {other} {opath}; give each output "
                                 "its own file")
        if option in plots:
            check_plot_target(path, option)
        else:
            check_output_file(path, option)


def check_report_target(path, option: str = "--report") -> None:
    """``--report`` must name an ``.html`` (or ``.htm``) file, and matplotlib must be there to draw its
    figures (before any work starts); the rest of its checks are :func:`check_outputs`'."""
    if path is None:
        return
    if not isinstance(path, str) or not path.lower().endswith((".html", ".htm")):
        raise ModelError(f"{option}: expected a file name ending in .html, got {path!r}")
    try:
        pyplot()  # the report's figures: matplotlib installed, or the install command
    except ModelError as exc:
        raise ModelError(f"{option}: {exc}".replace("--plot needs", "the report's figures need")) from None


def command_line(args) -> str:
    """The command as typed (``manipdyn COMMAND ARG ...``, shell-quoted), from the argv :func:`main` kept."""
    import shlex

    argv = getattr(args, "argv", None)
    return "manipdyn " + shlex.join(argv) if argv else f"manipdyn {getattr(args, 'command', '')}".strip()
