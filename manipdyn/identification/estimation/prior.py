"""The prior of an identification: made physical, pulled on its own scales, and what it decided.

Layer 5 (identification).

What a log does not excite, it cannot decide.  A Panda log that hardly accelerates the wrist leaves
joint 7's inertia about its axis (``D_77``) to whatever the fit's constraints allow: the data alone put
it at 8e-4 kg m^2 against the published 4.9e-3, and the forward dynamics, which divide the torque
error by ``D``, then drift nine times faster on that joint.  Torque cannot see the difference; a
simulation can.  This module keeps the prior where the data are silent:

* **A physical prior** (:func:`physical_prior`).  The pull towards the prior's bodies is the
  log-determinant (Bregman) divergence of the pseudo-inertias, ``d(J, J0) = tr(J0^-1 J) - log det(J0^-1 J) - 4``
  (Lee, Wensing and Park, "Geometric robot dynamic identification: a convex programming approach",
  IEEE T-RO 36(2), 2020; :func:`.sdp.consistent_fit`): zero at the prior, invariant to each body's
  frame and units, convex beside ``J >= 0``.  It needs ``J0`` positive definite.  A published model
  whose body is no rigid body (``kuka_lwr4_gaz.urdf``: four links with negative principal moments)
  makes ``tr(J0^-1 J)`` unbounded below along the negative direction, and the pull then drives the
  fit to its bounds (measured: the LWR4 fit at weight 1 had torque RMS 292 N m on joint 1 against
  0.643, masses at their bounds).  So the non-physical bodies are first replaced by the nearest
  physical ones with the same base parameters (:func:`manipdyn.model.completion.complete_parameters`,
  the completion the writers use): the same dynamics, a prior the divergence can measure from; the
  notes name the links.
* **Against the Euclidean pull.**  The former ``--prior-weight`` already pulled by the log-det divergence in
  the fit (step 1 of :mod:`.sdp`), but then chose the bodies among those with the same base parameters by
  their Euclidean distance to the prior (step 2), which lands on the ``J >= 0`` boundary wherever the
  prior's Euclidean projection does (measured on the Panda at weight 0.1: links 3 to 6 degenerate, smallest
  radius of gyration 7e-5 to 2e-4 m).  With a weight, step 2 now holds the radius-of-gyration floor instead,
  on the base parameters step 1 found (the same dynamics), and keeps step 1's bodies where the floor cannot
  be held.
* **Drive terms on their own scales** (:func:`extra_scales`).  Rotor inertia and friction have no
  pseudo-inertia; each is pulled towards the prior's value by ``((x - x0) / s)^2`` with ``s`` the
  torque that term typically makes on that joint's log turned into the term's unit (the joint's
  measured torque RMS over its velocity RMS for a viscous coefficient, over its acceleration RMS for
  a rotor inertia, the torque RMS itself for a Coulomb level or an offset), or the prior's own value
  when larger.  A friction term that the data need moves freely; one the data do not ask for stays
  near the prior's instead of soaking up what a body should explain.  A term the prior does not
  state (its value 0: a vendor URDF without friction, or a law of another kind) is not pulled at
  all: such a prior says nothing about it, and pulling it to 0 cost the Panda's joint 6 19 % of its
  held-out torque at weight 1 (measured; 8.5 % without the pull).  (The LWR4's weight-1 collapse
  of the issue, 32 N m s/rad of viscous friction on joint 6, came from its non-physical prior, not
  from the friction: with the prior made physical, weight 1 holds its torque.)
* **What came from where** (:func:`attribution`).  Per link (its mass, first moments and inertia
  about its joint axis) and per base parameter: the share of the data in the answer, from the
  curvature of the fit's objective at its answer (the Laplace approximation of the posterior): the
  data's ``2 K^T cov^-1 K / rows`` (``cov`` the base parameters' covariance, whose rows have unit noise
  variance) against the prior's ``w / n`` times the divergence's Hessian, ``H_kl = tr(J^-1 E_k J^-1 E_l)``
  at the identified bodies ``J`` (the divergence's curvature does not depend on ``J0``; taken at the prior
  it would overstate the pull on a body the data moved far from it).  For a quantity
  ``a^T pi`` the data's variance is ``a^T F^+ a`` (infinite off the identifiable directions), the
  prior's ``a^T P^-1 a``, and the data's share of the posterior is ``var_p / (var_d + var_p)``, the
  weight of the data in the combination of two Gaussian estimates.  A quantity is **decided by the
  data** where that share is at least one half, **by the floor** where its link sits on the
  radius-of-gyration floor (the plausibility bound decided, not the data nor the prior), and **by the
  prior** otherwise.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError
from ...model.inertia import pseudo_inertia_from_parameters
from ...model.parameters import PARAMETER_BASIS

__all__ = ["physical_prior", "prior_parameters", "extra_scales", "attribution", "describe_attribution", "link_quantities",
           "DATA_SHARE"]

#: the data's share of a quantity's posterior at or above which the data decided it (module docstring)
DATA_SHARE = 0.5
#: a prior body counts as physical when the smallest eigenvalue of its J is above this fraction of its largest
PHYSICAL_RTOL = 1e-9


def _links_to_complete(arm) -> tuple[list[int], list[int]]:
    """``(negative, degenerate)``: 0-based links whose pseudo-inertia J has a negative eigenvalue (no rigid body:
    a negative principal moment or a broken triangle inequality), and those whose J is singular (a point mass, a
    rod or a plate: physical, but the divergence's ``J0^-1`` does not exist).  A massless link (J = 0) is left
    alone: the divergence adds a margin to it."""
    negative, degenerate = [], []
    for i, j in enumerate(arm.chain()[0]):
        J = np.asarray(j.body.J, dtype=np.float64)
        if not np.any(J):
            continue
        w = np.linalg.eigvalsh(J)
        tol = PHYSICAL_RTOL * max(float(w[-1]), 1e-300)
        if w[0] < -tol:
            negative.append(i)
        elif w[0] <= tol:
            degenerate.append(i)
    return negative, degenerate


def physical_prior(arm, label: str = "the prior"):
    """``(arm', notes)``: ``arm`` with every body that is no rigid body (its pseudo-inertia J has a negative
    eigenvalue) or a degenerate one (J singular: a point mass, a rod, a plate) replaced by the nearest physical
    one with the same base parameters (:func:`manipdyn.model.completion.complete_parameters`); ``arm`` itself
    and no note when every body is physical and solid.  The notes say which links changed and whether the
    dynamics were kept exactly.

    Raises :class:`~manipdyn._support.errors.MissingExtraError` without cvxpy (the ``identify`` extra).
    """
    negative, degenerate = _links_to_complete(arm)
    if not negative and not degenerate:
        return arm, []
    from ...model.completion import complete_parameters
    from .model import arm_with_parameters

    c = complete_parameters(arm, links=sorted(negative + degenerate), plausible=True)
    full = np.asarray(c.parameters, dtype=np.float64)[:10 * arm.n]
    if not c.exact:
        # no physical arm has these base parameters: the completion's nearest arm may move every link (a
        # link made massless, measured on a UR5 with two broken bodies); a prior should move only where it
        # is wrong, so each such body is projected alone onto the nearest positive definite J instead
        full = _projected(arm, sorted(negative + degenerate))
        d = _torque_change(arm, full)
        what = (f"no physical arm has these base parameters, so each such body alone is replaced by the nearest "
                f"positive definite J (the prior's torques move by up to {d:.3g} N m on its seeded states)")

    def names(v):
        return ("link " if len(v) == 1 else "links ") + ", ".join(str(i + 1) for i in v)

    what = "with the same base parameters, so the same dynamics" if c.exact else c.summary()
    said = []
    if negative:
        said.append(f"{names(negative)} no rigid body (J has a negative eigenvalue)")
    if degenerate:
        said.append(f"{names(degenerate)} degenerate (J singular: a point mass, a rod or a plate)")
    note = (f"{label}: " + "; ".join(said) + f"; the pull towards the prior starts from the nearest solid bodies "
            f"({what}): the log-det divergence needs J0 positive definite")
    import warnings

    from ..._support.errors import PhysicalConsistencyWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        out = arm_with_parameters(arm, full, armature=False, friction=False, name=arm.name)
    return out, [note]


def _projected(arm, links) -> np.ndarray:
    """The arm's link parameters (10 n,) with each body of ``links`` replaced by the nearest positive definite J
    (Frobenius norm): its eigenvalues raised to a margin of 1e-6 of its largest."""
    from ...model.inertia import parameters_from_pseudo_inertia

    J = np.array([np.asarray(j.body.J, dtype=np.float64) for j in arm.chain()[0]])
    for i in links:
        w, V = np.linalg.eigh(J[i])
        J[i] = (V * np.maximum(w, 1e-6 * max(float(w[-1]), 1e-300))) @ V.T
    return parameters_from_pseudo_inertia(J).reshape(-1)


def _torque_change(arm, full) -> float:
    """The largest change of the arm's torques (N m or N) on its seeded states when its link parameters become
    ``full``."""
    from ...model.parameters import arm_parameters, stacked_regressor

    W = stacked_regressor(arm)
    return float(np.max(np.abs(W[:, :10 * arm.n] @ (full - arm_parameters(arm, False, False)))))


def prior_parameters(arm, armature, friction, count: int) -> np.ndarray:
    """The prior's full parameters (``count`` of them) with ``armature`` and ``friction`` entries, as the fit
    starts from them: zeros for a friction law of another kind than the prior's, (count,)."""
    from ...model.parameters import arm_parameters, parameter_count

    try:
        return arm_parameters(arm, armature, friction)
    except ModelError:   # the prior's friction law is not of the asked-for kind: start from none
        return np.concatenate([arm_parameters(arm, armature, False),
                               np.zeros(count - parameter_count(arm.n, armature, False))])


def extra_scales(names, n: int, qd, qdd, tau, prior_extra=None) -> np.ndarray:
    """The scale ``s`` of each entry beyond the ``10 n`` link parameters (module docstring), ``(p - 10 n,)``.

    Parameters
    ----------
    names : sequence of str
        The parameter names (``BaseParameters.names``), whose entries after ``10 n`` are
        ``joint<k>.<term>`` or ``motor<k>.<term>`` (``armature``, ``fv`` viscous, ``fc`` Coulomb, ``offset``, ...).
    qd, qdd, tau : (N, n)
        The fit data (rad/s, rad/s^2, N m).
    prior_extra : (p - 10 n,), optional
        The prior's values of those entries; a scale is never below the prior value's magnitude, and an entry
        whose prior value is 0 (the prior states no such term) gets ``inf``: not pulled.
    """
    names = list(names)[10 * n:]
    qd, qdd, tau = (np.asarray(x, dtype=np.float64) for x in (qd, qdd, tau))
    t_rms = np.sqrt(np.mean(tau ** 2, axis=0))
    v_rms = np.sqrt(np.mean(qd ** 2, axis=0))
    a_rms = np.sqrt(np.mean(qdd ** 2, axis=0))
    tiny = 1e-12 * max(float(t_rms.max()), 1e-300)
    out = np.empty(len(names))
    for k, name in enumerate(names):
        j = _joint_of(name, k, n)
        term = name.rsplit(".", 1)[-1]
        t = max(float(t_rms[j]), tiny)
        if term.startswith("armature"):
            s = t / max(float(a_rms[j]), 1e-6)
        elif term in ("fv", "viscous"):
            s = t / max(float(v_rms[j]), 1e-6)
        else:                      # a torque level: Coulomb, offset, Stribeck, sigmoid amplitudes
            s = t
        out[k] = s
    if prior_extra is not None:        # a term the prior does not state (0: it has no such term) is not pulled
        pe = np.abs(np.asarray(prior_extra, dtype=np.float64))
        out = np.where(pe > 0, np.maximum(out, pe), np.inf)
    return out


def _joint_of(name: str, k: int, n: int) -> int:
    """The 0-based joint (or motor) of an extra parameter's name ``joint<k>.<term>``."""
    digits = ""
    for ch in reversed(name.split(".", 1)[0]):
        if ch.isdigit():
            digits = ch + digits
        elif digits:
            break
    if digits and 1 <= int(digits) <= n:
        return int(digits) - 1
    return k % n


def link_quantities(arm) -> tuple[list[str], np.ndarray]:
    """``(labels, A)``: per link its mass, first moments and inertia about its joint axis as rows of ``A``
    (``(5 n, 10 n)``: ``A @ pi`` gives them in kg, kg m, kg m^2, URDF link frames)."""
    joints = arm.chain()[0]
    n = len(joints)
    labels, rows = [], []
    for i, j in enumerate(joints):
        a = np.asarray(j.axis, dtype=np.float64)
        a = a / max(float(np.linalg.norm(a)), 1e-300)
        base = 10 * i
        for k, what in ((0, "mass"), (1, "first moment x"), (2, "first moment y"), (3, "first moment z")):
            r = np.zeros(10 * n)
            r[base + k] = 1.0
            rows.append(r)
            labels.append(f"link {i + 1} {what}")
        r = np.zeros(10 * n)
        if j.joint == "revolute":      # a^T I a about the frame origin, on the joint's axis
            ax, ay, az = a
            r[base + 4], r[base + 6], r[base + 9] = ax * ax, ay * ay, az * az
            r[base + 5], r[base + 7], r[base + 8] = 2 * ax * ay, 2 * ax * az, 2 * ay * az
            labels.append(f"link {i + 1} inertia about joint {i + 1}'s axis")
        else:
            r[base] = 1.0
            labels.append(f"link {i + 1} mass (along joint {i + 1}'s axis)")
        rows.append(r)
    return labels, np.array(rows)


def _divergence_hessian(pi, n: int) -> np.ndarray:
    """``(10 n, 10 n)`` block diagonal: each link's ``H_kl = tr(J^-1 E_k J^-1 E_l)`` at the parameters ``pi``
    (the divergence's Hessian in J is ``J^-1 (x) J^-1`` wherever it is taken: its linear term in ``J0`` has none)."""
    J0 = pseudo_inertia_from_parameters(np.asarray(pi, dtype=np.float64)[:10 * n].reshape(n, 10))
    E = PARAMETER_BASIS
    H = np.zeros((10 * n, 10 * n))
    for i in range(n):
        J = J0[i] + 1e-8 * max(1.0, float(np.abs(J0[i]).max())) * np.eye(4)
        Ji = np.linalg.inv(J)
        G = np.einsum("ab,kbc->kac", Ji, E)             # J0^-1 E_k
        H[10 * i:10 * i + 10, 10 * i:10 * i + 10] = np.einsum("kab,lba->kl", G, G)
    return H


def attribution(result, prior_pi, weight: float, rows: int, floored_links=()) -> dict:
    """What the data decided and what the prior did (module docstring), as a dict:

    ``quantities``: ``[{"what", "value", "prior", "share", "by"}]`` per link quantity
    (:func:`link_quantities`), ``base``: the same per base parameter (``what`` its name), and ``links``:
    per link ``"data"``, ``"prior"`` or ``"floor"`` (the least-decided of its quantities: a link whose
    inertia about its axis the data did not decide is not "decided by the data").

    ``result`` is a :class:`.fitting.FitResult` of a weighted fit (its ``covariance`` of the base
    parameters); ``floored_links`` the 0-based links on the gyration floor.
    """
    base, cov = result.base, result.covariance
    if cov is None:
        raise ModelError("attribution: needs a weighted fit (its base parameters' covariance)")
    n = result.n
    K = np.asarray(base.K, dtype=np.float64)
    p = K.shape[1]
    pi = np.asarray(result.parameters, dtype=np.float64)
    prior_pi = np.asarray(prior_pi, dtype=np.float64)
    info = np.linalg.pinv(np.asarray(cov, dtype=np.float64), hermitian=True)
    F = 2.0 * K.T @ info @ K / max(int(rows), 1)                # (p, p), the data's curvature
    P = np.zeros((p, p))
    if weight and weight > 0:
        P[:10 * n, :10 * n] = (float(weight) / n) * _divergence_hessian(pi, n)   # at the answer: the posterior's
    Fp = np.linalg.pinv(F, hermitian=True)
    Pp = np.linalg.pinv(P, hermitian=True) if weight and weight > 0 else None
    # a direction outside the identifiable row space of F: the data cannot see it
    U, s, _ = np.linalg.svd(F, hermitian=True)
    keep = s > 1e-10 * max(float(s[0]) if s.size else 0.0, 1e-300)
    Ur = U[:, keep]

    def share(a):
        a = np.asarray(a, dtype=np.float64)
        na = float(np.linalg.norm(a))
        if na == 0:
            return 0.0
        off = float(np.linalg.norm(a - Ur @ (Ur.T @ a))) / na
        if off > 1e-6:
            return 0.0                       # unidentifiable: the data say nothing of it
        vd = float(a @ Fp @ a)
        if Pp is None:
            return 1.0
        vp = float(a @ Pp @ a)
        if not vp > 0:
            return 1.0
        return vp / (vd + vp) if vd + vp > 0 else 1.0

    labels, A = link_quantities(result.prior)
    floored = set(int(i) for i in floored_links)
    quantities = []
    for lab, a in zip(labels, A):
        a_full = np.zeros(p)
        a_full[:10 * n] = a
        sh = share(a_full)
        i = int(lab.split()[1]) - 1
        by = "data" if sh >= DATA_SHARE else ("floor" if i in floored and "inertia" in lab else "prior")
        quantities.append({"what": lab, "value": float(a_full @ pi), "prior": float(a_full @ prior_pi),
                           "share": sh, "by": by})
    base_rows = []
    for k, name in enumerate(base.expressions(digits=3)):
        sh = share(K[k])
        base_rows.append({"what": name, "value": float(K[k] @ pi), "prior": float(K[k] @ prior_pi), "share": sh,
                          "by": "data" if sh >= DATA_SHARE else "prior"})
    links = []
    for i in range(n):            # a link is the data's when every base parameter it enters is
        involved = [base_rows[k]["by"] for k in range(K.shape[0]) if np.any(np.abs(K[k, 10 * i:10 * i + 10]) > 1e-9)]
        links.append("floor" if i in floored else "data" if involved and all(b == "data" for b in involved)
                     else "prior")
    return {"quantities": quantities, "base": base_rows, "links": links, "weight": float(weight)}


def describe_attribution(attr: dict, max_items: int = 10) -> list[str]:
    """Notes: which links the data decided, which the prior or the floor, and the base parameters the prior
    decided (the logs do not excite them), with their values and the prior's."""
    out = []
    b = attr["base"]
    nd = sum(1 for x in b if x["by"] == "data")
    groups = {k: [i + 1 for i, by in enumerate(attr["links"]) if by == k] for k in ("data", "prior", "floor")}

    def links(v):
        return ("link " if len(v) == 1 else "links ") + ", ".join(map(str, v))

    parts = [f"{links(groups['data'])}: by the data" if groups["data"] else "",
             f"{links(groups['prior'])}: partly by the prior" if groups["prior"] else "",
             f"{links(groups['floor'])}: shape at the radius-of-gyration floor (what neither the data nor the "
             "prior decide of the body; its dynamics are the base parameters')"
             if groups["floor"] else ""]
    out.append(f"decided by the data or the prior (prior weight {attr['weight']:.3g}): {nd} of {len(b)} base "
               "parameters by the data; " + "; ".join(x for x in parts if x))
    prior_b = sorted((x for x in b if x["by"] == "prior"), key=lambda x: x["share"])
    if prior_b:
        more = len(prior_b) - max_items
        out.append("the logs do not excite these base parameters, so the prior decides them (each body's shape is "
                   "kept as the prior's, moved only with what the data decide of its mass and centre of mass; data "
                   "share in brackets): " + "; ".join(
                       f"{x['what']} = {x['value']:.4g} (prior {x['prior']:.4g}) [{x['share']:.2f}]"
                       for x in prior_b[:max_items]) + (f"; and {more} more (the trust record lists them)"
                                                       if more > 0 else ""))
    return out
