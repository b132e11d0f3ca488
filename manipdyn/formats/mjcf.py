"""Arm to MJCF, MuJoCo's model format: ``md.to_mjcf(arm)``, ``md.write_mjcf(arm, path)``.

Layer 2 (formats), beside the URDF writer (:mod:`manipdyn.formats.urdf.writer`).  Needs no
MuJoCo: the text is built with lxml.  What it writes:

* one ``<body>`` per joint, named for the arm's link, at the joint's origin (``pos``, ``quat``)
  in its parent's frame, so the body frame is the URDF link frame of :meth:`Arm.chain`; its
  ``<inertial>`` is the link's mass, COM and full inertia tensor about the COM, at full
  precision (``repr`` floats);
* a ``hinge`` or ``slide`` joint with the arm's joint name, axis and range (none where the model
  gives no limits), ``armature`` (rotor inertia reflected through the gear, ``R_kk^2 Jm_k``),
  ``damping`` (viscous friction) and ``frictionloss`` (Coulomb friction);
* a coupled transmission (``R`` not diagonal) held exactly: each motor whose row of ``R`` has
  couplings becomes a ``<fixed>`` tendon of length ``sum_j R_kj q_j`` carrying that motor's
  ``armature`` (``Jm_k``), ``damping`` and ``frictionloss`` (motor-side friction), so that
  ``M`` gains ``R_k^T Jm_k R_k``: together ``R^T diag(Jm) R``.  A coupling the tendon cannot
  carry (joint-side friction needs no tendon; nothing else is refused) is named;
* one ``<motor>`` actuator per joint (gear 1: the control is the joint torque, N m or N), with
  ``ctrlrange`` at the model's effort limit where it gives one;
* a ``site`` named ``tool`` at the tool frame, and the model's gravity in ``<option>``;
* an opening comment naming the model, its sha256, its source and the manipdyn version, then
  what MJCF cannot hold (:func:`manipdyn.formats.losses.format_losses`).

A body MuJoCo's compiler refuses (:func:`manipdyn.model.completion.mujoco_refusal`: a mass or a
principal moment at or below mjMINVAL, a triangle inequality broken) is written **completed**
(:func:`manipdyn.model.completion.complete_bodies`): a physical body with the same base parameters,
so the simulated arm's ``M``, ``h``, ``g`` and ``tau`` are the model's (to rounding), and the file's
comment says, per body, what was completed and why.  Where no physical arm has the model's base
parameters, the file holds the nearest one and its comment gives the largest torque difference on
the model's states.  ``as_published=True`` writes the raw values instead, with a
:class:`~manipdyn.PhysicalConsistencyWarning` at export (MuJoCo's compiler then refuses the file).
"""

from __future__ import annotations

import hashlib
import math
import warnings

import numpy as np

from .._support.errors import ModelError, PhysicalConsistencyWarning
from .losses import completion_lines, format_losses, friction_held, nonphysical_inertias, written_bodies
from .urdf.writer import round_off_text, xml_comment

__all__ = ["arm_to_mjcf", "mjcf_losses", "model_sha256", "quaternion", "TOOL_SITE", "ENGINE_OPTIONS"]

#: name of the site at the tool frame
TOOL_SITE = "tool"
#: what the file's ``<option>`` sets besides gravity: MuJoCo's recommended integrator for joint damping
ENGINE_OPTIONS = {"integrator": "implicitfast"}


def _r(x) -> str:
    """``repr`` of a float, -0.0 written 0.0 (full precision: round trip exact)."""
    return repr(float(x) + 0.0)


def _v(values) -> str:
    return " ".join(_r(x) for x in np.asarray(values, dtype=np.float64).reshape(-1))


def quaternion(R) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` of the rotation matrix ``R`` (3, 3) (Shepperd's method,
    the largest of the four candidate divisors, so every entry keeps full precision); ``w >= 0``."""
    R = np.asarray(R, dtype=np.float64)
    t = np.trace(R)
    d = np.array([t, R[0, 0], R[1, 1], R[2, 2]])
    k = int(np.argmax(d))
    if k == 0:
        s = 2.0 * math.sqrt(1.0 + t)
        q = np.array([0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s])
    elif k == 1:
        s = 2.0 * math.sqrt(max(1.0 + R[0, 0] - R[1, 1] - R[2, 2], 0.0))
        q = np.array([(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s])
    elif k == 2:
        s = 2.0 * math.sqrt(max(1.0 + R[1, 1] - R[0, 0] - R[2, 2], 0.0))
        q = np.array([(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s])
    else:
        s = 2.0 * math.sqrt(max(1.0 + R[2, 2] - R[0, 0] - R[1, 1], 0.0))
        q = np.array([(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s])
    q = q / np.linalg.norm(q)
    return -q if q[0] < 0 else q


def _pose(el, T) -> None:
    """Set ``pos`` and ``quat`` of ``el`` from the 4x4 ``T`` (omitted where identity)."""
    T = np.asarray(T, dtype=np.float64)
    if np.any(T[:3, 3]):
        el.set("pos", round_off_text(T[:3, 3]))
    q = quaternion(T[:3, :3])
    if not np.array_equal(q, [1.0, 0.0, 0.0, 0.0]):
        el.set("quat", _v(q))


def model_sha256(arm) -> str:
    """Hex sha256 of the model as manipdyn writes it: its model file (``md.to_toml``) for a DH
    arm, its URDF text for an arm read from a URDF."""
    text = getattr(arm, "urdf_text", None)
    if text is None:
        from .modelfile import model_to_toml

        text = model_to_toml(arm)
    return hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("manipdyn")
    except metadata.PackageNotFoundError:
        return "unknown"


def _drive(arm):
    """``(joint armature (n,), joint damping (n,), joint frictionloss (n,), tendons)``; each tendon
    ``(name, {joint index: coef}, armature, damping, frictionloss)`` for one coupled motor row."""
    n = arm.n
    R = np.asarray(arm.transmission.R, dtype=np.float64)
    Jm = np.asarray(arm.motor_inertia, dtype=np.float64)
    held, _words = friction_held(arm, "mjcf")
    Fv = np.zeros(n) if held is None else np.asarray(held.viscous, dtype=np.float64)
    Fc = np.zeros(n) if held is None else np.asarray(held.coulomb, dtype=np.float64)
    motor_side = held is not None and held.side == "motor"
    armature, damping, loss = np.zeros(n), np.zeros(n), np.zeros(n)
    if not motor_side:
        damping, loss = Fv.copy(), Fc.copy()
    tendons = []
    for k in range(n):
        coupled = np.count_nonzero(R[k]) > 1
        if coupled:
            coefs = {j: float(R[k, j]) for j in range(n) if R[k, j] != 0}
            tendons.append((f"motor{k + 1}", coefs, float(Jm[k]), float(Fv[k]) if motor_side else 0.0,
                            float(Fc[k]) if motor_side else 0.0))
            continue
        armature[k] += arm.armature[k]               # R_kk^2 Jm_k, as the model computes it
        if motor_side:
            damping[k] += R[k, k] * R[k, k] * Fv[k]
            loss[k] += abs(R[k, k]) * Fc[k]
    # the rotor inertia the file holds is R^T diag(Jm) R: checked against the model's own
    held_rotor = np.diag(armature)
    for _name, coefs, a, _d, _f in tendons:
        r = np.zeros(n)
        for j, c in coefs.items():
            r[j] = c
        held_rotor = held_rotor + a * np.outer(r, r)
    rotor = np.asarray(arm.rotor_inertia, dtype=np.float64)
    if not np.allclose(held_rotor, rotor, rtol=1e-13, atol=1e-15 * max(1.0, float(np.abs(rotor).max()))):
        raise ModelError(f"mjcf: the coupled rotor inertia R^T diag(Jm) R = {rotor.tolist()} is not held by "
                         f"joint armature and fixed tendons (coupling {arm.transmission.coupling})")
    return armature, damping, loss, tendons


def mjcf_losses(arm, as_published: bool = False) -> list:
    """What MJCF does not hold of ``arm`` (:func:`manipdyn.formats.losses.format_losses`), plus the
    limits the file leaves out, plus the bodies completed (:func:`manipdyn.formats.losses.written_bodies`): one line each."""
    _bodies, completion = written_bodies(arm, as_published)
    lines = format_losses(arm, "mjcf", published_bodies=completion is None) + completion_lines(completion)
    joints, _tool = arm.chain()
    no_effort = [j.name for j in joints if j.effort is None]
    if no_effort:
        lines.append(f"no effort limit in the model for {', '.join(no_effort)}: their motors are unbounded "
                     "(no ctrlrange)")
    with_velocity = [j.name for j in joints if j.velocity is not None]
    if with_velocity:
        lines.append(f"velocity limits of {', '.join(with_velocity)} are not held: MJCF has no joint velocity limit")
    return lines


def _unique(name: str, used: set) -> str:
    out, k = name, 1
    while out in used:
        k += 1
        out = f"{name}_{k}"
    used.add(out)
    return out


def arm_to_mjcf(arm, warn: bool = True, as_published: bool = False) -> str:
    """MJCF text of ``arm`` (any :class:`manipdyn.model.arm.Arm`); module docstring.

    ``as_published``: write every body as the model has it, even one MuJoCo's compiler refuses
    (default: such bodies are completed, :func:`manipdyn.formats.losses.written_bodies`).  ``warn``: with ``as_published``, a
    :class:`~manipdyn.PhysicalConsistencyWarning` names each link MuJoCo's compiler will refuse.
    Completing a body needs cvxpy (the ``identify`` extra); without it a
    :class:`~manipdyn._support.errors.MissingExtraError` gives the install command (or pass
    ``as_published=True``).
    """
    from lxml import etree

    joints, tool = arm.chain()
    bodies, _completion = written_bodies(arm, as_published)
    name = arm.name or "arm"
    armature, damping, loss, tendons = _drive(arm)
    root = etree.Element("mujoco", model=name)
    etree.SubElement(root, "compiler", angle="radian", autolimits="true")
    etree.SubElement(root, "option", gravity=_v(arm.gravity), **ENGINE_OPTIONS)
    world = etree.SubElement(root, "worldbody")
    parent = world
    used = {"world"}
    for k, j in enumerate(joints):
        body = etree.SubElement(parent, "body", name=_unique(j.link_name or f"{j.name}_link", used))
        _pose(body, j.origin)
        jel = etree.SubElement(body, "joint", name=j.name, type="hinge" if j.joint == "revolute" else "slide",
                               axis=_v(np.asarray(j.axis, dtype=np.float64) / np.linalg.norm(j.axis)))
        if j.qlim is not None and getattr(arm, "links", None) is not None and arm.links[k].qlim is None:
            pass                                   # a DH link without qlim: the joint is unlimited
        elif j.qlim is not None:
            jel.set("range", _v(j.qlim))
        for attr, value in (("armature", armature[k]), ("damping", damping[k]), ("frictionloss", loss[k])):
            if value:
                jel.set(attr, _r(value))
        b = bodies[k]
        I = np.asarray(b.inertia, dtype=np.float64)
        if b.mass > 0 or np.any(I):
            etree.SubElement(body, "inertial", pos=round_off_text(b.com), mass=_r(b.mass),
                             fullinertia=round_off_text([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
        parent = body
    site = etree.SubElement(parent, "site", name=TOOL_SITE)
    _pose(site, tool)
    if tendons:
        tel = etree.SubElement(root, "tendon")
        for tname, coefs, a, d, f in tendons:
            fixed = etree.SubElement(tel, "fixed", name=tname)
            for attr, value in (("armature", a), ("damping", d), ("frictionloss", f)):
                if value:
                    fixed.set(attr, _r(value))
            for jk, c in coefs.items():
                etree.SubElement(fixed, "joint", joint=joints[jk].name, coef=_r(c))
    act = etree.SubElement(root, "actuator")
    for j in joints:
        m = etree.SubElement(act, "motor", name=j.name, joint=j.name, gear="1")
        if j.effort is not None:
            m.set("ctrlrange", _v([-j.effort, j.effort]))
    head = [f"{name}: written by manipdyn {_version()}", f"model sha256 {model_sha256(arm)}"]
    if getattr(arm, "source", ""):
        head.append(f"source: {arm.source}")
    lost = mjcf_losses(arm, as_published)
    head += (["what MJCF does not hold of this model:"] + [f"  - {x}" for x in lost]) if lost else \
        ["MJCF holds all of this model"]
    root.insert(0, etree.Comment(" " + xml_comment("\n     ".join(head)) + " "))
    if warn and (as_published or _completion is None):
        for _k, lname, why in nonphysical_inertias(arm):
            warnings.warn(f"{name}: link {lname!r} is no physical body ({why}): MuJoCo's compiler refuses the "
                          "MJCF (and URDF) of this model; fix the inertia or let MuJoCo change it with "
                          "<compiler balanceinertia=\"true\" boundinertia=...>", PhysicalConsistencyWarning,
                          stacklevel=3)
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8").decode("utf-8")
