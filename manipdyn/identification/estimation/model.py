"""The identified arm: a DH arm or a URDF arm carrying a parameter vector.

Layer 5 (identification).

A DH arm (:class:`manipdyn.Manipulator`) gets new links.  A URDF arm
(:class:`manipdyn.model.arm.URDFArm`) gets a new URDF text, the original with only the
``<inertial>`` of each chain link changed (:func:`urdf_with_parameters`): same
kinematics, joints, names, limits, comments.  A chain body is the chain link
plus every link lumped into it (fixed children, locked subtrees); the identified
change of the body, ``J_new - J_prior`` (URDF link frame), is added to the chain
link's own ``<inertial>`` so the lumped links keep theirs.  When that would make
the chain link's own inertial unphysical (the change takes more than it holds),
the chain link carries the whole identified body and the lumped links' inertials
are removed, with a comment saying so.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...model.arm import Manipulator
from ..._support.errors import ModelError
from ...model.inertia import LinkInertia, pseudo_inertia_from_parameters, transform_pseudo_inertia
from ...model.kinematics import transform_inverse
from ...model.parameters import parameter_count

__all__ = ["arm_with_parameters", "urdf_with_parameters"]


def arm_with_parameters(arm, pi, armature: bool = False, friction: bool = False,
                        name: str | None = None, strict: bool = False, metadata=None, trust=None):
    """A copy of the DH or URDF arm ``arm`` whose links carry the parameters ``pi``.

    A URDF arm comes back as a URDF arm read from :func:`urdf_with_parameters`'s text
    (``.urdf_text``; write that to keep the file's structure).  URDF has no rotor
    inertia and its ``<dynamics>`` holds viscous and Coulomb friction only
    (``friction=True``): the rotor inertias (``armature=True``) and another friction law
    are carried by the returned arm (``motor_inertia``, ``friction_model``), not by its
    text; :func:`manipdyn.save` writes them to a model file with the URDF
    (:mod:`manipdyn.formats.modelfile_urdf`).

    Parameters
    ----------
    arm : manipdyn.Manipulator
        Gives the kinematics, limits, gear ratios and everything not in ``pi``.
    pi : (p,)
        Parameter vector in the layout of this module (URDF link frames).
    armature, friction : bool
        Whether ``pi`` holds armature (set as ``motor_inertia = armature / G^2``
        with the prior's gear ratio G) and friction entries; when False the
        prior's values are kept.
    name : str, optional
        Name of the new arm (default: the prior's).
    strict : bool
        Passed to :class:`Manipulator` (a physically impossible link raises).
    metadata : (source, sources, description), optional
        The new arm's citation (:func:`.provenance.model_metadata`); default: the prior's.
    trust : dict, optional
        The fit's trust record (:func:`.provenance.trust_record`): ``arm.trust``, and in a URDF
        arm's text as its comment (:mod:`manipdyn.formats.trust`).

    Raises :class:`ModelError` if a link's mass is negative (no file can hold
    that), naming the link.  A link whose identified mass is exactly 0 has no
    centre of mass: its first moments are dropped.
    """
    from ...model.arm import URDFArm

    if isinstance(arm, URDFArm):
        return _urdf_arm_with_parameters(arm, pi, armature, friction, name, strict, metadata, trust)
    if not isinstance(arm, Manipulator):
        raise ModelError(f"arm: writing identified parameters needs a DH arm (a Manipulator) or a URDF "
                         f"arm, got {type(arm).__name__} {arm.name!r}")
    n = arm.n
    pi = np.asarray(pi, dtype=np.float64)
    expect = parameter_count(n, armature, friction)
    if pi.shape != (expect,):
        raise ValueError(f"pi: expected shape ({expect},) for {n} joints "
                         f"(armature={armature}, friction={friction}), got {pi.shape}")
    J_urdf = pseudo_inertia_from_parameters(pi[:10 * n].reshape(n, 10))
    S = arm.urdf_link_offsets()
    S_inv = transform_inverse(S)                         # eq. 2.2, batched
    J_dh = transform_pseudo_inertia(J_urdf, S_inv)      # URDF link frame -> DH frame i
    col = 10 * n
    arm_vals = fv = fc = None
    if armature:
        arm_vals, col = pi[col:col + n], col + n
    law = None
    if friction is True:
        fv, fc = pi[col:col + n], pi[col + n:col + 2 * n]
    elif friction is not False and friction is not None:
        law = _friction_law(friction, pi[col:], n, arm.transmission)
    elif arm.friction is None and arm.friction_model is not None:
        law = arm.friction_model          # the prior's own law (not the links' kind), kept
    links = []
    for i, l in enumerate(arm.links):
        label = f"link {i + 1}" + (f" ({l.name})" if l.name else "")
        if J_dh[i, 3, 3] < 0:
            raise ModelError(f"{label}: identified mass {J_dh[i, 3, 3]:.6g} kg is negative; "
                             "no model file can hold it (use the 'consistent' method)")
        J = 0.5 * (J_dh[i] + J_dh[i].T)
        if J[3, 3] == 0.0:
            J[:3, 3] = J[3, :3] = 0.0
        kw = dict(body=LinkInertia.from_pseudo_inertia(J, name=label))
        if armature:
            kw["motor_inertia"] = float(arm_vals[i]) / l.gear_ratio**2
        if friction is True:
            kw["friction_viscous"], kw["friction_coulomb"] = float(fv[i]), float(fc[i])
        elif law is not None:
            kw["friction_viscous"], kw["friction_coulomb"] = 0.0, 0.0
        links.append(dataclasses.replace(l, **kw))
    source, sources, description = metadata or (arm.source, arm.sources, arm.description)
    out = Manipulator(links, convention=arm.convention, gravity=arm.gravity,
                      name=arm.name if name is None else name, strict=strict,
                      source=source, sources=sources, description=description,
                      transmission=arm.transmission, friction=law, base=arm.base, tool=arm.tool)
    out.trust = trust
    return out


def _friction_law(friction, values, n, transmission):
    """The :class:`manipdyn.Friction` whose regressor parameters are ``values``.

    Motor-side parameters are reflected (:mod:`manipdyn.model.friction`): viscous ``R_kk^2 Fv``,
    the other amplitudes ``|R_kk| x``; they are divided back here.
    """
    from ...model.friction import Friction, friction_spec

    spec = friction_spec(friction, n)
    values = np.asarray(values, dtype=np.float64)
    R = np.diag(transmission.R) if spec.side == "motor" else None
    kw, k = {}, 0
    blocks = {"viscous": ["viscous"], "coulomb": ["coulomb"], "asymmetric": ["coulomb_pos", "coulomb_neg"],
              "offset": ["offset"], "stribeck": ["stribeck_level"], "sigmoid": ["sigmoid_A"]}
    for t in spec.terms:
        for key in blocks[t]:
            x = values[k:k + n].copy()
            k += n
            if R is not None and t != "offset":
                x = x / (R**2 if t == "viscous" else np.abs(R))
            if key != "offset":
                x = np.maximum(x, 0.0) if key not in ("stribeck_level", "sigmoid_A") else x
            kw[key] = x
    if "stribeck" in spec.terms:
        kw["stribeck_velocity"] = spec.stribeck_velocity
    if "sigmoid" in spec.terms:
        kw["sigmoid_alpha"], kw["sigmoid_p3"] = spec.sigmoid_alpha, spec.sigmoid_p3
    return Friction(**kw, side=spec.side, smoothing=spec.smoothing, deadband=spec.deadband,
                    stribeck_exponent=spec.stribeck_exponent, n=n)


def _urdf_arm_with_parameters(arm, pi, armature, friction, name, strict, metadata, trust=None):
    from ...formats.urdf.reader import load_urdf

    n = arm.n
    pi = np.asarray(pi, dtype=np.float64)
    col = 10 * n
    Jm = arm.motor_inertia if np.any(arm.motor_inertia) else None
    if armature:      # the regressor's armature is R_kk^2 Jm_k; URDF has none, the arm carries Jm
        Jm = pi[col:col + n] / np.diag(arm.transmission.R) ** 2
        col += n
    law = None
    if friction is not True and friction is not False and friction is not None:
        law = _friction_law(friction, pi[col:], n, arm.transmission)
    elif friction is False and arm.custom_drive:
        law = arm.friction_model
    body = np.concatenate([pi[:10 * n], pi[col:col + 2 * n]]) if friction is True else pi[:10 * n]
    text = urdf_with_parameters(arm, body, friction=friction is True, metadata=metadata, trust=trust)
    custom = arm.custom_drive or armature
    return load_urdf(text, tip=arm.tip, name=arm.name if name is None else name, gravity=arm.gravity,
                     strict=strict, transmission=arm.transmission if custom else None,
                     friction=law, motor_inertia=Jm)


def _psd(J, rtol=1e-12) -> bool:
    w = np.linalg.eigvalsh(0.5 * (J + J.T))
    return bool(w[0] >= -rtol * max(float(np.abs(w).max()), 1e-300))


def _inertial_element(etree, J, where):
    """An ``<inertial>`` element holding the body of pseudo-inertia ``J`` (link frame)."""
    from ...model.inertia import tensor_from_pseudo_inertia

    J = 0.5 * (J + J.T)
    m, c, I = tensor_from_pseudo_inertia(J, name=where) if J[3, 3] > 0 else (0.0, np.zeros(3), np.zeros((3, 3)))
    el = etree.Element("inertial")
    el.text = "\n      "
    etree.SubElement(el, "origin", xyz=" ".join(repr(float(x)) for x in c), rpy="0 0 0").tail = "\n      "
    etree.SubElement(el, "mass", value=repr(float(m))).tail = "\n      "
    etree.SubElement(el, "inertia", **{k: repr(float(I[a, b])) for k, (a, b) in
                                       (("ixx", (0, 0)), ("ixy", (0, 1)), ("ixz", (0, 2)),
                                        ("iyy", (1, 1)), ("iyz", (1, 2)), ("izz", (2, 2)))}).tail = "\n    "
    return el


def _replace_inertial(etree, link_el, new):
    old = link_el.find("inertial")
    if old is None:
        link_el.insert(0, new)
    else:
        new.tail = old.tail
        link_el.replace(old, new)


def urdf_with_parameters(arm, pi, friction: bool = False, metadata=None, trust=None) -> str:
    """The URDF text of the URDF arm ``arm`` with its chain bodies set to ``pi`` (p,).

    Only ``<inertial>`` elements change (module docstring), and with ``friction=True``
    the chain joints' ``<dynamics damping friction>`` (the viscous and Coulomb entries
    of ``pi`` after the 10 n body ones).  ``metadata`` (source, sources, description)
    becomes a comment after ``<robot>``, and the trust record ``trust`` another
    (:func:`manipdyn.formats.trust.trust_comment`; a prior's own is removed).  Raises :class:`ModelError` for a negative
    identified mass, naming the link.
    """
    from lxml import etree

    from ...formats.trust import strip_trust_comments, trust_comment
    from ...formats.urdf.tree import read_link

    n = arm.n
    pi = np.asarray(pi, dtype=np.float64)
    if pi.shape[0] < 10 * n or not np.all(np.isfinite(pi)):
        raise ValueError(f"pi: expected at least {10 * n} finite entries, got shape {pi.shape}")
    J_new = pseudo_inertia_from_parameters(pi[:10 * n].reshape(n, 10))
    joints, _ = arm.chain()
    root = etree.fromstring(arm.urdf_text.encode("utf-8"), etree.XMLParser(remove_blank_text=False,
                                                                            resolve_entities=False))
    links = {el.get("name"): el for el in root.iterchildren("link")}
    joint_els = {el.get("name"): el for el in root.iterchildren("joint")}
    for k, j in enumerate(joints):
        where = f"{arm.name}: link '{j.link_name}'"
        Jk = 0.5 * (J_new[k] + J_new[k].T)
        if Jk[3, 3] < 0:
            raise ModelError(f"{where}: identified mass {Jk[3, 3]:.6g} kg is negative; no URDF can hold it "
                             "(use the 'consistent' method)")
        el = links[j.link_name]
        own = read_link(el, arm.name).body
        J_own = own.J if own is not None else np.zeros((4, 4))
        J_link = J_own + (Jk - j.body.J)          # the change, on the chain link's own body
        others = [m for m in arm.lumped_links[k] if m != j.link_name] if k < len(arm.lumped_links) else []
        if _psd(J_link) and J_link[3, 3] >= 0:
            _replace_inertial(etree, el, _inertial_element(etree, J_link, where))
        else:
            _replace_inertial(etree, el, _inertial_element(etree, Jk, where))
            for m in others:
                old = links[m].find("inertial")
                if old is not None:
                    links[m].replace(old, etree.Comment(f" inertial identified as part of link "
                                                        f"'{j.link_name}' (manipdyn identify) "))
        if friction:
            dyn = joint_els[j.name].find("dynamics")
            if dyn is None:
                dyn = etree.SubElement(joint_els[j.name], "dynamics")
            dyn.set("damping", repr(float(pi[10 * n + k])))
            dyn.set("friction", repr(float(pi[11 * n + k])))
    if metadata is not None:
        source, sources, description = metadata
        lines = [f" {source} ", *(f" {key}: {val} " for key, val in (sources or {}).items())]
        text = "\n".join(lines).replace("--", "- -")
        comment = etree.Comment(text)
        comment.tail = "\n  "
        root.insert(0, comment)
    strip_trust_comments(root)           # the prior's record is not this fit's
    record = trust_comment(trust)
    if record is not None:
        el = etree.Comment(record)
        el.tail = "\n  "
        root.insert(1 if metadata is not None else 0, el)
    return '<?xml version="1.0"?>\n' + etree.tostring(root, encoding="unicode") + "\n"
