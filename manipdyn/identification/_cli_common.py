"""Pieces shared by the ``excite`` and ``identify`` subcommands."""

from __future__ import annotations

import sys
import warnings

__all__ = ["load_model", "progress_bar", "usage_error", "EXIT_OK", "EXIT_FAILED", "EXIT_USAGE"]

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


def load_model(spec: str):
    """``md.load(spec)`` with physical-consistency warnings collected, not printed:
    ``(arm, notes)``."""
    import manipdyn as md

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", md.PhysicalConsistencyWarning)
        arm = md.load(spec)
    return arm, [str(w.message) for w in caught if issubclass(w.category, md.PhysicalConsistencyWarning)]


def usage_error(command: str, message: str) -> int:
    print(f"manipdyn {command}: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def progress_bar(label: str, enabled: bool | None):
    """``progress(done, total)`` writing one line on stderr (default: when it is a terminal)."""
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        return None

    def progress(done: int, total: int) -> None:
        width = 30
        k = int(width * done / max(total, 1))
        sys.stderr.write(f"\r{label:<12} [{'#' * k}{'-' * (width - k)}] {done}/{total}")
        if done >= total:
            sys.stderr.write("\n")
        sys.stderr.flush()

    return progress
