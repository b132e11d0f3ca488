"""Several models scored on the same data, side by side: ``validate MODEL_A MODEL_B ... DATA``.

Layer 5 (identification).

Each model is scored by :func:`.validation.validate` on the same samples; the table puts
their held-out RMS per joint in columns and marks the best per joint (the smallest RMS,
``*``).  The band's coverage and the extrapolation flags are each model's own (each model
carries its own fitted range and band).  The JSON form keeps every model's full scores
and adds ``best`` per joint (the model's index and label).
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError

__all__ = ["model_labels", "best_per_joint", "format_side_by_side", "side_by_side_dict"]


def best_per_joint(results) -> np.ndarray:
    """Index (n,) of the result with the smallest RMS on each joint (the first of equals)."""
    if not results:
        raise ModelError("results: expected at least one validation result")
    n = len(results[0].rms)
    if any(len(r.rms) != n or len(r.t) != len(results[0].t) for r in results):
        raise ModelError("results: the models were not scored on the same data (joints or samples differ)")
    rms = np.array([np.where(np.isfinite(r.rms), r.rms, np.inf) for r in results])
    return np.argmin(rms, axis=0)


def model_labels(results) -> list[str]:
    """The models' labels, numbered ``[k]`` where two share one (as the table and the JSON name them)."""
    labels = [r.model for r in results]
    return [f"{lab} [{k + 1}]" if labels.count(lab) > 1 else lab for k, lab in enumerate(labels)]


def format_side_by_side(results, unit: str = "N m", units=None) -> str:
    """One table: RMS per joint (rows) and model (columns), the best per joint marked ``*``; then each
    model's band coverage (with its ``BAND MISSES`` lines) and extrapolation lines.  ``units`` per joint (N m, N for a prismatic
    joint), else ``unit`` for every joint; mixed units are printed at the end of each row."""
    best = best_per_joint(results)
    labels = model_labels(results)
    width = max(12, *(len(lab) + 2 for lab in labels))
    n = len(results[0].rms)
    units = list(units) if units is not None else [unit] * n
    same = len(set(units)) == 1
    lines = [f"{len(results)} models on {len(results[0].t)} samples: RMS error"
             + (f" ({units[0]})" if same else " (unit at the end of each row)") + ", * = best on the joint",
             "joint " + "".join(f"{lab:>{width}}" for lab in labels)]
    for j in range(n):
        cells = [f"{r.rms[j]:.4g}" + ("*" if best[j] == k else " ") for k, r in enumerate(results)]
        lines.append(f"{j + 1:>5} " + "".join(f"{c:>{width}}" for c in cells) + ("" if same else f"  {units[j]}"))
    lines.append("best  " + ", ".join(f"j{j + 1}: {labels[best[j]]}" for j in range(n)))
    from .forward_error import format_accel_side_by_side

    lines += format_accel_side_by_side(results, labels, units)
    for lab, r in zip(labels, results):
        extra = []
        if r.coverage is not None:
            extra.append(f"  95 % band ({r.band_method}) holds: " + ", ".join(
                f"j{j + 1} {100 * c:.1f} %" for j, c in enumerate(r.coverage))
                + f"; pooled {100 * r.pooled_coverage:.1f} %")
            extra += r.band_miss_lines(indent="  ")
        if r.extrapolation is not None:
            extra.append("  " + r.extrapolation.summary())
        extra += [f"  note: {x}" for x in r.notes]
        if extra:
            lines += [f"{lab}:"] + extra
    return "\n".join(lines)


def side_by_side_dict(results) -> dict:
    """JSON-ready: ``{"models": [each model's scores], "best": [{"joint", "model", "index"}, ...],
    "best_accel": [...]}`` (``best_accel``: the smallest acceleration RMS per joint, None when a
    model has none, :mod:`.forward_error`)."""
    from .forward_error import best_accel_per_joint

    best = best_per_joint(results)
    labels = model_labels(results)
    acc = best_accel_per_joint(results)
    return {"models": [r.to_dict() for r in results],
            "best": [{"joint": j + 1, "model": labels[k], "index": int(k)} for j, k in enumerate(best)],
            "best_accel": None if acc is None else [{"joint": j + 1, "model": labels[k], "index": int(k)}
                                                    for j, k in enumerate(acc)]}
