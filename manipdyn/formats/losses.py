"""What a target format cannot hold of an arm: one account shared by the URDF and the MJCF writers.

Layer 2 (formats).  :func:`format_losses` returns one line per thing of the model that the
file does not carry as it is (dropped, approximated, or a placeholder), with how large the
difference is where it is a number.  Both writers put the lines into the file's opening
comment, and ``manipdyn urdf`` / ``manipdyn mjcf`` print them, so nothing is lost in silence.

What each format holds of the friction law (:class:`manipdyn.Friction`, the joints' torque
``tau_f(qd)``):

::

    =================  ========================================  ====================================
    term               URDF ``<dynamics damping friction>``       MJCF
    =================  ========================================  ====================================
    viscous            ``damping`` (the links' own, joint side)   ``damping``, motor side reflected
                                                                  (``R_kk^2 Fv``), coupled rows as
                                                                  ``<tendon><fixed damping>``
    coulomb            ``friction`` (the links' own, joint side)  ``frictionloss`` (a soft constraint
                                                                  in MuJoCo, not a sign function)
    asymmetric         dropped                                    ``frictionloss`` = mean level
    sigmoid (Gaz)      dropped                                    ``frictionloss`` = ``A / 2``, the mean
                                                                  of its saturation levels
    offset, stribeck   dropped                                    dropped
    smooth, deadband   dropped (the sign is sharp)                dropped (the constraint's softness
                                                                  plays their part)
    =================  ========================================  ====================================

The size of a dropped term is the largest ``|tau_f(qd) - held(qd)|`` over each joint's
velocities ``|qd_j| <= v_j`` (one joint moving at a time): ``v_j`` is the joint's velocity
limit where the model gives one, else :data:`VELOCITY_RANGE` (the cross-check's range).
Model files do not record the states a model was fitted on, so this grid stands in for them.
"""

from __future__ import annotations

import numpy as np

from .._support.errors import ModelError
from ..model.friction import Friction

__all__ = ["written_bodies", "completion_lines", "format_losses", "friction_held", "urdf_friction_words", "friction_difference", "nonphysical_inertias",
           "VELOCITY_RANGE", "URDF_GRAVITY", "TARGETS"]

#: the formats :func:`format_losses` knows
TARGETS = ("urdf", "mjcf")
#: joint speeds (rad/s for revolute, m/s for prismatic joints) over which a dropped friction
#: term is measured when the model gives no velocity limit: the cross-check's ranges
VELOCITY_RANGE = {"revolute": 2.0, "prismatic": 0.5}
#: the gravity URDF readers assume (URDF has no gravity element), m/s^2
URDF_GRAVITY = (0.0, 0.0, -9.81)
#: grid points per joint on which a friction difference is measured
_GRID = 801
#: a principal moment below this (kg m^2) counts as zero: MuJoCo's compiler refuses such a body
#: (its mjMINVAL is 1e-15)
_MINVAL = 1e-15


def _grid(arm) -> np.ndarray:
    """States (n * _GRID, n): each joint alone swept over +-v_j (limit or :data:`VELOCITY_RANGE`)."""
    joints, _tool = arm.chain()
    n = len(joints)
    rows = []
    for k, j in enumerate(joints):
        v = j.velocity if j.velocity is not None else VELOCITY_RANGE[j.joint]
        block = np.zeros((_GRID, n))
        block[:, k] = np.linspace(-v, v, _GRID)
        rows.append(block)
    return np.concatenate(rows)


def friction_held(arm, target: str):
    """``(held, words)``: the part of ``arm.friction_model`` the target format holds, as a
    :class:`Friction` (joint side or motor side as the law; None when nothing is held), and one
    phrase per term saying what became of it."""
    law = arm.friction_model
    if law is None:
        return None, []
    words = []
    z = np.zeros(law.n)
    viscous = law.viscous
    coulomb = law.coulomb
    if target == "urdf":          # what the URDF writer puts into <dynamics>: the links' friction
        joints, _tool = arm.chain()
        fv = np.array([j.friction_viscous for j in joints], dtype=np.float64)
        fc = np.array([j.friction_coulomb for j in joints], dtype=np.float64)
        if not (np.any(fv) or np.any(fc)):
            return None, [f"{', '.join(law.terms)} on the {law.side} side: dropped (URDF's <dynamics> "
                          "holds only the links' joint-side viscous and Coulomb friction)"]
        held = Friction(viscous=fv, coulomb=fc, smoothing=0.0)
        if held == law:
            return law, ["viscous and Coulomb friction as <dynamics damping friction>"]
        return held, [urdf_friction_words(law, fv, fc)]
    # MJCF: damping (reflected or on a tendon) and frictionloss hold viscous and a symmetric level
    if law.asymmetric:
        coulomb = 0.5 * (law.coulomb_pos + law.coulomb_neg)
    if law.sigmoid_A is not None:    # Gaz's sigmoid saturates at A (1 - l0) and -A l0: their mean is A / 2
        half = np.where(law.sigmoid_A > 0, 0.5 * law.sigmoid_A, 0.0)
        coulomb = half if coulomb is None else coulomb + half
    held = Friction(viscous=viscous if viscous is not None else z, coulomb=coulomb if coulomb is not None else z,
                    smoothing=law.smoothing, deadband=law.deadband, side=law.side)
    side = "" if law.side == "joint" else " (motor side: reflected through R, tendons for coupled rows)"
    for t in law.terms:
        words.append({
            "viscous": f"viscous as joint damping{side}",
            "coulomb": f"Coulomb as frictionloss{side}, a soft constraint in MuJoCo, not a sign function "
                       f"(the law's smoothing {law.smoothing:g} and deadband {law.deadband:g} are not held)",
            "asymmetric": "asymmetric Coulomb as frictionloss at the mean of its two levels",
            "sigmoid": "Gaz's sigmoid as frictionloss A/2, the mean of its two saturation levels A (1 - l0) and "
                       "A l0 (l0 = logistic(alpha p3)); its offset and smooth slope are not held",
        }.get(t, f"{t} dropped (MJCF has no such term)"))
    return held, words


def urdf_friction_words(law, fv, fc) -> str:
    """What a URDF's ``<dynamics damping friction>`` (the links' ``fv``, ``fc``, (n,) each) holds of the
    :class:`Friction` ``law``, and what it drops: only the terms and shapes it does not hold are named."""
    def same(a, b):
        return np.allclose(np.zeros(len(b)) if a is None else np.asarray(a, dtype=np.float64), b, rtol=1e-12, atol=0)

    joint = law.side == "joint"
    kept = [name for name, a, b in (("viscous", law.viscous, fv), ("Coulomb", law.coulomb, fc))
            if joint and b.any() and same(a, b)]
    dropped = [t for t in law.terms if not (t == "viscous" and "viscous" in kept)
               and not (t == "coulomb" and "Coulomb" in kept)]
    if not joint:
        dropped = [f"the {law.side}-side law ({', '.join(law.terms)})"]
    shapes = [f"the Coulomb smoothing {law.smoothing:g}" for _ in [0] if law.smoothing and "Coulomb" in kept]
    shapes += [f"the deadband {law.deadband:g}" for _ in [0] if law.deadband and "Coulomb" in kept]
    out = ("the links' " + " and ".join(kept) + " friction held as <dynamics damping friction>" if kept else
           "the links' joint-side friction as <dynamics damping friction>, which is not the model's law")
    if dropped:
        out += "; dropped: " + ", ".join(dropped)
    if shapes:
        out += "; not held: " + ", ".join(shapes) + " (URDF's friction is a sharp sign)"
    return out


def friction_difference(arm, held) -> np.ndarray:
    """Largest ``|law - held|`` per joint (n,), N m (N), over :func:`_grid`'s velocities."""
    law = arm.friction_model
    qd = _grid(arm)
    full = law.torque(qd, arm.transmission)
    kept = np.zeros_like(full) if held is None else held.torque(qd, arm.transmission)
    return np.abs(full - kept).max(axis=0)


def nonphysical_inertias(arm) -> list:
    """``(joint index, link name, why)`` of each body MuJoCo's compiler refuses: a principal
    moment not positive, or a triangle inequality broken (``A + B >= C``)."""
    joints, _tool = arm.chain()
    out = []
    for k, j in enumerate(joints):
        b = j.body
        I = np.asarray(b.inertia, dtype=np.float64)
        if b.mass == 0 and not np.any(I):
            continue        # an empty link: written without an inertial
        w = np.linalg.eigvalsh(0.5 * (I + I.T))
        name = j.link_name or j.name
        if b.mass <= 0:
            out.append((k, name, f"mass {float(b.mass)!r} with rotational inertia"))
        elif w[0] < _MINVAL:
            out.append((k, name, f"principal moments {[float(x) for x in w]} are not all positive"))
        elif w[0] + w[1] < w[2] * (1 - 1e-12):
            out.append((k, name, f"principal moments {[float(x) for x in w]} break A + B >= C"))
    return out


_COMPLETIONS: list = []        # the last few (arm, bodies, completion): the writer and the losses share one


def written_bodies(arm, as_published: bool = False, exact_only: bool = False):
    """``(bodies, completion)``: the chain bodies the MJCF and URDF of ``arm`` hold (URDF link frames) and the
    :class:`manipdyn.model.completion.Completion` that made them (None with ``as_published``, or when
    MuJoCo accepts every body as it is).  ``exact_only`` (the URDF, read by every tool, not only by
    simulators): where no physical arm has the model's base parameters, the model's own bodies, with
    the completion that was not used (its ``exact`` False says so)."""
    from ..model.completion import complete_bodies, is_massless, mujoco_refusal

    joints, _tool = arm.chain()
    if (as_published or not any(mujoco_refusal(j.body) is not None for j in joints)
            or (exact_only and is_massless(arm))):        # no dynamics: the URDF holds the massless arm as it is
        return [j.body for j in joints], None
    for a, bodies, c in _COMPLETIONS:
        if a is arm:
            return ([j.body for j in joints], c) if exact_only and not c.exact else (bodies, c)
    from .._support.errors import MissingExtraError

    try:
        bodies, c = complete_bodies(arm)
    except MissingExtraError as exc:
        raise MissingExtraError(f"{arm.name or 'the arm'}: {exc}; or write the bodies as published "
                                "(--as-published, as_published=True), which MuJoCo's compiler refuses") from None
    _COMPLETIONS.insert(0, (arm, bodies, c))
    del _COMPLETIONS[4:]
    return ([j.body for j in joints], c) if exact_only and not c.exact else (bodies, c)


def completion_lines(completion, used: bool = True) -> list:
    """The lines a completion adds to the file's comment and the command's output (``used`` False: a
    nearest arm the file does not hold, :func:`written_bodies` with ``exact_only``)."""
    if completion is None:
        return []
    if not used:
        return ["bodies MuJoCo refuses are written as the model has them (MuJoCo's compiler refuses this file): "
                + completion.summary() + "; manipdyn mjcf writes that nearest arm"]
    head = ("bodies MuJoCo refuses were completed: physical bodies with the model's base parameters, so M, h, g "
            f"and tau are the model's (largest torque difference on the model's states "
            f"{completion.torque_difference:.2g} N m)" if completion.exact else
            "bodies MuJoCo refuses were replaced by the nearest physical arm: " + completion.summary())
    return [head] + [x for x in completion.notes if not x.startswith("no physical arm")]


def _drive_lines(arm, target) -> list:
    lines = []
    Jm = np.asarray(arm.motor_inertia, dtype=np.float64)
    if np.any(Jm):
        if target == "urdf":
            lines.append("rotor inertia (armature, kg m^2 per joint, R_kk^2 Jm_k) is not expressible in URDF: "
                         + " ".join(repr(float(a)) for a in arm.armature)
                         + ("; the coupled rotor inertia R^T diag(Jm) R is not held either"
                            if not arm.transmission.is_diagonal else ""))
    if not arm.transmission.is_diagonal:
        if target == "urdf":
            lines.append(f"the coupled transmission (R entries {arm.transmission.coupling}, 1-based [motor, joint, "
                         "value]) is not expressible in URDF")
    return lines


def format_losses(arm, target: str, published_bodies: bool = True) -> list:
    """One line per thing of ``arm`` the ``target`` format (``"urdf"`` or ``"mjcf"``) does not hold
    as it is, with the size of the difference where it is a number (module docstring).
    ``published_bodies`` False: the file holds completed bodies (:func:`written_bodies`), so the
    bodies MuJoCo refuses are not among its losses (the completion's own lines say what became of them)."""
    if target not in TARGETS:
        raise ModelError(f"target: expected one of {', '.join(TARGETS)}, got {target!r:.40}")
    lines = []
    g = np.asarray(arm.gravity, dtype=np.float64)
    if target == "urdf" and not np.array_equal(g, URDF_GRAVITY):
        rel = float(np.linalg.norm(g - URDF_GRAVITY) / max(np.linalg.norm(g), 1e-300))
        lines.append(f"gravity {[float(x) for x in g]} m/s^2 is not expressible in URDF: readers assume their own "
                     f"(commonly {list(URDF_GRAVITY)}), which changes every gravity torque by {rel:.3g} relative")
    lines += _drive_lines(arm, target)
    law = arm.friction_model
    if law is not None:
        held, words = friction_held(arm, target)
        if held is not law:
            diff = friction_difference(arm, held)
            joints, _tool = arm.chain()
            size = ", ".join(f"{j.name} {float(d):.3g}" for j, d in zip(joints, diff))
            what = ("Largest difference from the model's law" if target == "urdf" or held.coulomb is None
                    or not np.any(held.coulomb) else "Largest difference of the held law's formula from the "
                    "model's law (not MuJoCo's forward dynamics, where frictionloss is a soft constraint: not "
                    "measured here; manipdyn mjcf measures them)")
            lines.append(f"friction law ({', '.join(law.terms)}; {law.side} side): {'; '.join(words)}. {what} "
                         f"over |qd| up to each joint's velocity limit (else "
                         f"{VELOCITY_RANGE['revolute']:g} rad/s, {VELOCITY_RANGE['prismatic']:g} m/s), N m or N: {size}")
        elif law.coulomb is not None and np.any(law.coulomb) and target == "mjcf":
            lines.append("Coulomb friction is held as frictionloss, a soft constraint in MuJoCo, "
                         "not a sign function: near qd = 0 MuJoCo's friction torque differs from the law's")
    for k, name, why in nonphysical_inertias(arm) if published_bodies else ():
        lines.append(f"link {name!r} (joint {k + 1}) is no physical body ({why}): MuJoCo's compiler refuses it "
                     "('inertia must have positive eigenvalues' or 'must satisfy A + B >= C'); the file holds "
                     "the model's values as they are")
    return lines
