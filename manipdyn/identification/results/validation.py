"""Scoring a model on held-out data: ``validate`` and its figure.

Layer 5 (identification).

A model (any arm, or a :class:`~.basemodel.BaseModel`) predicts the joint torques of
measured states; the score per joint is

* ``rms``: RMS of measured minus predicted torque (N m, N for a prismatic joint);
* ``relative_rms``: that RMS over the RMS of the measured torque (0 is perfect, 1 is as
  good as predicting zero torque);
* ``r2``: the coefficient of determination ``1 - SS_res / SS_tot`` about the measured
  mean (1 perfect, 0 as good as the mean, negative worse than the mean);
* ``mean_error``: the mean of measured minus predicted (a bias the RMS hides);
* a 95 % prediction band per sample and the fraction of measured torques inside it
  (per joint and pooled): the band the model carries from blocked hold-outs of its fit
  data (:mod:`.bands`: model error and correlated noise), or, for an older base model that
  carries only a covariance, ``1.96 sqrt(y_b C y_b^T + sigma_j^2)`` (parameter uncertainty
  plus white noise: too narrow on real data, and said so);
* with a model that carries its fitted range (:mod:`.coverage`): per joint, the fraction
  of samples outside the states the fit saw, and the joints that extrapolate.

The model's own friction and armature are included: what :meth:`Arm.inverse_dynamics`
predicts, the fast path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..._support.errors import ModelError
from ..._support.limits import check_fit_size

__all__ = ["ValidationResult", "validate", "plot_validation", "write_predictions"]

COVARIANCE_BAND = "parameter covariance and white noise only: no model error, too narrow on real data"


@dataclass
class ValidationResult:
    """Per-joint scores of :func:`validate` (module docstring), arrays of shape (n,).

    ``measured`` and ``predicted`` (N, n) and ``t`` (N,) are kept for the figure.
    """

    model: str
    rms: np.ndarray
    relative_rms: np.ndarray
    r2: np.ndarray
    mean_error: np.ndarray
    t: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    band: np.ndarray | None = None          # (N, n) half-width of the 95 % band
    coverage: np.ndarray | None = None      # (n,) fraction of measured torques inside it
    band_method: str | None = None
    carried_band: object = None             # bands.PredictionBand the model carries, or None
    extrapolation: object = None            # coverage.Extrapolation, or None
    notes: list = field(default_factory=list)

    @property
    def pooled_coverage(self) -> float | None:
        """The band's coverage over all joints' samples together."""
        return None if self.coverage is None else float(np.mean(self.coverage))

    def to_dict(self) -> dict:
        """JSON-ready figures (NaN, e.g. R^2 of a joint with constant torque, becomes None)."""
        def clean(a):
            return [float(x) if math.isfinite(x) else None for x in np.asarray(a)]

        out = {"model": self.model, "samples": int(len(self.t)), "rms": clean(self.rms),
               "relative_rms": clean(self.relative_rms), "r2": clean(self.r2),
               "mean_error": clean(self.mean_error)}
        if self.coverage is not None:
            out["band_95_coverage"] = clean(self.coverage)
            out["band_95_pooled"] = self.pooled_coverage
            out["band_method"] = self.band_method
            if self.carried_band is not None:
                out["band_95_half_width"] = clean(self.carried_band.half_width)
        out["extrapolation"] = None if self.extrapolation is None else self.extrapolation.to_list()
        out["model_notes"] = list(self.notes)
        return out

    def format(self, unit: str = "N m") -> str:
        """A table, one row per joint."""
        lines = [f"model {self.model}: {len(self.t)} samples",
                 f"joint   rms ({unit})   rms / measured rms       R^2   mean error ({unit})"]
        for j in range(len(self.rms)):
            lines.append(f"{j + 1:>5}   {self.rms[j]:10.4g}   {self.relative_rms[j]:18.4g}   "
                         f"{self.r2[j]:7.4f}   {self.mean_error[j]:+14.4g}")
        if self.coverage is not None:
            if self.carried_band is not None:
                lines.append("95 % prediction band: predicted +- " + ", ".join(
                    f"{x:.3g}" for x in self.carried_band.half_width) + f" {unit} per joint")
            lines.append(f"95 % prediction band ({self.band_method}) holds the measured torque: "
                         + ", ".join(f"j{j + 1} {100 * c:.1f} %" for j, c in enumerate(self.coverage))
                         + f"; pooled {100 * self.pooled_coverage:.1f} %")
        if self.extrapolation is not None:
            lines.append(self.extrapolation.format(units=None if unit == "N m" else [unit] * len(self.rms)))
        lines += [f"note: {x}" for x in self.notes]
        return "\n".join(lines)


def validate(model, data, name: str | None = None) -> ValidationResult:
    """Score ``model`` on the measurements ``data`` (module docstring).

    Parameters
    ----------
    model : manipdyn.Arm or BaseModel
        Anything with ``inverse_dynamics(q, qd, qdd)`` and ``n``.
    data : Measurements
        ``t`` (N,), ``q``, ``qd``, ``qdd``, ``tau`` (N, n), SI units, joint space.
    """
    n = getattr(model, "n", None)
    if data.q.ndim != 2 or data.q.shape[1] != n:
        raise ModelError(f"data: {data.q.shape[1] if data.q.ndim == 2 else '?'} joints, but the model "
                         f"{getattr(model, 'name', '')!r} has {n}")
    if len(data.t) < 2:
        raise ModelError(f"data: {len(data.t)} samples; validation needs at least 2")
    if hasattr(model, "parameters") and hasattr(model, "prediction_std"):    # a base model: a regressor
        check_fit_size(len(data.t), n, len(model.parameters))
    pred = np.asarray(model.inverse_dynamics(data.q, data.qd, data.qdd), dtype=np.float64)
    err = data.tau - pred
    rms = np.sqrt(np.mean(err**2, axis=0))
    meas_rms = np.sqrt(np.mean(data.tau**2, axis=0))
    ss_tot = np.sum((data.tau - data.tau.mean(axis=0)) ** 2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(meas_rms > 0, rms / meas_rms, np.nan)
        r2 = np.where(ss_tot > 0, 1.0 - np.sum(err**2, axis=0) / ss_tot, np.nan)
    from .provenance import carried

    fitted, held_out, notes = carried(model)
    band = coverage = method = None
    std = None
    if held_out is not None:
        band, method = np.broadcast_to(held_out.half_width, pred.shape), held_out.describe()
    elif hasattr(model, "prediction_std"):
        std = model.prediction_std(data.q, data.qd, data.qdd)
    if std is not None:
        noise = np.asarray(model.data.get("noise_sigma") or np.zeros(n), dtype=np.float64)
        band = 1.959964 * np.sqrt(std**2 + noise**2)      # 95 % of a Gaussian
        method = COVARIANCE_BAND
    if band is not None:
        coverage = np.mean(np.abs(err) <= band, axis=0)
    return ValidationResult(model=name or getattr(model, "name", "model"), rms=rms, relative_rms=rel,
                            r2=r2, mean_error=err.mean(axis=0), t=np.asarray(data.t), measured=data.tau,
                            predicted=pred, band=band, coverage=coverage, band_method=method, carried_band=held_out,
                            extrapolation=None if fitted is None else fitted.outside(data), notes=notes)


def write_predictions(result: ValidationResult, path) -> None:
    """Write ``t, tau1..taun`` (measured), ``pred1..predn`` and, with a band, ``lo1..lon, hi1..hin``
    per sample as CSV, atomically (s, N m or N): anyone can check the band with it."""
    from ..._support.files import atomic_write_text

    n = result.measured.shape[1]
    cols = [result.t[:, None], result.measured, result.predicted]
    names = ["t"] + [f"{k}{j + 1}" for k in ("tau", "pred") for j in range(n)]
    if result.band is not None:
        cols += [result.predicted - result.band, result.predicted + result.band]
        names += [f"{k}{j + 1}" for k in ("lo", "hi") for j in range(n)]
    table = np.hstack(cols)
    lines = [",".join(names)] + [",".join(repr(float(x)) for x in row) for row in table]
    atomic_write_text(path, "\n".join(lines) + "\n")


def plot_validation(results, path, title: str | None = None, units=None) -> None:
    """Measured against predicted torque per joint, with a residual panel under each, written to ``path``.

    ``results`` is one :class:`ValidationResult` or a list of them (several models on the
    same data, e.g. identified against published); ``units`` per joint (default N m).
    """
    from ..._support.figures import pyplot, save_figure

    plt = pyplot()
    results = results if isinstance(results, (list, tuple)) else [results]
    r0 = results[0]
    n = r0.measured.shape[1]
    units = units or ["N m"] * n
    ncol = 2 if n > 3 else 1
    nrow = math.ceil(n / ncol)
    fig = plt.figure(figsize=(12 if ncol == 2 else 7.5, 2.9 * nrow + 0.9))
    outer = fig.add_gridspec(nrow, ncol, hspace=0.5, wspace=0.3, top=1 - 1.3 / (2.9 * nrow + 0.9))
    for j in range(n):
        inner = outer[j // ncol, j % ncol].subgridspec(2, 1, height_ratios=(3, 1), hspace=0.05)
        ax, axr = fig.add_subplot(inner[0]), fig.add_subplot(inner[1])
        ax.plot(r0.t, r0.measured[:, j], color="0.55", lw=1.2, label="measured")
        for k, r in enumerate(results):
            if r.band is not None:
                ax.fill_between(r.t, r.predicted[:, j] - r.band[:, j], r.predicted[:, j] + r.band[:, j],
                                color=f"C{k}", alpha=0.25, lw=0, label=f"{r.model}: 95 % prediction band")
            ax.plot(r.t, r.predicted[:, j], lw=1.0, color=f"C{k}", label=f"{r.model}: predicted")
            axr.plot(r.t, r.measured[:, j] - r.predicted[:, j], lw=0.8, color=f"C{k}")
        axr.axhline(0.0, color="0.3", lw=0.6)
        ax.set_ylabel(f"torque ({units[j]})")
        axr.set_ylabel(f"residual ({units[j]})", fontsize=8)
        axr.text(0.005, 0.97, "measured \u2212 predicted", transform=axr.transAxes, va="top", fontsize=7,
                 bbox=dict(facecolor="white", edgecolor="none", alpha=0.8, pad=1.0))
        for a in (ax, axr):                   # one column of labels: the two never overlap
            a.yaxis.set_label_coords(-0.14, 0.5)
        ax.tick_params(labelbottom=False)
        best = int(np.argmin([r.rms[j] if np.isfinite(r.rms[j]) else np.inf for r in results]))
        flagged = any(r.extrapolation is not None and bool(r.extrapolation.flagged[j]) for r in results)
        scores = [f"{r.rms[j]:.3g} {units[j]}" + (f" (band holds {100 * r.coverage[j]:.0f} %)"
                                                  if r.coverage is not None else "") for r in results]
        warn = ", EXTRAPOLATES" if flagged else ""     # beyond the states the fit saw (coverage.py)
        if len(results) == 1:
            ax.set_title(f"joint {j + 1}: RMS error {scores[0]}{warn}", fontsize=9, color="C3" if flagged else "black")
        else:           # one line per model inside the panel, the best marked
            ax.set_title(f"joint {j + 1}: best {results[best].model}{warn}", fontsize=9,
                         color="C3" if flagged else "black")
            ax.text(0.01, 0.97, "\n".join(("* " if k == best else "  ") + f"{r.model}: {scores[k]}"
                                          for k, r in enumerate(results)),
                    transform=ax.transAxes, va="top", ha="left", fontsize=7, family="monospace",
                    bbox=dict(facecolor="white", alpha=0.7, lw=0))
        if j == 0:
            handles, labels = ax.get_legend_handles_labels()
        ax.grid(alpha=0.3)
        axr.grid(alpha=0.3)
        axr.set_xlabel("time (s)", fontsize=8)
    fig.legend(handles, labels, loc="upper center", ncol=min(len(labels), 4), frameon=False, fontsize=8,
               bbox_to_anchor=(0.5, 1 - 0.55 / (2.9 * nrow + 0.9)))
    fig.suptitle(title or f"measured and predicted joint torques: {', '.join(r.model for r in results)}")
    save_figure(fig, path)
