"""``identify --payload`` as one self-contained HTML page (``--report FILE.html``).

Layer 5 (identification), room ``results``.

The payload of a known arm (:func:`manipdyn.identification.identify_payload`) read from the top
down, as the other reports (:mod:`manipdyn.identification.results.html`): what was done (the
command, the model, the link, the log with its sha256, the solver, the version), the verdict in
a sentence (the mass and COM, what the data do not determine), the payload's figures with their
standard deviations, the ten parameters of the fit, the per-joint residual against the noise,
the figure (measured torque against the arm carrying the payload), the notes and the data notes
in words. The tables hold the numbers of ``--json`` of the same command (each cell's exact value
in ``data-value``; an infinite standard deviation, a parameter the data do not excite, is an
empty cell as it is ``null`` in JSON); every text from a log, a file name or a model is escaped.
"""

from __future__ import annotations

import os

import numpy as np

from ..._support import html as H
from ..._support.errors import ModelError
from .html import torque_figure

__all__ = ["payload_page", "write_payload_report"]


def _finite(x):
    """``x`` as a float, or None where it is not finite (JSON's null)."""
    x = float(x)
    return x if np.isfinite(x) else None


def _verdict(d: dict) -> tuple[str, str]:
    com = ", ".join(f"{a} = {1e3 * c:.2f}" for a, c in zip("xyz", d["com"]))
    text = (f"The payload on link {d['link']} weighs {d['mass']:.4g} kg (standard deviation {d['mass_std']:.2g} kg) "
            f"with its centre of mass at {com} mm in the payload frame")
    poor = d["poorly_determined"]
    if poor:
        text += (f"; the data do not determine {', '.join(poor)}: the arm carrying it is a plant for what the "
                 "logged motion excited, not beyond")
        return text + ".", "warn"
    return text + "; every parameter is determined by the data.", "ok"


def payload_page(result, data=None, command: str | None = None, model: str | None = None) -> str:
    """The page of a :class:`manipdyn.identification.PayloadResult` (module docstring).

    ``data``: the :class:`manipdyn.identification.Measurements` it was fitted on (for the log's
    sha256, the figure and the data notes; None leaves them out); ``command``: the command line to show; ``model``: the
    arm's name or file as the user gave it."""
    d = result.as_dict()
    n = len(d["rms_residual"])
    arm = result.arm
    units = ["N" if t == "prismatic" else "N m" for t in getattr(arm, "joint_types", ())] or ["N m"] * n
    done = [("command", command or "(library call) manipdyn.identification.identify_payload(...)"),
            ("model", model or getattr(arm, "name", "") or "arm"),
            ("payload on", f"link {d['link']}, in the payload frame (the tool frame unless a link was named)")]
    if data is not None:
        src = getattr(data, "source", None)
        sha = getattr(data, "source_sha256", None) or (H.sha256_of(src) if isinstance(src, (str, os.PathLike))
                                                        else None)
        name = os.path.basename(os.fspath(src)) if isinstance(src, (str, os.PathLike)) else (src or "arrays")
        done.append(("log", f"{name}: {len(data.t)} samples" + (f", sha256 {sha}" if sha else "")))
    cond = d["condition_number"]
    done += [("solver", f"{d['solver']} (J >= 0), condition number "
                        + ("infinite (a parameter not excited)" if not np.isfinite(cond) else f"{cond:.4g}")),
             ("manipdyn", H.version())]
    text, level = _verdict(d)
    parts = [H.section("What was done", H.facts(done)), H.section("Verdict", H.verdict(text, level))]

    rows = [["mass (kg)", d["mass"], _finite(d["mass_std"])]]
    rows += [[f"COM {a} (m)", c, _finite(s)] for a, c, s in zip("xyz", d["com"], d["com_std"])]
    names = ("xx", "xy", "xz", "yy", "yz", "zz")
    idx = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
    rows += [[f"I{nm} about the COM (kg m^2)", d["inertia"][i][k], None] for nm, (i, k) in zip(names, idx)]
    payload = H.table(["quantity", "value", "std"], rows, name="payload",
                      caption="The payload: mass, centre of mass (payload frame) and inertia about it (payload-"
                              "frame axes); the inertia's spread is in the parameters below")
    poor = set(d["poorly_determined"])
    prow = [[k, v, _finite(d["parameter_std"][k])] for k, v in d["parameters"].items()]
    params = H.table(["parameter", "value (J >= 0 fit)", "std (WLS)"], prow, name="parameters",
                     flagged={i for i, r in enumerate(prow) if r[0] in poor},
                     caption="The ten parameters about the payload frame's origin ([m, m c, I], tensor sign); "
                             "highlighted: not determined by the data (an empty std: not excited at all)")
    parts.append(H.section("Payload", payload, params))

    jrows = [[f"joint {j + 1}", d["rms_residual"][j], d["noise_sigma"][j]] for j in range(n)]
    parts.append(H.section("Per joint", H.table(
        ["joint", f"RMS residual ({'/'.join(sorted(set(units)))})", "noise sigma"], jrows, name="joints",
        caption="Measured torque minus the arm carrying the payload, and each joint's noise level (the weight "
                "of its rows in the fit)")))
    if data is not None:
        try:
            pred = np.asarray(result.predict(data.q, data.qd, data.qdd))
            fig = torque_figure(data.t, data.tau, [(f"{getattr(arm, 'name', 'arm')} + payload", pred, None)],
                                units, None, "Payload fit data", "the fit data is what the payload was fitted on")
        except (ModelError, ValueError) as exc:
            fig = f"No figure: {exc}"
        parts.append(H.section("Measured and predicted (fit data)", fig))
    if d["notes"]:
        parts.append(H.section("Notes on the fit", H.bullets(d["notes"])))
    notes = list(getattr(data, "notes", []) or []) if data is not None else []
    parts.append(H.section("Data notes", H.bullets(notes) if notes else
                           "The log was used as read: nothing was resampled, filtered or trimmed."))
    return H.page(f"Payload: {model or getattr(arm, 'name', '') or 'arm'}",
                  f"payload on link {d['link']} from {n}-joint torques", parts)


def write_payload_report(result, path, data=None, command: str | None = None, model: str | None = None) -> str:
    """Write :func:`payload_page` to ``path`` atomically; returns the path."""
    H.write_page(path, payload_page(result, data=data, command=command, model=model))
    return os.fspath(path)
