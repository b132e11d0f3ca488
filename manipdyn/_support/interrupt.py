"""Ctrl-C, or a core dependency missing, while the ``manipdyn`` command is still starting: one line, not a
traceback.

Layer 0 (support).  The command's own ``main`` turns a Ctrl-C into ``manipdyn: interrupted``
(exit 130), but the first half second of a run is spent importing NumPy, SciPy and the
engines, before ``main`` runs: a Ctrl-C there would print the import's traceback (some 30
lines).  :func:`quiet_interrupt_while_starting`, called first by ``manipdyn/__init__.py``,
installs a ``sys.excepthook`` that prints the same one line for an uncaught
``KeyboardInterrupt`` (Python then ends the process by SIGINT, as before), or for any error
that follows a Ctrl-C (a C extension being imported may turn the interrupt into an
``ImportError``: then exit 130), and only when this
process is the command (``manipdyn ...`` or ``python -m manipdyn ...``): a program that
imports manipdyn keeps its own hook.  The same hook says in one line (exit 2) when a core
dependency is not installed in the Python that runs the command (:func:`.deps.missing_core`).
"""

from __future__ import annotations

import os
import sys

__all__ = ["is_command_line", "quiet_interrupt_while_starting"]


def is_command_line(argv=None) -> bool:
    """True when this process runs the ``manipdyn`` command: the console script (``argv[0]``
    named ``manipdyn``) or ``python -m manipdyn`` (read from ``sys.orig_argv``)."""
    if argv is None:
        if os.path.basename(sys.argv[0] if sys.argv else "") in ("manipdyn", "manipdyn.exe"):
            return True
        argv = list(getattr(sys, "orig_argv", ()))
    k = 1
    while k < len(argv):
        a = argv[k]
        if a == "-m":
            return k + 1 < len(argv) and argv[k + 1] in ("manipdyn", "manipdyn.cli")
        if a.startswith("-m"):
            return a[2:] in ("manipdyn", "manipdyn.cli")
        if a == "-c" or a.startswith("-c") or not a.startswith("-") or a == "-":
            return False                 # a program (-c, a script, stdin) that imports manipdyn
        k += 2 if a in ("-X", "-W", "--check-hash-based-pycs") else 1     # options with a value
    return False


def quiet_interrupt_while_starting() -> None:
    """In the ``manipdyn`` command only (:func:`is_command_line`), report an uncaught Ctrl-C as
    ``manipdyn: interrupted``, one line (module docstring)."""
    if not is_command_line() or getattr(sys.excepthook, "_manipdyn", False):
        return
    import signal

    previous = sys.excepthook
    seen = []

    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        def on_sigint(signum, frame):
            # as Python's own handler, remembering it: a C extension being imported may turn the
            # KeyboardInterrupt into another error (NumPy: "Importing the numpy C-extensions failed")
            seen.append(signum)
            raise KeyboardInterrupt

        signal.signal(signal.SIGINT, on_sigint)

    def hook(kind, value, tb):
        from .deps import missing_core

        line = None if seen else missing_core(value)
        if line is not None:
            try:
                sys.stderr.write(line + "\n")
                sys.stderr.flush()
            except (OSError, ValueError):
                pass
            os._exit(2)              # the command's usage exit: what is to be installed, not a bug
        if issubclass(kind, KeyboardInterrupt) or seen:
            try:
                sys.stderr.write("manipdyn: interrupted\n")
                sys.stderr.flush()
            except (OSError, ValueError):
                pass
            if not issubclass(kind, KeyboardInterrupt):
                os._exit(130)        # the error was the interrupt's consequence: exit as an interrupt
            return
        previous(kind, value, tb)

    hook._manipdyn = True
    sys.excepthook = hook
