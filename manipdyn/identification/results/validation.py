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
  of samples outside the states the fit saw, and the joints that extrapolate; with its
  leverage reference (:mod:`.leverage`), per sample and joint whether the state is beyond
  every fitted sample's for that joint's regressor row, and the band widened there;
* with a model that carries the joints' rest (``rest``: :mod:`..inputs.rest`), a joint at rest is still
  (the prediction its rigid part, no Coulomb torque on the sign of the velocity's noise) and the band
  there widens by its static friction level; at rest where the fit never rested, the sample is flagged;
* a joint whose band holds under 80 % of the samples is flagged (``BAND MISSES``,
  ``--json`` ``band_95_missed``): the band failed there, whatever the flags predicted.

The model's own friction and armature are included: what ``Arm.inverse_dynamics``
predicts, the fast path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..._support.errors import ModelError
from ..._support.limits import check_fit_size

__all__ = ["ValidationResult", "validate", "plot_validation", "write_predictions"]

#: a joint whose 95 % band holds under this fraction of the samples is flagged (the band failed there)
MISS_COVERAGE = 0.8
COVARIANCE_BAND = "parameter covariance and white noise only: no model error, too narrow on real data"


def percent_under(fraction: float, limit: float) -> str:
    """``100 * fraction`` as text with the fewest decimals (0 to 6) that keep it below ``100 * limit``
    when ``fraction < limit``: 0.798 under 0.8 is ``"79.8"``, never ``"80"``."""
    x, cap = 100 * float(fraction), 100 * float(limit)
    for d in range(7):
        text = f"{x:.{d}f}"
        if not (fraction < limit) or float(text) < cap:
            return text
    return f"{x:.6g}"


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
    carried_band: object = None             # band_record.PredictionBand the model carries, or None
    extrapolation: object = None            # coverage.Extrapolation, or None
    notes: list = field(default_factory=list)
    accel_rms: np.ndarray | None = None     # (n,) RMS of D^-1 (tau - tau_hat), rad/s^2 (:mod:`.forward_error`)

    @property
    def band_missed(self) -> np.ndarray | None:
        """(n,) bool: the joints whose band holds under :data:`MISS_COVERAGE` of this data's samples."""
        return None if self.coverage is None else self.coverage < MISS_COVERAGE

    @property
    def pooled_coverage(self) -> float | None:
        """The band's coverage over all joints' samples together."""
        return None if self.coverage is None else float(np.mean(self.coverage))

    def band_miss_lines(self, indent: str = "") -> list[str]:
        """One ``BAND MISSES joint j`` line per joint whose band holds under :data:`MISS_COVERAGE`
        (the coverage printed with as many decimals as it takes to stay under it: 79.8 %, not 80 %)."""
        if self.coverage is None:
            return []
        return [f"{indent}BAND MISSES joint {j + 1}: the 95 % band holds "
                f"{percent_under(self.coverage[j], MISS_COVERAGE)} % of these samples (under {100 * MISS_COVERAGE:g} %): this joint's error here is beyond what the "
                "fit data showed; do not trust its band" for j in np.flatnonzero(self.band_missed)]

    def to_dict(self) -> dict:
        """JSON-ready figures (NaN, e.g. R^2 of a joint with constant torque, becomes None).

        Keys (added, never renamed): ``model``, ``samples``, ``rms``, ``relative_rms``, ``r2``,
        ``mean_error`` (per joint); with a band ``band_95_coverage`` (per joint), ``band_95_pooled``,
        ``band_method``, ``band_95_half_width`` (at a typical fitted sample), ``band_95_leverage_gain``,
        ``band_95_mean_half_width`` (over these samples), ``band_95_missed`` (1-based joints under
        80 %); with per-sample flags, ``flagged_fraction``, ``band_95_coverage_flagged`` and
        ``band_95_coverage_unflagged`` (per joint, None where no sample is so) and ``band_95_pooled_flagged``,
        ``band_95_pooled_unflagged``; ``extrapolation`` (one object per joint: ``extrapolates``, ``range_extrapolates``,
        ``leverage_extrapolates``, ``beyond_fit_fraction``, ``leverage_ratio``, and per quantity),
        ``beyond_fit_fraction`` (samples beyond the fit on any joint), ``model_notes``; ``accel_rms``
        (per joint, rad/s^2 or m/s^2: the forward dynamics' error, :mod:`.forward_error`; None for a
        base model).
        """
        def clean(a):
            return [float(x) if math.isfinite(x) else None for x in np.asarray(a)]

        out = {"model": self.model, "samples": int(len(self.t)), "rms": clean(self.rms),
               "relative_rms": clean(self.relative_rms), "r2": clean(self.r2),
               "mean_error": clean(self.mean_error),
               "accel_rms": None if self.accel_rms is None else clean(self.accel_rms)}
        if self.coverage is not None:
            out["band_95_coverage"] = clean(self.coverage)
            out["band_95_pooled"] = self.pooled_coverage
            out["band_method"] = self.band_method
            if self.carried_band is not None:
                out["band_95_half_width"] = clean(self.carried_band.half_width)
                out["band_95_leverage_gain"] = (None if self.carried_band.leverage_gain is None
                                                else clean(self.carried_band.leverage_gain))
            out["band_95_mean_half_width"] = clean(np.mean(self.band, axis=0))
            out["band_95_missed"] = [int(j + 1) for j in np.flatnonzero(self.band_missed)]
            flags = None if self.extrapolation is None else self.extrapolation.flags
            if flags is not None:       # does a flag predict the misses?
                inside = np.abs(self.measured - self.predicted) <= self.band

                def held(mask):
                    return [float(np.mean(inside[mask[:, j], j])) if np.any(mask[:, j]) else None
                            for j in range(mask.shape[1])]

                out["flagged_fraction"] = clean(np.mean(flags, axis=0))
                out["band_95_coverage_flagged"] = held(flags)
                out["band_95_coverage_unflagged"] = held(~flags)
                out["band_95_pooled_flagged"] = float(np.mean(inside[flags])) if np.any(flags) else None
                out["band_95_pooled_unflagged"] = float(np.mean(inside[~flags])) if np.any(~flags) else None
        out["extrapolation"] = None if self.extrapolation is None else self.extrapolation.to_list()
        ex = self.extrapolation
        out["beyond_fit_fraction"] = (None if ex is None or ex.beyond is None
                                      else float(np.mean(np.any(ex.beyond, axis=1))))
        out["model_notes"] = list(self.notes)
        return out

    def format(self, unit: str = "N m", units=None) -> str:
        """A table, one row per joint; ``units`` per joint (N m, N for a prismatic joint), else
        ``unit`` for every joint.  Mixed units are printed on each row, one unit in the header."""
        n = len(self.rms)
        units = list(units) if units is not None else [unit] * n
        same = len(set(units)) == 1
        head = f" ({units[0]})" if same else ""
        acc = self.accel_rms is not None
        ahead = "   accel rms" + (" (rad/s^2)" if same and units[0] != "N" else " (m/s^2)" if same else "")
        lines = [f"model {self.model}: {len(self.t)} samples",
                 f"joint   rms{head:<7}   rms / measured rms       R^2   mean error{head}" + (ahead if acc else "")
                 + ("" if same else "   unit")]
        for j in range(n):
            lines.append(f"{j + 1:>5}   {self.rms[j]:10.4g}   {self.relative_rms[j]:18.4g}   "
                         f"{self.r2[j]:7.4f}   {self.mean_error[j]:+14.4g}"
                         + (f"   {self.accel_rms[j]:{len(ahead) - 3}.4g}" if acc else "")
                         + ("" if same else f"   {units[j]}"))
        if self.coverage is not None:
            if self.carried_band is not None:
                lines.append("95 % prediction band: predicted +- " + ", ".join(
                    f"{x:.3g}" + ("" if same else f" {u}") for x, u in zip(self.carried_band.half_width, units))
                    + (f" {units[0]} per joint" if same else " per joint"))
            lines.append(f"95 % prediction band ({self.band_method}) holds the measured torque: "
                         + ", ".join(f"j{j + 1} {100 * c:.1f} %" for j, c in enumerate(self.coverage))
                         + f"; pooled {100 * self.pooled_coverage:.1f} %")
            lines += self.band_miss_lines()
        if self.extrapolation is not None:
            lines.append(self.extrapolation.format(units=units))
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
    from .provenance import carried_trust

    trust = carried_trust(model)        # at rest (its record): the joint still, the prediction its rigid part
    qd = data.qd if trust.rest is None else trust.rest.velocity(data.qd)
    pred = np.asarray(model.inverse_dynamics(data.q, qd, data.qdd), dtype=np.float64)
    err = data.tau - pred
    rms = np.sqrt(np.mean(err**2, axis=0))
    meas_rms = np.sqrt(np.mean(data.tau**2, axis=0))
    ss_tot = np.sum((data.tau - data.tau.mean(axis=0)) ** 2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(meas_rms > 0, rms / meas_rms, np.nan)
        r2 = np.where(ss_tot > 0, 1.0 - np.sum(err**2, axis=0) / ss_tot, np.nan)
    fitted, held_out, notes = trust.fitted_range, trust.band, list(trust.notes)
    u = beyond = None
    if trust.leverage is not None:
        try:
            u, beyond = trust.leverage.ratio(_feature_arm(model), data.q, data.qd, data.qdd)
        except ModelError as exc:
            notes.append(f"{exc}; no leverage")
    band = coverage = method = None
    std = None
    if held_out is not None:
        band = held_out.sample_widths(u, data.qd, trust.rest)    # the slowest speeds' class, the static band at rest
        method = held_out.describe()
    elif hasattr(model, "prediction_std"):
        std = model.prediction_std(data.q, data.qd, data.qdd)
    if std is not None:
        noise = np.asarray(model.data.get("noise_sigma") or np.zeros(n), dtype=np.float64)
        band = 1.959964 * np.sqrt(std**2 + noise**2)      # 95 % of a Gaussian
        method = COVARIANCE_BAND
    if band is not None:
        coverage = np.mean(np.abs(err) <= band, axis=0)
    if held_out is not None and held_out.within_one_trajectory:
        from ..uncertainty.bands import WITHIN_ONE_TRAJECTORY

        notes.append(WITHIN_ONE_TRAJECTORY)
    from .forward_error import acceleration_error

    a_err, why = acceleration_error(model, np.asarray(data.q, dtype=np.float64), err)
    if why is not None:
        notes.append(why)
    extrapolation = _extrapolation(fitted, data, u, beyond)
    if extrapolation is not None:
        flags = fitted.far_samples(data)
        if beyond is not None:
            flags = flags | beyond
        if trust.leverage is not None:
            flags = flags | trust.leverage.rest_flags(data.qd)
        if trust.rest is not None:         # at rest where the fit never rested: its static level a stand-in
            flags = flags | trust.rest.flags(data.qd)
        extrapolation.flags = flags
    return ValidationResult(model=name or getattr(model, "name", "model"), rms=rms, relative_rms=rel,
                            r2=r2, mean_error=err.mean(axis=0), t=np.asarray(data.t), measured=data.tau,
                            predicted=pred, band=band, coverage=coverage, band_method=method, carried_band=held_out,
                            extrapolation=extrapolation, notes=notes,
                            accel_rms=None if a_err is None else np.sqrt(np.mean(a_err**2, axis=0)))


def _feature_arm(model):
    """The arm whose regressor gives ``model``'s leverage features: itself, or a base model's or a result's prior."""
    from ...model.arm import Arm

    if isinstance(model, Arm):
        return model
    return getattr(model, "prior", None) or getattr(model, "arm", None) or model


def _extrapolation(fitted, data, u, beyond):
    if fitted is None:
        return None
    out = fitted.outside(data)
    out.beyond, out.leverage_ratio = beyond, u
    return out


def write_predictions(result: ValidationResult, path) -> None:
    """Write ``t, tau1..taun`` (measured), ``pred1..predn``, with a band ``lo1..lon, hi1..hin``, and with a
    fitted range ``x1..xn`` (1 where the sample is flagged on that joint before its torque is seen: its own q or
    qd beyond the fitted range, its leverage beyond the held-out data's, near rest where the fit never rested;
    :mod:`.coverage`, :mod:`.leverage`)
    per sample as CSV, atomically (s, N m or N): anyone can check the band with it."""
    from ..._support.files import atomic_write_text

    n = result.measured.shape[1]
    cols = [result.t[:, None], result.measured, result.predicted]
    names = ["t"] + [f"{k}{j + 1}" for k in ("tau", "pred") for j in range(n)]
    if result.band is not None:
        cols += [result.predicted - result.band, result.predicted + result.band]
        names += [f"{k}{j + 1}" for k in ("lo", "hi") for j in range(n)]
    ex = result.extrapolation
    if ex is not None and ex.flags is not None:     # 1 where the sample is flagged, before its torque is seen
        cols.append(ex.flags.astype(np.float64))
        names += [f"x{j + 1}" for j in range(n)]
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
    fig = plt.figure(figsize=(12 if ncol == 2 else 7.5, 2.9 * nrow + 1.2))
    outer = fig.add_gridspec(nrow, ncol, hspace=0.5, wspace=0.3, top=1 - 1.75 / (2.9 * nrow + 0.9))
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
        # the residual's name is its axis label, outside the traces
        axr.set_ylabel(f"measured \u2212\npredicted ({units[j]})", fontsize=7)
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
        else:           # the scores in the title, above the traces (a box inside would hide them)
            ax.set_title(f"joint {j + 1}{warn}: RMS " + ", ".join(
                ("*" if k == best else "") + f"{r.model} {scores[k]}" for k, r in enumerate(results)),
                fontsize=8, color="C3" if flagged else "black", wrap=True)
        if j == 0:
            handles, labels = ax.get_legend_handles_labels()
        ax.grid(alpha=0.3)
        axr.grid(alpha=0.3)
        axr.set_xlabel("time (s)", fontsize=8)
    fig.legend(handles, labels, loc="upper center", ncol=min(len(labels), 4), frameon=False, fontsize=8,
               bbox_to_anchor=(0.5, 1 - 0.8 / (2.9 * nrow + 0.9)))
    fig.suptitle(title or f"measured and predicted joint torques: {', '.join(r.model for r in results)}", fontsize=10)
    save_figure(fig, path)
