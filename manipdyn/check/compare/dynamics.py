"""The dynamics half of :func:`manipdyn.check.compare.compare`.

Layer 4 (checks: compare) (compare).

At ``q`` (arm b) the matched state of arm a is ``q' = sign*q + offset``,
``qd' = sign*qd``.  D and h are coordinate-free given the joint variables,
so they do not depend on the base transform: ``D_b`` is compared with
``S D_a S`` and ``h_b`` with ``S h_a`` (``S = diag(sign)``).  Gravity does
depend on it: each model states gravity in its own base frame, and a base
rotated by ``base`` sees b's gravity as ``R_base^T g_b``.  To compare the
same physical situation, arm a's gravity torque is computed with b's gravity
expressed in a's base; if that differs from the gravity arm a declares, a
note says so (the two files then disagree about which way is up).  D, h, g
are of the rigid bodies; the rotor inertias ``G^2 Jm`` are compared joint by
joint on their own (a URDF cannot state them), friction is left out.

Which link is responsible: once aligned, every link of a is a body in b's
link frame, ``J_a' = X_k J_a X_k^T`` (:func:`manipdyn.model.inertia.transform_pseudo_inertia`,
``X_k`` from a's link frame k to b's).  D, h and g are linear in the
pseudo-inertias, so with b's kinematics their difference is exactly the sum
over links of the terms of ``J_b - J_a'``; the link whose term is largest
(in the worst quantity) is the one reported, with both sets of parameters.
"""

from __future__ import annotations

import math

import numpy as np

from ...model.inertia import tensor_from_pseudo_inertia, transform_pseudo_inertia
from ...model.kinematics import transform_inverse
from .report import QuantityDiff

__all__ = ["rigid_engine", "quantity_diff", "dynamics_mismatch", "compare_dynamics", "gravity_in_a",
           "gravity_note", "rotor_diff", "link_table"]


def rigid_engine(arm, gravity, J=None):
    """A trace-form engine of ``arm``'s rigid bodies (no rotors, no friction).

    ``gravity`` (3,) m/s^2 in the arm's base; ``J`` (n, 4, 4) replaces the
    arm's pseudo-inertias (link frames) when given.
    """
    from ...engines.lagrange.engine import TraceFormEngine

    data = arm.trace_form_data()
    kin, J_arm = data.kinematics, data.J
    return TraceFormEngine(kin, J_arm if J is None else J, gravity)


def quantity_diff(name: str, xb, xa) -> QuantityDiff:
    """Largest absolute and relative difference of a batch (N, ...) of one quantity."""
    N = xb.shape[0]
    diff = np.abs(xb - xa).reshape(N, -1).max(axis=1)
    scale = np.maximum(np.abs(xb).reshape(N, -1).max(axis=1), np.abs(xa).reshape(N, -1).max(axis=1))
    rel = np.where(scale > 1e-12, diff / np.where(scale > 1e-12, scale, 1.0), 0.0)
    i = int(np.argmax(rel))
    return QuantityDiff(name, float(diff.max()), float(rel[i]), i)


def gravity_in_a(alignment, b) -> np.ndarray:
    """B's gravity in A's base frame under ``alignment`` (3,), m/s^2."""
    return alignment.base[:3, :3].T @ np.asarray(b.gravity, dtype=np.float64)


def dynamics_mismatch(a, b, alignment, q: np.ndarray) -> float:
    """Relative D and g mismatch of one alignment on a few states q (N, n) (tie-breaking)."""
    S = np.asarray(alignment.signs, dtype=np.float64)
    qa = S * q + alignment.offsets
    eb, ea = rigid_engine(b, b.gravity), rigid_engine(a, gravity_in_a(alignment, b))
    Da = S[:, None] * ea.mass_matrix(qa) * S[None, :]
    ga = S * ea.gravity_torque(qa)
    return float(quantity_diff("D", eb.mass_matrix(q), Da).max_rel
                 + quantity_diff("g", eb.gravity_torque(q), ga).max_rel)


def compare_dynamics(a, b, alignment, q: np.ndarray, qd: np.ndarray) -> dict:
    """D, h, g of b against a's at the matched states: ``{"D"|"h"|"g": QuantityDiff}``.

    ``q``, ``qd`` (N, n) are b's states (rad, rad/s; m, m/s).
    """
    S = np.asarray(alignment.signs, dtype=np.float64)
    eb = rigid_engine(b, b.gravity)
    ea = rigid_engine(a, gravity_in_a(alignment, b))
    Db, hb, gb = eb.dynamics_terms(q, qd)
    Da, ha, ga = ea.dynamics_terms(S * q + alignment.offsets, S * qd)
    return {"D": quantity_diff("D", Db, S[:, None] * Da * S[None, :]),
            "h": quantity_diff("h", hb, S * ha),
            "g": quantity_diff("g", gb, S * ga)}


def _fmt_vec(v) -> str:
    return "(" + ", ".join(f"{float(x):.6g}" for x in v) + ")"


def gravity_note(a, b, alignment) -> str | None:
    """A note when a's declared gravity is not b's gravity seen in a's base; else None."""
    g_decl = np.asarray(a.gravity, dtype=np.float64)
    g_used = gravity_in_a(alignment, b)
    na, nb = float(np.linalg.norm(g_decl)), float(np.linalg.norm(g_used))
    tilt = math.atan2(float(np.linalg.norm(np.cross(g_decl, g_used))), float(g_decl @ g_used)) \
        if na > 0 and nb > 0 else 0.0
    if abs(na - nb) > 1e-9 * max(na, nb) or tilt > 1e-4 or (na == 0) != (nb == 0):
        return (f"gravity: a declares {_fmt_vec(g_decl)} m/s^2 in its base; b's gravity "
                f"{_fmt_vec(b.gravity)} is {_fmt_vec(g_used)} in a's base ({math.degrees(tilt):.3g} deg "
                f"apart, magnitudes {na:.6g} and {nb:.6g}); g above uses b's")
    return None


def rotor_diff(a, b) -> QuantityDiff | None:
    """Rotor inertias ``G^2 Jm`` joint by joint (worst_index = joint, 0-based); None if both are zero."""
    ra = np.asarray(a.armature, dtype=np.float64)
    rb = np.asarray(b.armature, dtype=np.float64)
    if not (np.any(ra) or np.any(rb)):
        return None
    d = np.abs(rb - ra)
    scale = float(max(np.abs(ra).max(), np.abs(rb).max()))
    i = int(np.argmax(d))
    return QuantityDiff("rotor", float(d[i]), float(d[i] / scale), i)


def _bodies_in_b(a, b, alignment):
    """a's and b's pseudo-inertias (n, 4, 4), both in b's link frames, and the link poses."""
    Ja = a.trace_form_data().J
    Jb = b.trace_form_data().J
    Pa = alignment.base @ a.link_poses(alignment.offsets)   # a's link frames at b's q = 0, in b's base
    Pb = b.link_poses(np.zeros(b.n))
    X = np.array([transform_inverse(Pb[k]) @ Pa[k] for k in range(b.n)])
    return transform_pseudo_inertia(Ja, X), np.asarray(Jb)


def _link_terms(b, dJ, quantity: str, q, qd) -> np.ndarray:
    """Norm over states and entries of each link's term of ``quantity`` for the differences dJ."""
    out = np.zeros(b.n)
    for k in range(b.n):
        Jk = np.zeros_like(dJ)
        Jk[k] = dJ[k]
        D, h, g = rigid_engine(b, b.gravity, Jk).dynamics_terms(q, qd)
        out[k] = float(np.linalg.norm({"D": D, "h": h, "g": g}[quantity]))
    return out


def _tensor6(I) -> list:
    return [float(I[0, 0]), float(I[1, 1]), float(I[2, 2]), float(I[0, 1]), float(I[0, 2]), float(I[1, 2])]


def link_table(a, b, alignment, worst: str | None, q, qd):
    """Per link masses and COM offsets, and the link most responsible for ``worst``.

    Returns ``(masses, responsible)``: ``masses`` a list of dicts (link,
    name_a, name_b, mass_a, mass_b, diff kg, com_offset m: distance between
    the two centres of mass once aligned); ``responsible`` None when ``worst``
    is None or the rotor inertia, else a dict with the link, its share of the
    per-link terms, and both parameter sets (mass kg, com m, inertia about
    the COM kg m^2 as ixx, iyy, izz, ixy, ixz, iyz) in b's link frame.
    """
    ja, _ = a.chain()
    jb, _ = b.chain()
    Ja_b, Jb = _bodies_in_b(a, b, alignment)
    masses, params = [], []
    for k in range(b.n):
        ma, ca, Ia = tensor_from_pseudo_inertia(Ja_b[k], name=f"a: link {k + 1}")
        mb, cb, Ib = tensor_from_pseudo_inertia(Jb[k], name=f"b: link {k + 1}")
        off = float(np.linalg.norm(ca - cb)) if ma > 0 and mb > 0 else None
        entry = {"link": k + 1, "name_a": ja[k].link_name or f"link{k + 1}",
                 "name_b": jb[k].link_name or f"link{k + 1}",
                 "mass_a": ma, "mass_b": mb, "diff": mb - ma, "com_offset": off}
        masses.append(entry)
        params.append({"mass_a": ma, "mass_b": mb, "com_a": ca.tolist(), "com_b": cb.tolist(),
                       "inertia_a": _tensor6(Ia), "inertia_b": _tensor6(Ib)})
    if worst not in ("D", "h", "g"):
        return masses, None
    terms = _link_terms(b, Jb - Ja_b, worst, q, qd)
    if not np.any(terms):
        return masses, None
    k = int(np.argmax(terms))
    responsible = {"quantity": worst, "link": k + 1, "name_a": masses[k]["name_a"],
                   "name_b": masses[k]["name_b"], "share": float(terms[k] / terms.sum()), **params[k]}
    return masses, responsible
