"""The notes ``identify`` adds to a fit: torques in another unit, a prior that is no physical arm, what the
data decided and what the prior kept, and what the fit should doubt.

Layer 5 (identification), room ``results``.  Each function returns sentences (and, for
:func:`decided_by`, the figures behind them) that :func:`manipdyn.identification.identify` puts among the
fit's notes, the trust record and the report.
"""

from __future__ import annotations

import os

__all__ = ["decided_by", "decided_record", "units_notes", "not_physical_notes", "fit_doubts"]


def decided_by(result, arm, weight, data, method):
    """``(decided, notes)``: what the data, the prior and the floor decided
    (:func:`..estimation.prior.attribution`) and its notes, or ``(None, [])`` for a fit without the base
    parameters' covariance (``ols``)."""
    from ..estimation.prior import attribution, describe_attribution, prior_parameters

    if method == "ols" or result.covariance is None:
        return None, []
    b = result.base
    prior_pi = prior_parameters(arm, b.armature, b.friction, len(b.names))
    floored = [int(x.split()[1]) - 1 for x in result.report.get("active_bounds", []) if "radius of gyration" in x]
    decided = attribution(result, prior_pi, float(weight), len(data.q) * arm.n, floored)
    return decided, describe_attribution(decided)


def decided_record(decided) -> dict:
    """The trust record's ``decided``: the weight, each link's verdict and the base parameters the prior kept."""
    return {"weight": decided["weight"], "links": decided["links"],
            "prior": [x["what"] for x in decided["base"] if x["by"] == "prior"]}


def units_notes(arm, data) -> list[str]:
    """Torques in another unit than the prior's (:mod:`..inputs.units`): first among the notes, and warned."""
    from ..._support.errors import SuspiciousValueWarning, warn_at_caller
    from ..inputs.units import prior_torque_note

    note = prior_torque_note(arm, data)
    if note:
        warn_at_caller(note, SuspiciousValueWarning)
    return [note] if note else []


def not_physical_notes(arm, label) -> list[str]:
    """The prior's own doubt: no physical arm (:func:`manipdyn.model.plausible.not_physical_note`)."""
    from ...model.plausible import not_physical_note

    note = not_physical_note(arm, os.path.basename(str(label)), "the prior")
    return [note] if note else []


def fit_doubts(result, data, runs) -> list[str]:
    """What the fit should doubt (:mod:`.doubts`): degenerate bodies, runs far off, payloads contradicted."""
    from .doubts import degenerate_links, floor_doubts, payload_doubts, run_doubts, solver_doubts

    return (solver_doubts(result.report) + (degenerate_links(result.arm) if result.arm is not None else [])
            + floor_doubts(result.report.get("active_bounds")) + run_doubts(result, data, result.report)
            + payload_doubts(result.arm, runs))
