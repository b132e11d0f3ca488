"""``identify`` and ``validate`` results as one self-contained HTML page each (``--report FILE.html``).

Layer 5 (identification).

Read from the top down: what was done (the command, every log with its sha256, the options,
the version), the verdict in a sentence, the per-joint table (RMS in-sample and held out,
the 95 % band's width and coverage, extrapolation; a flagged joint's row highlighted), the
figure (measured against predicted with the band, the residuals under it, the stretches where
the data is beyond the fit shaded), the parameters with their standard deviations and the
active bounds (identify), the models side by side (validate with several models), and the
data notes in words.  The tables hold the numbers of ``--json`` (each cell's exact value in
``data-value``, :mod:`manipdyn._support.html`); every text from a log, a file name or a model
name is escaped.  Fields that another version of the band or the trust data may add (a
per-sample band, a per-sample ``beyond`` mask) are read when present and never required.
"""

from __future__ import annotations

import os

import numpy as np

from ..._support import html as H
from ..._support.errors import ModelError
from ..uncertainty.coverage import FLAG_FRACTION, FLAG_MARGIN
from .validation import MISS_COVERAGE, percent_under

__all__ = ["identify_page", "validation_page", "beyond_mask", "torque_figure"]

#: the shading of the stretches beyond the fit: pale yellow, hatched (no model's line colour)
_SHADE = "#fff3a0"
_NO_FIG = ("No figure: matplotlib is not installed (pip install 'manipdyn[plot]', in a checkout "
           "pip install -e '.[plot]').")


def _logs(data, extra=()) -> list:
    """``(term, value)`` rows naming each log with its sample count and sha256."""
    rows = []
    for src, k in zip(getattr(data, "sources", ()) or (), getattr(data, "segments", ()) or ()):
        sha = H.sha256_of(src) if isinstance(src, (str, os.PathLike)) else None
        rows.append(("log", f"{os.path.basename(os.fspath(src)) if isinstance(src, (str, os.PathLike)) else src}: "
                            f"{int(k)} samples" + (f", sha256 {sha}" if sha else "")))
    return rows + list(extra)


def beyond_mask(result, data) -> np.ndarray | None:
    """(N, n) bool: the samples beyond the fit, per joint; the mask the extrapolation carries
    (``flags``, the ``x{i}`` columns of ``validate --predictions``, else ``beyond``) when it has one, else
    the samples whose ``q_j``,
    ``qd_j`` or ``tau_j`` lies beyond the fitted interval by more than the flag's margin
    (what :class:`.coverage.Extrapolation` counts as ``far_fraction``); None without a fitted range."""
    ex = getattr(result, "extrapolation", None)
    if ex is None:
        return None
    mask = getattr(ex, "flags", None)
    if mask is None:
        mask = getattr(ex, "beyond", None)
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape == result.measured.shape:
            return mask
    fitted = getattr(ex, "fitted", None)
    if fitted is None or data is None:
        return None
    far = np.zeros(result.measured.shape, dtype=bool)
    for k in ("q", "qd", "tau"):
        x, box = getattr(data, k, None), getattr(fitted, k, None)
        if x is None or box is None or np.shape(x) != far.shape:
            continue
        box = np.asarray(box, dtype=np.float64)
        pad = ex.margin * (box[:, 1] - box[:, 0])
        far |= (x < box[:, 0] - pad) | (x > box[:, 1] + pad)
    return far


def _spans(t, mask):
    """``[(t0, t1), ...]`` of the runs of True in ``mask`` (N,)."""
    out, k, N = [], 0, len(mask)
    while k < N:
        if mask[k]:
            s = k
            while k < N and mask[k]:
                k += 1
            out.append((t[s], t[min(k, N - 1)]))
        k += 1
    return out


def _draw(t, measured, series, units, beyond=None, xlabel="time (s)"):
    """Per joint: measured, each ``(label, predicted, band or None)``, the residual under it, and the
    stretches in ``beyond`` (N, n) shaded.  Returns the figure."""
    from ..._support.figures import pyplot

    plt = pyplot()
    n = measured.shape[1]
    ncol = 2 if n > 3 else 1
    nrow = -(-n // ncol)
    fig = plt.figure(figsize=(12 if ncol == 2 else 8, 2.8 * nrow + 0.8))
    outer = fig.add_gridspec(nrow, ncol, hspace=0.55, wspace=0.28, top=1 - 0.75 / (2.8 * nrow + 0.8), bottom=0.06)
    handles = {}
    for j in range(n):
        inner = outer[j // ncol, j % ncol].subgridspec(2, 1, height_ratios=(3, 1.2), hspace=0.06)
        ax, axr = fig.add_subplot(inner[0]), fig.add_subplot(inner[1], sharex=None)
        if beyond is not None and beyond[:, j].any():
            for a in (ax, axr):
                for t0, t1 in _spans(t, beyond[:, j]):
                    h = a.axvspan(t0, t1, facecolor=_SHADE, edgecolor="#b8a200", hatch="//", alpha=0.5, lw=0)
            handles.setdefault(f"beyond {series[0][0]}'s fit (extrapolates)", h)
        (h,) = ax.plot(t, measured[:, j], color="0.45", lw=1.1)
        handles.setdefault("measured", h)
        for k, (label, pred, band) in enumerate(series):     # every band first, under every line, edged in
            if band is not None:                                # its model's colour: no model sits on another's
                lo, hi = pred[:, j] - band[:, j], pred[:, j] + band[:, j]
                h = ax.fill_between(t, lo, hi, facecolor=f"C{k}", alpha=0.18 if len(series) > 1 else 0.22,
                                    edgecolor="none", zorder=1)
                if len(series) > 1:
                    for edge in (lo, hi):
                        ax.plot(t, edge, color=f"C{k}", lw=0.5, ls="--", zorder=1.5)
                handles.setdefault(f"{label}: 95 % band", h)
        for k, (label, pred, band) in enumerate(series):
            (h,) = ax.plot(t, pred[:, j], color=f"C{k}", lw=0.9, zorder=3)
            handles.setdefault(f"{label}: predicted", h)
            axr.plot(t, measured[:, j] - pred[:, j], color=f"C{k}", lw=0.7)
        axr.axhline(0.0, color="0.3", lw=0.6)
        ax.set_title(f"joint {j + 1}", fontsize=9, loc="left")
        ax.set_ylabel(units[j], fontsize=8)
        axr.set_ylabel("residual", fontsize=8)
        ax.tick_params(labelbottom=False, labelsize=7)
        axr.tick_params(labelsize=7)
        axr.set_xlabel(xlabel, fontsize=8)
        for a in (ax, axr):
            a.grid(alpha=0.3)
            a.set_xlim(t[0], t[-1])
    fig.legend(list(handles.values()), list(handles), loc="upper center", ncol=min(len(handles), 4), frameon=False,
               fontsize=8)
    return fig


def torque_figure(t, measured, series, units, beyond, what: str, flagged_text: str):
    t = np.asarray(t, dtype=np.float64)
    xlabel = "time (s)"
    if len(t) > 1 and np.any(np.diff(t) < 0):      # several logs stacked, each from its own t = 0
        t, xlabel = np.arange(len(t), dtype=np.float64), "sample (the logs one after the other)"
    try:
        fig = _draw(t, np.asarray(measured), series, units, beyond, xlabel=xlabel)
    except ModelError:
        return _NO_FIG
    n = measured.shape[1]
    alt = (f"{what}: measured and predicted torque of each of the {n} joints against time, with the 95 % "
           f"prediction band where there is one and the residual (measured minus predicted) under each; "
           f"{flagged_text}")
    shaded = (" Hatched yellow stretches: the samples flagged beyond the fit before their torque is seen (their "
              "q or qd beyond the fitted interval by over 10 % of its width, their leverage beyond the held-out "
              "data's, or at rest where the fit never rested)." if beyond is not None and beyond.any() else
              f" Nothing is shaded: {flagged_text}.")
    banded = [s[0] for s in series if len(s) > 2 and s[2] is not None]
    whose = ("" if not banded else " and its 95 % band" if len(series) == 1 else
             "; shaded between dashed lines of its colour, the 95 % band of " + ", ".join(banded)
             + " only (drawn under every line)")
    return H.figure(fig, alt=alt, caption=f"{what}. Grey: measured; coloured: predicted" + whose
                                          + "; the small panel under each: measured minus predicted." + shaded)


def _units(n, units):
    return list(units) if units else ["N m"] * n


# ---------------------------------------------------------------------------------------- validate


def _joint_rows(r, d: dict, units):
    """Rows of one model's per-joint table, and the flagged rows (extrapolates or band misses);
    each flag's reason is in the row's last cell (by range, by leverage, the band's coverage)."""
    n = len(r.rms)
    ex = d.get("extrapolation") or [None] * n
    cov = d.get("band_95_coverage")
    missed = set(d.get("band_95_missed") or [])
    mean_hw = d.get("band_95_mean_half_width") or (None if r.band is None
                                                   else [float(x) for x in np.mean(r.band, axis=0)])
    rows, flagged = [], set()
    for j in range(n):
        e = ex[j] if j < len(ex) else None
        row = [f"joint {j + 1}", d["rms"][j], d["relative_rms"][j], d["r2"][j], d["mean_error"][j],
               None if d.get("accel_rms") is None else d["accel_rms"][j], None if mean_hw is None else mean_hw[j], None if cov is None else cov[j],
               None if e is None else e["outside_fraction"], None if e is None else e["far_outside_fraction"],
               None if e is None else e.get("beyond_fit_fraction")]
        flags, why = [], []
        if e is not None and e.get("extrapolates"):
            flags.append("EXTRAPOLATES")
            why += _extrapolation_reasons(e)
        if (j + 1) in missed:
            flags.append("BAND MISSES")
            why.append(f"band misses: the 95 % band holds {percent_under(cov[j], MISS_COVERAGE)} % of the "
                       f"samples (under {100 * MISS_COVERAGE:g} %)" if cov is not None
                       else f"band misses: the band holds under {100 * MISS_COVERAGE:g} % of the samples")
        row.append(", ".join(flags) or "-")
        row.append("; ".join(why) or "-")
        if flags:
            flagged.add(j)
        rows.append(row)
    return rows, flagged


def _extrapolation_reasons(e: dict) -> list[str]:
    """Why a joint EXTRAPOLATES, from its ``to_list`` object: by its own range, by leverage, or both."""
    why = []
    if e.get("range_extrapolates"):
        why.append(f"by range: {100 * e['far_outside_fraction']:.1f} % of the samples beyond the fitted q, qd "
                   f"or tau by over {100 * FLAG_MARGIN:g} % of its width (over {100 * FLAG_FRACTION:g} % flags)")
    if e.get("leverage_extrapolates"):
        lev = e.get("leverage_ratio") or {}
        why.append(f"by leverage: {100 * (e.get('beyond_fit_fraction') or 0.0):.1f} % of the samples beyond every "
                   "fitted sample by the leverage of the joint's regressor row (the other joints' states its "
                   "torque depends on)" + (f", up to {lev['max']:.3g} times the fit's mean" if "max" in lev else "")
                   + f" (over {100 * FLAG_FRACTION:g} % flags)")
    if not why:                                     # a flag whose kind this page does not know yet
        why.append("extrapolates (see the text report)")
    return why


_JOINT_HEADERS = ["joint", "RMS error", "RMS / measured RMS", "R^2", "mean error",
                  "acceleration error RMS (D^-1 of the torque error)", "band half-width (mean)",
                  "band coverage", "outside fitted range", "far outside", "beyond the fit by leverage", "flags",
                  "why flagged"]


def _joints_table(r, name: str, units, caption: str):
    """One model's per-joint table; the columns it has nothing for (no band, no fitted range) left out."""
    rows, flagged = _joint_rows(r, r.to_dict(), units)
    keep = [k for k in range(len(_JOINT_HEADERS)) if k < 5 or any(row[k] not in (None, "-") for row in rows)]
    return H.table([_JOINT_HEADERS[k] for k in keep], [[row[k] for k in keep] for row in rows], name=name,
                   flagged=flagged, caption=caption), flagged


def _verdict_validate(v) -> tuple[str, str]:
    rs = v.results
    if len(rs) == 1:
        r = rs[0]
        text = (f"{r.model} predicts the {len(r.t)} measured samples with a relative RMS error of "
                + ", ".join(f"{x:.2g}" for x in r.relative_rms) + " (joints 1 to "
                f"{len(r.rms)}; 0 is perfect, 1 as good as predicting zero torque)")
    else:
        from .comparison import best_per_joint, model_labels as _labels

        best = best_per_joint(rs)
        labels = _labels(rs)
        wins = {labels[k]: [j + 1 for j in range(len(best)) if best[j] == k] for k in range(len(rs))}
        lead = max(wins, key=lambda k: len(wins[k]))
        text = (f"Of {len(rs)} models on {len(rs[0].t)} samples, {lead} has the smallest RMS error on "
                f"{len(wins[lead])} of {len(best)} joints ({', '.join(map(str, wins[lead]))})")
    level = "ok"
    for r in rs:
        if r.coverage is not None:
            text += f"; {r.model}'s 95 % band holds {100 * r.pooled_coverage:.1f} % of the samples"
            if r.pooled_coverage < 0.9:
                level = "warn"
        ex = r.extrapolation
        if ex is not None and np.any(ex.flagged):
            text += (f"; {r.model} extrapolates on joint(s) "
                     + ", ".join(str(j + 1) for j in np.flatnonzero(ex.flagged)))
            level = "warn"
    for line in (getattr(v, "fit_data", None) or []) + (getattr(v, "model_notes", None) or []):
        text += "; " + line
        level = "warn"
    return text + ".", level


def _accel_side_by_side(rs, labels, units) -> list:
    """The section of the forward dynamics' error per joint and model, the best in bold ([] without any)."""
    from .forward_error import acceleration_units, best_accel_per_joint

    best = best_accel_per_joint(rs)
    if best is None:
        return []
    au = acceleration_units(units)
    rows = [[f"joint {j + 1}", *(r.accel_rms[j] for r in rs), au[j], labels[best[j]]] for j in range(len(best))]
    return [H.section("Forward dynamics side by side", H.table(
        ["joint", *(f"{lab}: acceleration error RMS" for lab in labels), "unit", "best"], rows, name="accel_side_by_side",
        best={(j, 1 + int(best[j])) for j in range(len(best))},
        caption="RMS of D^-1 (tau - tau_hat) per joint and model, on each model's own mass matrix D at the "
                "measured q: what the forward dynamics a simulator runs miss by; the best per joint in bold"))]


def validation_page(v, command: str | None = None, options: dict | None = None, model_files=()) -> str:
    """The page of a :class:`.scoring.Validation` (module docstring)."""
    rs = v.results
    n = len(rs[0].rms)
    units = _units(n, v.units)
    done = [("command", command or "(library call) manipdyn.validate(...)")]
    for spec in model_files:
        sha = H.sha256_of(spec) if isinstance(spec, (str, os.PathLike)) else None
        done.append(("model", f"{os.fspath(spec) if isinstance(spec, (str, os.PathLike)) else spec}"
                              + (f", sha256 {sha}" if sha else "")))
    done = done + _logs(v.data) + [
        ("samples", f"{len(rs[0].t)} (the logs stacked)"),
        ("options", ", ".join(f"{k}={val}" for k, val in sorted((options or {}).items()) if val not in (None, False))
         or "defaults"),
        ("manipdyn", H.version())]
    text, level = _verdict_validate(v)
    parts = [H.section("What was done", H.facts(done)), H.section("Verdict", H.verdict(text, level))]
    unit_note = (f"Torques in {', '.join(sorted(set(units)))}; accelerations in "
                 f"{', '.join(sorted(set('m/s^2' if u == 'N' else 'rad/s^2' for u in units)))}; fractions from 0 to 1.")
    joint_parts, any_flag = [], set()
    for k, r in enumerate(rs):
        name = "joints" if len(rs) == 1 else f"joints_{k + 1}"
        tab, flagged = _joints_table(r, name, units, f"{r.model}: per joint, on the validation data")
        any_flag |= flagged
        joint_parts.append(tab)
        if r.band_method:
            joint_parts.append(H.paragraph(f"{r.model}'s band: {r.band_method}."))
        if r.notes:
            joint_parts.append(H.bullets([f"{r.model}: {x}" for x in r.notes]))
    if len(rs) > 1:
        from .comparison import best_per_joint, model_labels as _labels

        best = best_per_joint(rs)
        labels = _labels(rs)
        rows = [[f"joint {j + 1}", *(r.rms[j] for r in rs), labels[best[j]]] for j in range(n)]
        parts.append(H.section("Models side by side", H.table(
            ["joint", *(f"{lab}: RMS error" for lab in labels), "best"], rows, name="side_by_side",
            best={(j, 1 + int(best[j])) for j in range(n)},
            caption="RMS error per joint and model on the same samples; the best per joint in bold")))
        parts += _accel_side_by_side(rs, labels, units)
    parts.append(H.section("Per joint", *joint_parts, unit_note,
                           "Highlighted rows: the joint extrapolates (more than 5 % of its samples beyond the "
                           "fitted states by over 10 % of their width, or beyond every fitted sample by the "
                           "leverage of its regressor row) or its band holds under 80 % of the samples; the "
                           "last column says which, with its figure." if any_flag else "No joint is flagged."))
    per_run = v.per_run()
    if len(per_run) > 1:
        labels = [r.model for r in rs]
        rows = [[row["log"], row["samples"], lab, *row["rms"][lab]] for row in per_run for lab in labels]
        parts.append(H.section("Per log", H.table(["log", "samples", "model", *(f"joint {j + 1}" for j in range(n))],
                                                  rows, name="runs", caption="RMS error per joint on each log")))
    beyond = beyond_mask(rs[0], v.data)
    series = [(r.model, r.predicted, r.band) for r in rs]
    flagged_text = ("the shaded stretches are beyond the states the fit saw" if beyond is not None and beyond.any()
                    else "no stretch is beyond the states the fit saw" if beyond is not None
                    else "the model carries no fitted range")
    parts.append(H.section("Measured and predicted", torque_figure(rs[0].t, rs[0].measured, series, units, beyond,
                                                             "Validation data", flagged_text)))
    parts.append(H.section("Data notes", H.bullets(v.notes) if v.notes else "The logs were used as read: nothing "
                           "was resampled, filtered or trimmed."))
    title = "Validation: " + ", ".join(r.model for r in rs)
    return H.page(title, f"{len(rs)} model{'s' * (len(rs) > 1)} scored on {len(rs[0].t)} samples of "
                         f"{len(per_run)} log{'s' * (len(per_run) != 1)}", parts)


# ---------------------------------------------------------------------------------------- identify


def band_words(band: dict) -> str:
    """How a prediction band (its trust-record dict) was held out, in a few words: the trajectories,
    the posture regions, or the blocks it came from."""
    if band.get("method") == "held-out trajectories":
        return f"{band.get('trajectories')} held-out trajectories, each predicted by a fit on the others"
    if band.get("regions"):
        return f"{band.get('regions')} held-out posture regions and {band.get('folds')} blocks, within one trajectory"
    return f"blocked, {band.get('folds')} folds, within one trajectory"


def _collision(prov: dict):
    """The collision thresholds the model carries (its trust record's ``collision``), or why none."""
    thr = prov.get("collision")
    if not isinstance(thr, dict) or not thr.get("threshold"):
        return H.section("Collision thresholds", "None in this model's trust record (--no-thresholds, no model file "
                         "written, or none could be had: the command's output says which).")
    facts = [("observer gain", f"{thr.get('gain')} 1/s"),
             ("false alarms", f"{thr.get('false_alarms_per_hour')} per hour, all joints together"),
             ("residual low-pass", f"{thr.get('velocity_cutoff')} Hz" if thr.get("velocity_cutoff") else "none"),
             ("from", str(thr.get("source", "")))]
    rows = [[f"joint {j + 1}", x] for j, x in enumerate(thr["threshold"])]
    return H.section("Collision thresholds", H.facts(facts), H.table(
        ["joint", "threshold (N m or N)"], rows, name="collision_thresholds",
        caption="What manipdyn observe watches the momentum observer's residual against, stored in the model file"))


def _verdict_identify(rep: dict, unit: str = "N m") -> tuple[str, str]:
    band = (rep.get("provenance") or {}).get("prediction_band")
    text = (f"The {rep['method']} fit of {rep['n_base']} base parameters to {rep['samples']} samples is "
            + ("a physical arm (every J_i >= 0)" if rep.get("consistent") else "NOT a physical arm")
            + "; its RMS residual per joint is " + ", ".join(H.number(x, 3) for x in rep["rms_residual"])
            + f" {unit}")
    if band:
        text += ("; held out (" + band_words(band) + "): "
                 + ", ".join(H.number(x, 3) for x in band.get("held_out_rms", [])) + f" {unit}")
    active = rep.get("active_bounds") or []
    if active:
        text += f"; {len(active)} plausibility bound{'s' * (len(active) > 1)} active"
    level = "bad" if not rep.get("consistent") else ("warn" if active or rep.get("fit_notes") else "ok")
    return text + ".", level


def _parameters(rep: dict):
    boot = rep.get("bootstrap") or {}
    bstd = boot.get("std") or []
    has_boot = bool(bstd)
    headers = ["#", "base parameter", "value", "std (fit)", "rel. std (%)"] + (["std (bootstrap)"] if has_boot else [])
    rows = []
    for k, row in enumerate(rep.get("base_parameters") or []):
        cells = [k + 1, row.get("expression", ""), row.get("value"), row.get("std"), row.get("rel_std_percent")]
        if has_boot:
            cells.append(bstd[k] if k < len(bstd) else None)
        rows.append(cells)
    src = rep.get("std_source")
    return H.table(headers, rows, name="base_parameters", row_headers=False,
                   caption="Base parameters (the identifiable combinations), with their standard deviations"
                           + (f" ({src})" if src else ""))


def _links(rep: dict):
    rows = []
    for b in rep.get("links") or []:
        c = b["com"] or [None] * 3
        mom = b["principal_moments"] or [None] * 3
        rows.append([f"{b['link']} ({b['name']})", b["mass"], b["prior_mass"], *c, *mom])
    return H.table(["link", "mass (kg)", "prior mass (kg)", "COM x (m)", "COM y (m)", "COM z (m)",
                    "I1 (kg m^2)", "I2 (kg m^2)", "I3 (kg m^2)"], rows, name="links",
                   caption="The identified bodies: mass beside the prior's, centre of mass in the link's URDF "
                           "frame, principal moments about the centre of mass (ascending)")


def _decided(rep: dict):
    """The base parameters with what decided each: the data, or the prior where the logs do not excite them."""
    d = rep["decided"]
    rows = [[x["what"], x["value"], x["prior"], x["share"], x["by"]] for x in d.get("base", [])]
    flagged = {k for k, x in enumerate(d.get("base", [])) if x["by"] != "data"}
    return H.table(["base parameter", "identified", "prior", "data share", "decided by"], rows, name="decided",
                   flagged=flagged,
                   caption=f"What the data decided (prior weight {d.get('weight', 0):.3g}): the data's share of each "
                           "base parameter's posterior curvature; highlighted rows the logs do not excite, so the "
                           "prior decides them")


def _joints_identify(rep: dict):
    band = (rep.get("provenance") or {}).get("prediction_band") or {}
    held, hw = band.get("held_out_rms"), band.get("half_width")
    rows = []
    for j, r in enumerate(rep["rms_residual"]):
        sig = rep.get("noise_sigma") or []
        rows.append([f"joint {j + 1}", r, held[j] if held and j < len(held) else None,
                     sig[j] if j < len(sig) else None, hw[j] if hw and j < len(hw) else None])
    flagged = {j for j, row in enumerate(rows)
               if row[1] is not None and row[2] is not None and row[1] > 0 and row[2] > 2 * row[1]}
    tab = H.table(["joint", "RMS residual (in-sample)", "RMS held out", "noise sigma", "95 % band half-width"], rows,
                  name="joints", flagged=flagged,
                  caption="Per joint: the fit's residual on its own data, and on blocks of it held out from refits")
    return tab, flagged


def identify_page(result, command: str | None = None) -> str:
    """The page of an :class:`.result.IdentifyResult` (module docstring)."""
    rep = result.report()
    prov = rep.get("provenance") or {}
    n = len(rep["rms_residual"])
    units = ["N" if t == "prismatic" else "N m" for t in getattr(result.prior, "joint_types", ())] or ["N m"] * n
    done = [("command", command or "(library call) manipdyn.identify(...)"), ("prior", rep.get("model"))]
    done += _logs(result.data)
    done += [("samples", f"{rep['samples']} (the logs stacked)"),
             ("method", f"{rep['method']} ({rep.get('solver')})"),
             ("options", ", ".join(f"{k}={v}" for k, v in (prov.get("options") or {}).items()) or "defaults"),
             ("output", ", ".join(x for x in (rep.get("output"), rep.get("base_model")) if x) or "none"),
             ("date", prov.get("date", "")), ("manipdyn", H.version())]
    text, level = _verdict_identify(rep, "/".join(sorted(set(units))))
    parts = [H.section("What was done", H.facts(done)), H.section("Verdict", H.verdict(text, level))]
    tab, flagged = _joints_identify(rep)
    parts.append(H.section("Per joint", tab, f"Torques in {', '.join(sorted(set(units)))}. "
                           + ("Highlighted rows: the held-out RMS is over twice the in-sample one (the fit "
                              "explains its own data better than data it did not see)." if flagged
                              else "No joint is flagged: held out, each joint's RMS stays within twice the "
                                   "in-sample one.")
                           + " A new log's extrapolation is what validate reports against the states recorded here."))
    data = result.data
    try:
        pred = np.asarray(result.fit.predict(data.q, data.qd, data.qdd))
        hw = (prov.get("prediction_band") or {}).get("half_width")
        band = None if hw is None else np.broadcast_to(np.asarray(hw, dtype=np.float64), pred.shape)
        fig = torque_figure(data.t, data.tau, [(result.name, pred, band)], units, None, "Fit data",
                      "the fit data is inside the fitted states by definition")
    except (ModelError, ValueError) as exc:
        fig = f"No figure: {exc}"
    parts.append(H.section("Measured and predicted (fit data)", fig))
    parts.append(_collision(prov))
    active = rep.get("active_bounds") or []
    parts.append(H.section("Parameters",
                           H.section("Active bounds", H.bullets(active) if active else
                                     "No plausibility bound is active: the data alone placed every parameter.",
                                     level=3),
                           H.section("Notes on the fit", H.bullets(rep["fit_notes"]), level=3)
                           if rep.get("fit_notes") else "",
                           _links(rep) if rep.get("links") else "",
                           _decided(rep) if rep.get("decided") else "",
                           _parameters(rep)))
    extra = []
    tc = rep.get("torque_constants")
    if tc:
        rows = [[f"motor {j + 1}", v, s] for j, (v, s) in enumerate(zip(tc.get("values", []), tc.get("std", [])))]
        extra.append(H.table(["motor", "k_t (N m/A)", "std"], rows, name="torque_constants",
                             caption="Torque constants from the currents (scale: " + {
                                 "gravity": "the prior's gravity torque", "payload": "the known payload",
                                 "model": "the model's k_t"}.get(str(tc.get("scale")), str(tc.get("scale")))
                             + "; the notes on the fit say which and how sure)"))
    if extra:
        parts.append(H.section("Drives", *extra))
    parts.append(H.section("Data notes", H.bullets(rep.get("data_notes") or []) if rep.get("data_notes") else
                           "The logs were used as read: nothing was resampled, filtered or trimmed."))
    return H.page(f"Identification: {result.name}",
                  f"{rep['method']} fit of {rep.get('model')} to {rep['samples']} samples", parts)
