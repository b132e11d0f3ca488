"""What a fit should have doubted, said: runs far off, contradicted payloads, degenerate bodies.

Layer 5 (identification), room ``results``.

``identify`` used to exit 0 in three cases a robotics engineer would not trust, without a word:

* **A run far off** (:func:`run_doubts`): with several logs, each run's RMS residual of the final
  fit per joint is compared with that run's own noise level (``noise_sigma_per_run``: each
  joint's own least-squares fit on that run alone, :func:`.fit`) and with the other runs'
  residuals.  A run whose residual on some joint is over :data:`NOISE_FACTOR` times its noise
  and over :data:`RUN_FACTOR` times the median of the other runs' is named: its torques are
  not what the model and the other runs say (a wrong payload, another tool, a different
  setting of the drive).  With one run the noise is that of the run's own fit and the test
  says nothing new, so it is not made.
* **A declared payload the data contradict** (:func:`payload_doubts`): the payload's ten
  parameters are fitted on that run's measured torque (:func:`..payload.fit.identify_payload`)
  with the identified arm taken as known.  A fitted mass off the declared one by more than
  :data:`PAYLOAD_RTOL` of it (and by more than three of its standard deviations, and 0.1 kg)
  is named with both masses.
* **Degenerate inertias** (:func:`degenerate_links`): a consistent fit pushed by data that do
  not decide some directions of the parameters ends at the boundary ``J_i >= 0``: a body with
  a principal second moment of nearly zero, a rod or a plate no real link is (the Panda fitted
  with the README's command had links with a smallest principal moment of 2e-8 kg m^2, a
  5 kg rod).  A link is named when its smallest radius of gyration about the centre of mass
  is under :data:`GYRATION_FRACTION` of the arm's size (the sum of the joint offsets and the
  tool's) or its pseudo-inertia's smallest eigenvalue is under :data:`BOUNDARY_RTOL` of its
  largest.  Such a body predicts the logged motion but is a poor plant for simulation (its
  fastest mode is the smallest moment's) and says nothing of the real link.  The default
  consistent fit keeps every radius of gyration above 1 % of the arm's size
  (:meth:`manipdyn.identification.estimation.bounds.Bounds.plausible`), so its bodies sit on that floor instead, which
  :func:`floor_doubts` says: the data did not decide their shape, the floor did.

The sentences go into the fit's notes (``identify``'s text and ``--json`` ``fit_notes``), into
the trust record's ``doubts`` (so the model file, URDF and base model carry them, and
``validate`` repeats them), and the JSON key ``doubts``.
"""

from __future__ import annotations

import os

import numpy as np

from ...model.plausible import arm_scale, gyration_radius

__all__ = ["degenerate_links", "floor_doubts", "solver_doubts", "run_doubts", "payload_doubts", "NOISE_FACTOR", "RUN_FACTOR", "PAYLOAD_RTOL",
           "GYRATION_FRACTION", "BOUNDARY_RTOL"]

#: a run's residual over this many times its own noise level ...
NOISE_FACTOR = 3.0
#: ... and this many times the other runs' median residual on the same joint is named
RUN_FACTOR = 2.0
#: a fitted payload mass off the declared one by more than this fraction contradicts it
PAYLOAD_RTOL = 0.25
#: a smallest radius of gyration under this fraction of the arm's size is degenerate (half the default fit's
#: floor, ``estimation.bounds.PLAUSIBLE_GYRATION``: a body on the floor is named by the active bounds)
GYRATION_FRACTION = 0.005
#: a pseudo-inertia whose smallest eigenvalue is under this fraction of its largest sits on J >= 0
BOUNDARY_RTOL = 1e-6


def arm_size(arm) -> float:
    """The arm's size, m: the lengths of its joints' offsets and the tool's, summed (at least 1 mm;
    :func:`manipdyn.model.plausible.arm_scale`'s)."""
    return arm_scale(arm)[1]


def degenerate_links(arm) -> list[str]:
    """One sentence per link of ``arm`` whose body is degenerate (module docstring)."""
    out = []
    size = arm_size(arm)
    joints, _ = arm.chain()
    for k, j in enumerate(joints):
        b = j.body
        m = float(b.mass)
        if not m > 0:
            continue
        lam = np.linalg.eigvalsh(0.5 * (b.J + b.J.T))
        I = np.linalg.eigvalsh(0.5 * (b.inertia + b.inertia.T))     # principal moments, for the sentence
        rg = gyration_radius(m, b.inertia)
        boundary = lam[0] < BOUNDARY_RTOL * max(float(lam[-1]), 1e-300)
        if rg < GYRATION_FRACTION * size or boundary:
            name = f"link {k + 1}" + (f" ({j.link_name})" if getattr(j, "link_name", "") else "")
            out.append(f"{name}: degenerate inertia{' at the J >= 0 boundary' if boundary else ''}: smallest "
                       f"principal moment {float(np.min(I)):.3g} kg m^2, smallest radius of gyration {rg:.3g} m "
                       f"for {m:.4g} kg on an arm of {size:.3g} m (a rod or a plate, not a link): the data do not "
                       "decide this body's shape; its prediction on these motions may hold, its use as a plant "
                       "(simulation, control) does not")
    return out


def solver_doubts(report) -> list[str]:
    """One sentence when the solver stopped short of the best physical fit (``report["stopped_short"]``):
    the model is saved, and this doubt travels with it (issue 38 item 7), rather than only being printed."""
    if not report.get("stopped_short"):
        return []
    return [f"the solver ({report.get('solver')}) stopped short of the best physical fit: these parameters are "
            "physical but not the best fit the data allow; refit (other data, --no-bounds, or another method) "
            "before trusting them beyond the band"]


def floor_doubts(active_bounds) -> list[str]:
    """One sentence naming the bodies that sit on the radius-of-gyration floor (``report["active_bounds"]``)."""
    links = [b.split(" radius")[0] for b in active_bounds or [] if "radius of gyration" in b and "at its floor" in b]
    below = [b.split(" radius")[0] for b in active_bounds or [] if "radius of gyration" in b and "below its floor" in b]
    out = [", ".join(links) + ": radius of gyration at the plausibility floor (1 % of the arm's size, or half the "
           "prior's own; from the geometry where the prior's body is degenerate): the data do "
           "not decide these bodies' shapes, the floor does (their smallest principal moments are not measured)"]
    out += [", ".join(below) + ": radius of gyration below the plausibility floor: the floor does not hold on "
            "these bodies (the fit's answer is off it), and the data do not decide their shapes"]
    return [line for line, names in zip(out, (links, below)) if names]


def run_doubts(fit_result, data, report) -> list[str]:
    """One sentence per run far off (module docstring); ``data`` the stacked Measurements with
    ``segments`` and ``sources``, ``report`` the fit's (``noise_sigma_per_run``)."""
    sigmas = report.get("noise_sigma_per_run")
    segments = list(getattr(data, "segments", []) or [])
    if sigmas is None or len(segments) < 2:
        return []
    sigmas = np.asarray(sigmas, dtype=np.float64)
    pred = fit_result.predict(data.q, data.qd, data.qdd)
    edges = np.concatenate([[0], np.cumsum(segments)])
    rms = np.array([np.sqrt(np.mean((data.tau[a:b] - pred[a:b]) ** 2, axis=0)) for a, b in zip(edges[:-1], edges[1:])])
    out = []
    for k, src in enumerate(getattr(data, "sources", [None] * len(segments))):
        others = np.median(np.delete(rms, k, axis=0), axis=0)
        bad = np.flatnonzero((rms[k] > NOISE_FACTOR * sigmas[k]) & (rms[k] > RUN_FACTOR * others))
        if bad.size:
            label = os.path.basename(str(src)) if src is not None else f"run {k + 1}"
            out.append(f"run {label}: its residual is far above its own noise and the other runs' on joint(s) "
                       + ", ".join(f"{j + 1} ({rms[k, j]:.3g} N m against noise {sigmas[k, j]:.3g} and "
                                   f"{others[j]:.3g} on the other runs)" for j in bad)
                       + ": its torques are not what the model and the other runs say (a wrong declared payload, "
                       "another tool, another drive setting?); check it, or fit without it")
    return out


def payload_doubts(arm, runs) -> list[str]:
    """One sentence per run whose declared payload the data contradict (module docstring); ``arm`` the
    identified arm (known), ``runs`` ``[(Measurements with the payload's torque subtracted, Payload or None)]``."""
    from ..payload.fit import identify_payload

    out = []
    for data, payload in runs:
        if payload is None or arm is None:
            continue
        raw = data.tau + payload.torque(arm, data.q, data.qd, data.qdd)
        try:
            res = identify_payload(arm, data.q, data.qd, data.qdd, raw)
        except Exception as exc:       # noqa: BLE001 - a check that cannot run must not stop the fit
            out.append(f"run {os.path.basename(str(data.source))}: the declared payload could not be checked ({exc})")
            continue
        m, s, declared = float(res.mass), float(res.mass_std), float(payload.mass)
        if abs(m - declared) > max(PAYLOAD_RTOL * declared, 3 * s, 0.1):
            out.append(f"run {os.path.basename(str(data.source))}: declared payload {declared:g} kg, but its torques "
                       f"say {m:.3g} +- {s:.2g} kg (a payload fitted on the run with the identified arm known): the "
                       "declaration is contradicted; correct it in RUNS.toml or drop the run")
    return out
