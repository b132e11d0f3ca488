"""The ``identify`` page of ``--report FILE.html``: what was done, the verdict, per joint RMS in-sample and held
out, the fit figure with its band, the bodies, what the data decided, the parameters, the drives, the collision
thresholds and the data notes.

Layer 5 (identification), room ``results``; the blocks it shares with the ``validate`` page are :mod:`manipdyn.identification.results.html`'s.
"""

from __future__ import annotations

import numpy as np

from ..._support import html as H
from ..._support.errors import ModelError
from . import html as html_blocks
from .html import band_words

__all__ = ["identify_page"]


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
    rows = [[x["by"], x["share"], x["value"], x["prior"], x["what"]] for x in d.get("base", [])]   # the long
    # expressions last: the verdict and the numbers stay on screen
    flagged = {k for k, x in enumerate(d.get("base", [])) if x["by"] != "data"}
    return H.table(["decided by", "data share", "identified", "prior", "base parameter"], rows, name="decided",
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
    done += html_blocks.log_facts(result.data)
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
        fig = html_blocks.torque_figure(data.t, data.tau, [(result.name, pred, band)], units, None, "Fit data",
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
