"""What ``manipdyn identify`` checks before any work starts: its outputs and its unbounded options.

Layer 7 (CLI, the top).

Everything here runs before the log is read, so that a mistake costs a second, not a
fit: every output is writable and none of them is (or resolves to) MODEL or DATA
(:func:`~manipdyn.cli.common.check_outputs`); ``--bootstrap``, ``--prior-weight`` and
``--scheduler`` are within :mod:`manipdyn.limits` and well formed.
"""

from __future__ import annotations

import os

from .._support import limits
from .._support.errors import ModelError
from .common import check_outputs, check_report_target

__all__ = ["check_identify", "check_cutoff"]


def _implied_base(args):
    """The base model ``identify`` writes beside ``-o`` when ols/wls gives no physical arm."""
    out = args.output
    if (out is None or getattr(args, "payload", False) or args.base_json is not None
            or out.lower().endswith(".json") or args.method not in ("ols", "wls")):
        return None
    return os.path.splitext(out)[0] + ".base.json"


def check_cutoff(value, option: str = "--velocity-cutoff") -> None:
    """Refuse a residual low-pass cut-off that is no frequency (negative, nan, inf) or none a log resolves
    (over limits.MAX_BANDWIDTH, or under limits.MIN_VELOCITY_CUTOFF but 0), before the fit: after it,
    the thresholds would be missing (or 1e-12 N m) with the reason on stdout only."""
    if value is None:
        return
    fc = float(value)
    if fc == 0:
        return
    if not (limits.MIN_VELOCITY_CUTOFF <= fc <= limits.MAX_BANDWIDTH):
        raise ModelError(f"{option}: expected 0 (no low-pass) or a cut-off in Hz from {limits.MIN_VELOCITY_CUTOFF:g} "
                         f"(manipdyn.limits.MIN_VELOCITY_CUTOFF) to {limits.MAX_BANDWIDTH:g}, got {value}")


def check_identify(args) -> None:
    """Refuse, with a ModelError naming the option, what would fail or destroy an input after a fit."""
    if args.bootstrap:
        limits.check_count(args.bootstrap, "--bootstrap", "the number of replicates (each a whole refit)",
                           "MAX_BOOTSTRAP", cli=True)
    w = args.prior_weight
    if w not in (None, "auto"):
        try:
            w = float(w)
        except (TypeError, ValueError):
            raise ModelError(f"--prior-weight: expected a number >= 0 or 'auto', got {w!r:.60}") from None
        if not 0 <= w <= limits.MAX_PRIOR_WEIGHT:
            raise ModelError(f"--prior-weight: expected a number in [0, {limits.MAX_PRIOR_WEIGHT:g}] "
                             f"(manipdyn.limits.MAX_PRIOR_WEIGHT) or 'auto', got {args.prior_weight}")
    check_cutoff(getattr(args, "velocity_cutoff", None))
    if args.scheduler is not None:
        from ..check.scale import check_scheduler

        check_scheduler(args.scheduler, "--scheduler")
    report = getattr(args, "report", None)
    check_report_target(report)
    check_outputs([("-o", args.output), ("--base-json", args.base_json),
                   ("the base model beside -o", _implied_base(args)), ("--report", report)],
                  [("MODEL", args.model), ("--logs", getattr(args, "logs", None))]
                  + [("LOG", d) for d in ([args.data] if isinstance(args.data, str) else args.data)])
