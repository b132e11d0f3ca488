"""Identification report: the figures of ``manipdyn identify --json`` and a text table.

Layer 5 (identification).
"""

from __future__ import annotations

import numpy as np

from ...model.inertia import pseudo_inertia_from_parameters
from .covariance import STD_SOURCE

__all__ = ["build_report", "format_report", "friction_to_json", "shortfall", "FLOOR_DROPPED", "SHORTFALL_RTOL",
           "SHORTFALL_ATOL"]


def friction_to_json(friction, n: int):
    """A regressor's ``friction=`` as JSON: a bool, or the law's terms, side, smoothing,
    deadband and nonlinear shapes (:func:`friction_from_json` reads it back)."""
    if friction is None or friction is False or friction is True:
        return bool(friction)
    from ...model.friction import friction_spec

    spec = friction_spec(friction, n)
    out = {"terms": list(spec.terms), "side": spec.side, "smoothing": spec.smoothing,
           "deadband": spec.deadband, "stribeck_exponent": spec.stribeck_exponent}
    for key in ("stribeck_velocity", "sigmoid_alpha", "sigmoid_p3"):
        v = getattr(spec, key)
        if v is not None:
            out[key] = [float(x) for x in v]
    return out



def build_report(result, solver: str, samples: int, cov=None, min_eigenvalues=None) -> dict:
    """A JSON-ready dict: ``n_base``, ``condition_number``, ``rms_residual`` (n, N m),
    ``consistent``, ``method`` and details (noise levels, base parameters with their
    expressions, values and, for ``wls`` and ``consistent``, standard deviations and
    Gautier's relative standard deviations in %; ``std_source`` says how they were
    estimated, :mod:`.uncertainty`)."""
    b = result.base
    rms = np.sqrt(np.mean(result.residuals**2, axis=0))
    rows = []
    std = np.sqrt(np.clip(np.diag(cov), 0, None)) if cov is not None else None
    for k, expr in enumerate(b.expressions()):
        row = {"expression": expr, "value": float(result.beta[k])}
        if std is not None:
            row["std"] = float(std[k])
            row["rel_std_percent"] = float(100 * std[k] / max(abs(result.beta[k]), 1e-300))
        rows.append(row)
    return {
        "method": result.method,
        "n_base": int(b.count),
        "condition_number": float(result.condition_number) if np.isfinite(result.condition_number) else None,
        "rms_residual": [float(x) for x in rms],
        "noise_sigma": [float(x) for x in result.sigma],
        "consistent": bool(result.consistent),
        "min_eigenvalue_J": [float(x) for x in (min_eigenvalues if min_eigenvalues is not None else [])],
        "samples": int(samples),
        "solver": solver,
        "friction": friction_to_json(b.friction, len(result.sigma)),
        "armature": bool(b.armature),
        "arm_error": result.arm_error,
        "base_parameters": rows,
        "std_source": STD_SOURCE.get(result.method) if std is not None else None,
    }


def format_report(rep: dict) -> str:
    """A readable summary of :func:`build_report`'s dict."""
    lines = [
        f"method {rep['method']} ({rep['solver']}), {rep['samples']} samples, "
        f"{rep['n_base']} base parameters, condition number "
        f"{'infinite' if rep['condition_number'] is None else format(rep['condition_number'], '.4g')}",
        f"physically consistent (every J_i >= 0): {'yes' if rep['consistent'] else 'NO'}",
        "joint   rms residual   noise (OLS)",
    ]
    floored = set(rep.get("noise_floor_joints") or ())
    for j, (r, s) in enumerate(zip(rep["rms_residual"], rep["noise_sigma"])):
        lines.append(f"{j + 1:>5}   {r:12.4g}   {s:11.4g}" + ("  (floor)" if j + 1 in floored else ""))
    if floored:
        lines.append("(floor): the joint's OLS noise estimate is below 1e-6 of its own RMS torque, rounding "
                     "rather than noise (exact data?); the floor, 1e-6 of the "
                     "largest joint's RMS torque, is printed and weighs it")
    lines.append("base parameters" + (" (+- %sigma: Gautier's relative standard deviation, "
                                      f"{rep['std_source']})" if rep.get("std_source") else "") + ":")
    for row in rep["base_parameters"]:
        extra = ""
        if "rel_std_percent" in row:     # a relative spread over 1000 % says nothing a reader can use
            extra = (f"  (+-{row['rel_std_percent']:.2g} %)" if row["rel_std_percent"] <= 1000
                     else f"  (+-{row['std']:.2g}: over 10 times its value, not determined)")
        lines.append(f"  {row['value']:+.6g} = {row['expression']}{extra}")
    comp = rep.get("completion")
    if comp and comp["exact"]:
        lines.append(f"the least-squares bodies were no physical arm; physical bodies with the same base parameters "
                     f"(to {comp['base_error']:.1g} relative) are the model: links "
                     f"{', '.join(map(str, comp['changed_links']))} completed (model/completion.py)")
    if rep.get("arm_error"):
        lines.append(f"the identified parameters cannot be written as a model: {rep['arm_error']}")
    return "\n".join(lines)


#: relative growth of the weighted residual over least squares' that :func:`shortfall` explains
SHORTFALL_RTOL = 1e-2
#: and the absolute floor (of the weighted torque's norm) below which it is rounding
SHORTFALL_ATOL = 1e-6
#: the note of a fit that dropped the radius-of-gyration floor (the reason in braces)
FLOOR_DROPPED = ("the radius-of-gyration floor (a plausibility bound, best effort) was dropped: the fit with it "
                 "failed ({}); this fit has the mass, COM and total-mass bounds and J_i >= 0 only, so a body's "
                 "shape may be degenerate (a rod or a plate)")


def shortfall(R, c, rho0, yw, ew, pi, n, nonnegative, bounds, solver, active_bounds, prior_weight: float = 0.0) -> dict:
    """How much more of the (weighted) torque the consistent fit leaves than least squares,
    and why: the constraints it sits on, the pull towards the prior (``prior_weight`` > 0: the gap is the
    pull's price, chosen, not a solver's failure), or a solver that stopped short.

    Returns ``relative_residual`` (``||e_w|| / ||tau_w||``, weighted rows),
    ``least_squares_relative_residual`` (the same for the unconstrained optimum),
    ``stopped_short`` (bool) and ``fit_notes`` (sentences, empty when the two agree).
    """
    norm = max(float(np.linalg.norm(yw)), 1e-300)
    rel = float(np.linalg.norm(ew)) / norm
    beta_ls = np.linalg.lstsq(R, c, rcond=None)[0]
    ls = float(np.sqrt(np.sum((R @ beta_ls - c) ** 2) + rho0**2)) / norm
    out = {"relative_residual": rel, "least_squares_relative_residual": ls, "stopped_short": False,
           "fit_notes": []}
    inaccurate = "inaccurate" in str(solver)
    J = pseudo_inertia_from_parameters(np.asarray(pi)[:10 * n].reshape(n, 10))
    ev = np.linalg.eigvalsh(J)
    at_psd = [i + 1 for i in range(n) if ev[i, 0] <= 1e-6 * max(float(ev[i, -1]), 1e-300)]
    extra = np.asarray(pi)[10 * n:][nonnegative] if len(pi) > 10 * n else np.zeros(0)
    at_zero = int(np.sum(extra <= 1e-9 * max(float(np.abs(pi).max()), 1e-300)))
    reasons = ([f"J_i >= 0 of link(s) {', '.join(map(str, at_psd))}"] if at_psd else []) \
        + ([f"{at_zero} armature/friction coefficient(s) at 0"] if at_zero else []) + list(active_bounds)
    if bounds is not None and not bounds.satisfied(pi, n, rtol=1e-6):
        out["fit_notes"].append("the answer is outside its bounds: the data and the bounds disagree beyond "
                                "what the solver can resolve (are the torques in other units than the "
                                "prior's masses?); widen or drop the bounds")
        reasons.append("the bounds")
    if rel <= ls * (1 + SHORTFALL_RTOL) + SHORTFALL_ATOL and not inaccurate:
        return out
    head = (f"the consistent fit leaves {rel:.3g} of the weighted torque unexplained where least squares "
            f"leaves {ls:.3g}")
    if prior_weight and prior_weight > 0 and not inaccurate:
        out["fit_notes"].append(f"{head}: the pull towards the prior (weight {prior_weight:.3g}) costs that"
                                + (f", with the constraints it sits on ({'; '.join(reasons)})" if reasons else ""))
    elif reasons and not inaccurate:
        out["fit_notes"].append(f"{head}: the constraints it sits on cost that ({'; '.join(reasons)})")
    else:
        out["stopped_short"] = True
        why = "the solver reported an inaccurate answer" if inaccurate else "no constraint is active"
        out["fit_notes"].append(f"{head}, and {why}: the solver ({solver}) stopped short of the best "
                                "physical fit; this answer is not it")
    return out
