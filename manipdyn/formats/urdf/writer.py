"""Arm to URDF, built through yourdfpy's objects (not string templates).

Layer 2 (formats: urdf) writers (below the engines: the Pinocchio engine reads this URDF).

Structure: a ``base_link``; one link and one joint per arm joint; a fixed
``tool`` (flange) link at the end frame, named after a URDF arm's tip when the tip is
not a chain link (``panda_hand``: the file loads with the tip it was read with,
:func:`tool_link`), which the opening comment then names.  Joint positions in the URDF are the
arm's joint variables q: fixed DH offsets live in the joint origins.

Defaults written where the arm gives none (URDF requires them on
revolute/prismatic joints): ``effort = 1000`` (N m or N) and
``velocity = 10`` (rad/s or m/s).  They are placeholders for tools that
insist on them; manipdyn's dynamics never read them.  A comment before each
joint says where its limits came from: the model's values, or these
documented defaults (and :data:`manipdyn.model.registry.DEFAULT_QLIM` for a DH link
without ``qlim``).

Rotor inertia (armature) has no element in URDF; it is kept in the model
file and given to Pinocchio as ``model.armature``.  Viscous and Coulomb
friction of the links go into ``<dynamics damping=... friction=...>``.  What URDF cannot hold (gravity, rotor inertia, friction
terms, non-physical inertias MuJoCo refuses) is said in the opening comment, from the
account shared with the MJCF writer (:func:`manipdyn.formats.losses.format_losses`).
"""

from __future__ import annotations

import numpy as np

from ..losses import completion_lines, format_losses, written_bodies
from ..trust import trust_comment

__all__ = ["arm_to_urdf", "limit_provenance", "urdf_losses", "xml_comment", "round_off_text", "DEFAULT_EFFORT",
           "DEFAULT_VELOCITY", "TOOL_LINK", "tool_link"]

#: name of the fixed flange link at the end frame T_n
TOOL_LINK = "tool"

DEFAULT_EFFORT = 1000.0
DEFAULT_VELOCITY = 10.0


def _f(x) -> float:
    """A plain Python float (so the XML never reads ``np.float64(...)``)."""
    return float(x)


#: entries of an origin's xyz or an inertia tensor smaller than this times the largest
#: entry of the same vector or tensor are round-off of a rotation (cos(pi/2) * d is
#: 6e-17 d) and are written 0; an rpy angle under this many rad is written 0.  The
#: change is 1e4 times below the readers' agreement tolerance (1e-9 relative)
ROUND_OFF = 1e-13


def round_off_text(values, absolute: bool = False) -> str:
    """Space-separated ``repr`` of ``values`` with round-off (:data:`ROUND_OFF`) and -0.0 written 0.0."""
    v = np.asarray(values, dtype=np.float64)
    scale = 1.0 if absolute else float(np.abs(v).max(initial=0.0))
    v = np.where(np.abs(v) <= ROUND_OFF * scale, 0.0, v) + 0.0
    return " ".join(repr(float(x)) for x in v)


def _clean_numbers(root) -> None:
    """Write round-off as 0 in every ``<origin>`` and ``<inertia>`` of the URDF tree ``root``."""
    for el in root.iter("origin"):
        for attr, absolute in (("xyz", False), ("rpy", True)):
            if el.get(attr) is not None:
                el.set(attr, round_off_text([float(x) for x in el.get(attr).split()], absolute))
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    for el in root.iter("inertia"):
        if all(el.get(k) is not None for k in keys):
            cleaned = round_off_text([float(el.get(k)) for k in keys]).split()
            for k, text in zip(keys, cleaned):
                el.set(k, text)


def xml_comment(text: str) -> str:
    """``text`` as the body of an XML comment: ``--`` broken up, and every character XML 1.0
    cannot hold (control characters, lone surrogates) written as ``\\uXXXX``."""
    out = []
    for ch in text.replace("--", "- -"):
        o = ord(ch)
        bad = (o < 0x20 and ch not in "\t\n\r") or 0x7F <= o <= 0x9F or 0xD800 <= o <= 0xDFFF or o in (0xFFFE, 0xFFFF)
        out.append(f"\\u{o:04X}" if bad else ch)
    text = "".join(out)
    return text + " " if text.endswith("-") else text


def limit_provenance(arm, k: int, joint) -> str:
    """Where joint ``k``'s ``<limit>`` values come from, in one line (written as a comment)."""
    from ...model.arm import DEFAULT_QLIM

    unit = "rad" if joint.joint == "revolute" else "m"
    lo, hi = DEFAULT_QLIM[joint.joint]
    links = getattr(arm, "links", None)            # a DH arm: its links say whether qlim was given
    if links is not None and links[k].qlim is None:
        bounds = f"lower/upper {lo:g}/{hi:g} {unit}: manipdyn's default (DEFAULT_QLIM), the model gives none"
    elif links is not None:
        bounds = "lower/upper: the model's qlim"
    else:
        bounds = (f"lower/upper: as read from the source URDF (manipdyn's default {lo:g}/{hi:g} {unit} "
                  "where it gave none, e.g. continuous joints)")
    if joint.effort is not None and joint.velocity is not None:
        rates = "effort/velocity: the model's"
    else:
        rates = (f"effort {DEFAULT_EFFORT:g}, velocity {DEFAULT_VELOCITY:g}: manipdyn's placeholders "
                 "(URDF requires them; manipdyn's dynamics never read them)")
    return f"{joint.name} limits: {bounds}; {rates}"


def urdf_losses(arm, as_published: bool = True) -> list:
    """What URDF does not hold of ``arm`` (:func:`manipdyn.formats.losses.format_losses`), plus the
    placeholder limits the file carries, plus, unless ``as_published``, the bodies completed
    (:func:`manipdyn.formats.losses.written_bodies`): one line each (the file's opening comment, and
    what ``manipdyn urdf`` prints)."""
    _bodies, completion = written_bodies(arm, as_published, exact_only=True)
    used = completion is not None and completion.exact
    lines = format_losses(arm, "urdf", published_bodies=not used) + completion_lines(completion, used=used)
    joints, _tool = arm.chain()
    placeholders = [j.name for j in joints if j.effort is None or j.velocity is None]
    if placeholders:
        lines.append(f"effort {DEFAULT_EFFORT:g} and velocity {DEFAULT_VELOCITY:g} of {', '.join(placeholders)} are "
                     "PLACEHOLDERS (URDF requires them; the model gives none): not the arm's limits")
    return lines


def _unheld_fit(arm) -> str | None:
    """What of an identified arm's fit a URDF does not hold, in words ("the fitted friction law (...)",
    "rotor inertia"), or None when it holds all: a friction law the links' ``<dynamics>`` carry as
    it is (viscous and sharp Coulomb on the joint side) is held."""
    from ..losses import friction_held

    parts = []
    law = getattr(arm, "friction_model", None)
    if law is not None and friction_held(arm, "urdf")[0] is not law:
        parts.append(f"the fitted friction law ({', '.join(law.terms)}, {law.side} side) as it is")
    if np.any(getattr(arm, "armature", 0)):
        parts.append("rotor inertia")
    return " nor ".join(parts) or None


def tool_link(arm) -> str:
    """Name of the fixed link at the tool frame in :func:`arm_to_urdf`'s text: a URDF arm's
    tip (``arm.tip``) when that is no chain link's name, so the written file loads with the
    tip the arm was read with (``tip="panda_hand"``); else :data:`TOOL_LINK`."""
    tip = getattr(arm, "tip", None)
    joints, _ = arm.chain()
    chain_links = {"base_link"} | {j.link_name or f"{j.name}_link" for j in joints}
    return tip if isinstance(tip, str) and tip and tip not in chain_links else TOOL_LINK


def arm_to_urdf(arm, as_published: bool = True) -> str:
    """URDF text of ``arm`` (any :class:`manipdyn.model.arm.Arm`).

    ``as_published=False`` writes each body MuJoCo's compiler (and its URDF reader) refuses
    completed, with the model's base parameters (:func:`manipdyn.formats.losses.written_bodies`), as
    ``manipdyn urdf`` and :func:`manipdyn.to_urdf` do; the default keeps the model's own bodies (the
    Pinocchio engine reads this text).
    """
    import yourdfpy
    from lxml import etree

    joints, tool = arm.chain()
    bodies, _completion = written_bodies(arm, as_published, exact_only=True)
    tool_name = tool_link(arm)
    links = [yourdfpy.Link(name="base_link")]
    ujoints = []
    parent = "base_link"
    used = {"base_link", tool_name}
    for k, j in enumerate(joints):
        lname = j.link_name or f"{j.name}_link"
        if lname in used:
            lname = f"{lname}_{len(used)}"
        used.add(lname)
        b = bodies[k]
        inertial = None
        if b.mass > 0 or np.any(b.inertia):
            origin = np.eye(4)
            origin[:3, 3] = b.com
            inertial = yourdfpy.Inertial(
                origin=origin, mass=_f(b.mass), inertia=np.array(b.inertia, dtype=np.float64)
            )
        links.append(yourdfpy.Link(name=lname, inertial=inertial))
        lo, hi = (j.qlim if j.qlim is not None else (None, None))
        limit = yourdfpy.Limit(
            effort=_f(j.effort if j.effort is not None else DEFAULT_EFFORT),
            velocity=_f(j.velocity if j.velocity is not None else DEFAULT_VELOCITY),
            lower=None if lo is None else _f(lo),
            upper=None if hi is None else _f(hi),
        )
        dyn = None
        if j.friction_viscous or j.friction_coulomb:
            dyn = yourdfpy.Dynamics(damping=_f(j.friction_viscous), friction=_f(j.friction_coulomb))
        ujoints.append(yourdfpy.Joint(
            name=j.name, type=j.joint, parent=parent, child=lname,
            origin=np.array(j.origin, dtype=np.float64),
            axis=np.array(j.axis, dtype=np.float64), limit=limit, dynamics=dyn,
        ))
        parent = lname
    links.append(yourdfpy.Link(name=tool_name))
    ujoints.append(yourdfpy.Joint(name="tool_joint", type="fixed", parent=parent, child=tool_name,
                                  origin=np.array(tool, dtype=np.float64)))
    index = {j.name: k for k, j in enumerate(joints)}
    robot = yourdfpy.Robot(name=arm.name or "arm", links=links, joints=ujoints)
    urdf = yourdfpy.URDF(robot=robot, build_scene_graph=False, load_meshes=False)
    root = urdf.write_xml().getroot()
    comment = f" {arm.name or 'arm'}: generated by manipdyn"
    if getattr(arm, "source", ""):
        comment += f". Data source: {arm.source}"
    if tool_name != TOOL_LINK:               # a URDF arm's tip, kept by name: load it with tip='<that link>'
        comment += (f".\n     Tool frame (fkine, jacobian(frame='tool')): link '{tool_name}', the tip the arm "
                    f"was read with")
    lost = urdf_losses(arm, as_published)
    if lost:
        comment += ".\n     What URDF does not hold of this model:\n" + "\n".join(f"       - {x}" for x in lost)
    _clean_numbers(root)
    root.insert(0, etree.Comment(xml_comment(comment) + " "))
    trust = getattr(arm, "trust", None)      # what an identified arm carries (formats.trust)
    unheld = _unheld_fit(arm) if trust is not None else None
    if unheld:
        trust = dict(trust, doubts=list(trust.get("doubts", [])) + [
            f"written as URDF, which does not hold {unheld}: the band and the "
            "leverage were calibrated with them, so this URDF's predictions are not the ones the band covers "
            "(keep the model file)"])
    record = trust_comment(trust)
    if record is not None:
        root.insert(1, etree.Comment(record))
    for el in root.findall("joint"):
        k = index.get(el.get("name"))
        if k is not None:
            el.addprevious(etree.Comment(" " + xml_comment(limit_provenance(arm, k, joints[k])) + " "))
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8").decode("utf-8")
