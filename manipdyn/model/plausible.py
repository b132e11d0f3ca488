"""What a body must be for MuJoCo, and what a plausible one is: the checks the completion and the
identification share.

Layer 1 (model).

* :func:`mujoco_refusal`: why MuJoCo's compiler refuses a body (a mass or a principal moment at
  or below ``mjMINVAL``, a triangle inequality broken); measured with MuJoCo 3 and 4 (``A + B = C``
  is accepted, ``C`` 1e-7 above ``A + B`` refused, a moment of 1e-14 accepted, 0 or 1e-16 refused).
* :func:`gyration_floor`: the radius of gyration under which a body is a rod or a plate, from the
  arm's own geometry where the prior body is degenerate: never 0 m.
* :func:`smallest_gyration`: each body's smallest radius of gyration about its centre of mass,
  the one number the fit's active bounds and its doubts give of a model.
* :func:`arm_scale`: the arm's units (mean link mass, size).
* :func:`not_physical_note`: one line when a model is no physical arm (a published model with
  negative principal moments): what ``validate`` and ``identify`` (of it as the prior) say.
* :func:`is_massless` and :func:`without_subnormals`: an arm with no dynamics, and subnormal
  parameters taken as 0, which the completion refuses and cleans before any solver sees them.
"""

from __future__ import annotations

import numpy as np

from .inertia import pseudo_inertia_from_parameters, tensor_from_pseudo_inertia

__all__ = ["not_physical_note", "is_massless", "without_subnormals", "MASSLESS", "mujoco_refusal", "gyration_floor", "gyration_radius", "smallest_gyration", "arm_scale", "MJ_MINVAL", "GYRATION_FLOOR"]

#: MuJoCo's mjMINVAL: a mass or principal moment at or below it is refused by MuJoCo's compiler
MJ_MINVAL = 1e-15
#: the radius-of-gyration floor, as a fraction of the arm's size (:func:`gyration_floor`)
GYRATION_FLOOR = 0.01


def arm_scale(arm) -> tuple[float, float]:
    """``(m_ref, L)``: the mean link mass (kg; 1 for a massless arm) and the arm's size (m: its joint
    offsets and tool summed, at least 1 mm), the units of :func:`manipdyn.model.completion.complete_parameters`."""
    joints, tool = arm.chain()
    masses = np.array([float(j.body.mass) for j in joints])
    total = float(masses.sum())
    m_ref = total / len(joints) if total > 0 and np.isfinite(total) else 1.0
    L = sum(float(np.linalg.norm(j.origin[:3, 3])) for j in joints) + float(np.linalg.norm(tool[:3, 3]))
    return m_ref, max(L, 1e-3)


def gyration_radius(mass, inertia) -> float:
    """Smallest radius of gyration about the COM (m) of a body of ``mass`` kg whose inertia tensor about
    its COM is ``inertia`` (3, 3), kg m^2: the square root of the smallest principal second moment over
    the mass; 0 for a massless or flat body."""
    m = float(mass)
    if not m > 0:
        return 0.0
    I = np.asarray(inertia, dtype=np.float64)
    w = np.linalg.eigvalsh(0.5 * (I + I.T))
    S = 0.5 * float(np.sum(w)) - w          # principal second moments about the COM
    return float(np.sqrt(max(float(S.min()), 0.0) / m))


def gyration_floor(arm, fraction: float = GYRATION_FLOOR) -> np.ndarray:
    """Per link, the floor (m) under the radii of gyration of a plausible body, (n,).

    ``fraction`` of the arm's size (:func:`arm_scale`), or half the prior body's own smallest
    radius when that is less and the prior body is a body at all; when the prior body is
    degenerate (massless, or its own radius under half of ``fraction`` of the size: a rod or a
    plate), the floor comes from the geometry alone, ``fraction`` of the size.  Never 0 m.
    """
    joints, _tool = arm.chain()
    _m, L = arm_scale(arm)
    geometric = float(fraction) * L
    out = []
    for j in joints:
        own = gyration_radius(j.body.mass, j.body.inertia)
        out.append(geometric if own < 0.5 * geometric else min(geometric, 0.5 * own))
    return np.array(out)


def mujoco_refusal(body) -> str | None:
    """Why MuJoCo's compiler refuses ``body`` (a :class:`LinkInertia`) on a moving link, or None."""
    m = float(body.mass)
    I = np.asarray(body.inertia, dtype=np.float64)
    w = np.linalg.eigvalsh(0.5 * (I + I.T))
    if not m > MJ_MINVAL:
        what = "no mass and no inertia" if m == 0 and not np.any(I) else f"mass {m!r} kg"
        return f"{what} (MuJoCo needs a mass above mjMINVAL = 1e-15 on a moving body)"
    if not w[0] > MJ_MINVAL:
        return f"principal moments {[float(x) for x in w]} kg m^2 are not all above mjMINVAL"
    if w[0] + w[1] < w[2] * (1 - 1e-12):      # MuJoCo accepts A + B = C to rounding
        return f"principal moments {[float(x) for x in w]} kg m^2 break the triangle inequality A + B >= C"
    return None


def smallest_gyration(pi, n: int) -> np.ndarray:
    """Per body, its smallest radius of gyration about its centre of mass (m), (n,): the square root of
    the smallest principal second moment over the mass (0 for a massless body); the number the
    doubts (``degenerate_links`` of the identification's doubts) give of the model."""
    J = pseudo_inertia_from_parameters(np.asarray(pi, dtype=np.float64)[:10 * n].reshape(n, 10))
    out = np.zeros(n)
    for i in range(n):
        if float(J[i, 3, 3]) > 0:
            m, _c, I = tensor_from_pseudo_inertia(0.5 * (J[i] + J[i].T))
            out[i] = gyration_radius(m, I)
    return out


def not_physical_note(arm, label: str | None = None, role: str = "the model") -> str | None:
    """One line, or None when every body of ``arm`` is physical: which links (numbered 1 to n along the
    chain) have a negative principal moment, which break the triangle inequality of their principal
    moments only, which have inertia without mass.  ``role`` and ``label`` open it: e.g. "the prior
    kuka_lwr4_gaz.urdf is not a physical arm: links 1, 5, 6, 7 have negative principal moments; ..."."""
    chain = getattr(arm, "chain", None)
    if chain is None:
        return None
    groups = {"have negative principal moments": [], "break the triangle inequality of their principal moments": [],
              "have inertia without mass": []}
    for i, j in enumerate(chain()[0]):
        problems = " ".join(j.body.consistency_problems())
        key = ("have negative principal moments" if "negative principal moment" in problems else
               "break the triangle inequality of their principal moments" if "triangle inequality" in problems else
               "have inertia without mass" if problems else None)
        if key:
            groups[key].append(str(i + 1))
    parts = [("links " if len(v) > 1 else "link ") + ", ".join(v) + " "
             + (k if len(v) > 1 else k.replace("have ", "has ").replace("break ", "breaks ").replace("their", "its"))
             for k, v in groups.items() if v]
    if not parts:
        return None
    name = label or getattr(arm, "name", None) or "arm"
    return (f"{role} {name} is not a physical arm: " + "; ".join(parts) + ": no rigid body has such mass properties "
            "(manipdyn check names them), so what is compared with it, or pulled towards it, is no real arm")


#: why a massless arm is not completed (:func:`manipdyn.model.completion.complete_parameters`)
MASSLESS = ("completion: every link of the arm is massless (mass 0 and no inertia; a subnormal value counts as "
            "0): the arm has no dynamics, and no physical body has all-zero base parameters, so there is "
            "nothing to complete; give the links their masses, or write the bodies as the model has them "
            "(--as-published, as_published=True), which MuJoCo's compiler refuses on a moving body")


def without_subnormals(pi, prior, n: int):
    """``(pi, prior, notes)`` with every subnormal entry (under 2.2e-308 in magnitude, not 0) taken as 0:
    no solver works in units a subnormal needs (a 5e-324 kg link made every scale of the problem NaN),
    and such a body is no body; one note says which entries were."""
    tiny = np.finfo(np.float64).tiny
    sub = (pi != 0) & (np.abs(pi) < tiny)
    if not sub.any():
        return pi, prior, []
    idx = [int(k) for k in np.flatnonzero(sub)]
    where = ", ".join(f"link {k // 10 + 1} entry {k % 10}" if k < 10 * n else f"entry {k}" for k in idx[:6])
    note = (f"{len(idx)} subnormal parameter(s) (|x| < {tiny:.3g}: {where}{', ...' if len(idx) > 6 else ''}) "
            "taken as 0")
    pi = np.where(sub, 0.0, pi)
    prior = np.where((prior != 0) & (np.abs(prior) < tiny), 0.0, prior)
    return pi, prior, [note]


def is_massless(arm) -> bool:
    """Whether every link of ``arm`` has mass 0 and no inertia (subnormal values counting as 0): an arm
    with no dynamics, which :func:`manipdyn.model.completion.complete_parameters` refuses (a URDF holds it as it is)."""
    tiny = np.finfo(np.float64).tiny
    joints, _tool = arm.chain()
    return all(abs(float(j.body.mass)) < tiny and not np.any(np.abs(np.asarray(j.body.inertia)) >= tiny)
               for j in joints)
