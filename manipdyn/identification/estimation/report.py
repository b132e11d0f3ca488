"""Identification report: the figures of ``manipdyn identify --json`` and a text table.

Layer 5 (identification).
"""

from __future__ import annotations

import numpy as np

from .covariance import STD_SOURCE

__all__ = ["build_report", "format_report", "friction_to_json"]


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
    for j, (r, s) in enumerate(zip(rep["rms_residual"], rep["noise_sigma"])):
        lines.append(f"{j + 1:>5}   {r:12.4g}   {s:11.4g}")
    lines.append("base parameters" + (" (+- %sigma: Gautier's relative standard deviation, "
                                      f"{rep['std_source']})" if rep.get("std_source") else "") + ":")
    for row in rep["base_parameters"]:
        extra = f"  (+-{row['rel_std_percent']:.2g} %)" if "rel_std_percent" in row else ""
        lines.append(f"  {row['value']:+.6g} = {row['expression']}{extra}")
    if rep.get("arm_error"):
        lines.append(f"the identified parameters cannot be written as a model: {rep['arm_error']}")
    return "\n".join(lines)
