"""The outputs of a command, checked before its work starts: writable files, figures, HTML pages,
none of them an input.

Layer 7 (CLI, the top).
"""

from __future__ import annotations

import os

from .._support.errors import ModelError
from .._support.figures import pyplot

__all__ = ["check_output_file", "check_outputs", "check_plot_target", "check_report_target", "with_runs"]


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

