"""Variants of an arm to use as the plant of a simulation: a payload, mis-estimated masses.

Layer 1 (model): an arm changed into another arm.  Used as simulation plants (control,
Monte-Carlo) and by payload identification.

Each returns a new arm of the kind it was given (the original is immutable and
unchanged), built by combining pseudo-inertias (eq. 2.20: the pseudo-inertias
of bodies described in one frame add) and ``dataclasses.replace`` on the links.
:func:`with_payload` takes every kind of arm and is ``arm.with_payload``: on a URDF
arm the payload becomes a link of its own, fixed to the tip, in the URDF text
(which Pinocchio reads) and lumped into the last chain body (which the trace
form reads), so the engines' agreement check holds the two to each other.
:func:`with_scaled_inertia` needs a DH arm.
"""

from __future__ import annotations

import dataclasses
import re
import warnings

import numpy as np

from .._support.errors import ModelError, PhysicalConsistencyWarning
from .._support.limits import nonnegative
from .arm import Manipulator, URDFArm, register_service
from .inertia import LinkInertia, transform_pseudo_inertia

__all__ = ["with_payload", "with_scaled_inertia"]


def _rebuild(arm: Manipulator, links, name: str) -> Manipulator:
    # The unchanged links were checked (and warned about) when ``arm`` was built;
    # the changes below keep J positive semidefinite, so nothing new to report.
    # The drive and the poses go along: a friction law given apart from the links (the bundled
    # panda's sigmoid, an identified [friction]) and a coupled transmission are the plant's too.
    law = None if any(l.friction_viscous or l.friction_coulomb for l in links) else arm.friction_model
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        return Manipulator(links, convention=arm.convention, gravity=arm.gravity, name=name,
                           strict=arm.strict, source=arm.source, sources=arm.sources,
                           transmission=arm.transmission, friction=law, poses=dict(arm.poses),
                           base=arm.base, tool=arm.tool)


def _dh_arm(arm, fn: str) -> Manipulator:
    if not isinstance(arm, Manipulator):
        raise ModelError(f"{fn}: needs a DH arm (manipdyn.Manipulator), got {type(arm).__name__}")
    return arm


def _six(inertia):
    """Six numbers ``[ixx, iyy, izz, ixy, ixz, iyz]`` (RUNS.toml's payload order) as the (3, 3) tensor;
    anything else as given (:class:`LinkInertia` checks it and names what it expects)."""
    if isinstance(inertia, (str, bytes, dict)):
        return inertia
    try:
        v = np.asarray(inertia, dtype=np.float64)
    except (TypeError, ValueError):
        return inertia
    if v.shape != (6,):
        return inertia
    ixx, iyy, izz, ixy, ixz, iyz = v
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


def with_payload(arm, mass: float, com=(0.0, 0.0, 0.0), inertia=None, name=None):
    """The arm carrying a payload rigidly attached at its tool; ``arm.with_payload(...)``.

    Parameters
    ----------
    arm : manipdyn.Arm
        A DH arm (:class:`~manipdyn.Manipulator`) or a URDF arm (:class:`~manipdyn.URDFArm`).
    mass : float
        Payload mass, kg (>= 0).
    com : (3,)
        Payload centre of mass in the tool frame, the frame :meth:`~manipdyn.Arm.fkine`
        gives (a DH arm's frame n; a URDF arm's tip link), m.
    inertia : (3, 3), (6,) or (3,), optional
        Payload inertia tensor about its own centre of mass (tensor sign, tool-frame
        axes; six values are ``[ixx, iyy, izz, ixy, ixz, iyz]``, the order of RUNS.toml's
        ``payload.inertia``; three values are the diagonal), kg m^2; default 0 (a point mass).
    name : str, optional
        Default ``"<arm>+<mass>kg"``.

    Returns
    -------
    manipdyn.Arm
        A new arm of the same kind.  The last link's pseudo-inertia becomes ``J_n + J_payload``
        (both in that link's frame), converted back by :meth:`LinkInertia.from_pseudo_inertia`;
        a URDF arm's text gains the payload as a link fixed to the tip (named
        ``<tip>_payload``), so the arm written to a file carries it too.
    """
    if not isinstance(arm, (Manipulator, URDFArm)):
        raise ModelError(f"with_payload: needs an arm (manipdyn.Manipulator or manipdyn.URDFArm), "
                         f"got {type(arm).__name__}")
    mass = nonnegative(mass, "with_payload: mass", "kg")
    payload = LinkInertia(mass, com, np.zeros((3, 3)) if inertia is None else _six(inertia), name="payload")
    payload.check_physical(strict=True, where="with_payload: payload")
    name = name if name is not None else f"{arm.name or 'arm'}+{mass:g}kg"
    if isinstance(arm, URDFArm):
        return _urdf_with_payload(arm, payload, name)
    last = arm.links[-1]
    if not np.array_equal(arm.tool, np.eye(4)):       # given in the tool frame: into DH frame n
        payload = payload.transformed(arm.tool)
    body = LinkInertia.from_pseudo_inertia(last.body.J + payload.J, name=last.name or "last link")
    links = arm.links[:-1] + (dataclasses.replace(last, mass=body.mass, com=body.com, inertia=body.inertia),)
    return _rebuild(arm, links, name)


def _outside_comments(text: str, needle: str) -> int:
    """Index of the last ``needle`` in ``text`` outside XML comments, or -1."""
    comments = [m.span() for m in re.finditer(r"<!--.*?-->", text, flags=re.S)]
    at = len(text)
    while True:
        at = text.rfind(needle, 0, at)
        if at < 0 or not any(a <= at < b for a, b in comments):
            return at


def _with_payload_link(text: str, link: str, joint: str, tip: str, payload: LinkInertia) -> str:
    """``text`` with ``<link name=link>`` (the payload's inertial, about its COM in the tip
    frame) fixed to ``tip`` by ``<joint name=joint>``, just before ``</robot>``."""
    at = _outside_comments(text, "</robot>")
    if at < 0:
        raise ModelError("with_payload: the arm's URDF text has no closing </robot>")
    I = [[float(x) for x in row] for row in payload.inertia]      # repr of a float: exact, and plain
    c = [float(x) for x in payload.com]
    block = (f'  <link name="{link}">\n    <inertial>\n      <origin xyz="{c[0]!r} {c[1]!r} {c[2]!r}" rpy="0 0 0"/>\n'
             f'      <mass value="{float(payload.mass)!r}"/>\n'
             f'      <inertia ixx="{I[0][0]!r}" ixy="{I[0][1]!r}" ixz="{I[0][2]!r}" iyy="{I[1][1]!r}" '
             f'iyz="{I[1][2]!r}" izz="{I[2][2]!r}"/>\n    </inertial>\n  </link>\n'
             f'  <joint name="{joint}" type="fixed">\n    <parent link="{tip}"/>\n    <child link="{link}"/>\n'
             f'    <origin xyz="0 0 0" rpy="0 0 0"/>\n  </joint>\n')
    return text[:at] + block + text[at:]


def _urdf_with_payload(arm: URDFArm, payload: LinkInertia, name: str) -> URDFArm:
    joints, tool = arm.chain()
    taken = arm.urdf_text + arm.source_urdf
    link = f"{arm.tip}_payload"
    k = 1
    while f'"{link}"' in taken or f'"{link}_joint"' in taken:
        k += 1
        link = f"{arm.tip}_payload{k}"
    last = joints[-1]
    body = LinkInertia.from_pseudo_inertia(last.body.J + transform_pseudo_inertia(payload.J, tool),
                                           name=last.link_name or "last link")
    joints = joints[:-1] + (dataclasses.replace(last, body=body),)
    members = [list(m) for m in arm.lumped_links]
    if members:
        members[-1].append(link)
    custom = arm.custom_drive                  # a drive given apart from the text goes along
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        out = URDFArm(name=name, gravity=arm.gravity, source=arm.source,
                      urdf_text=_with_payload_link(arm.urdf_text, link, f"{link}_joint", arm.tip, payload),
                      pin_text=_with_payload_link(arm.source_urdf, link, f"{link}_joint", arm.tip, payload),
                      root=arm.root, tip=arm.tip, joints=joints, tool=tool, locked=arm.locked_joints,
                      members=members, transmission=arm.transmission if custom else None,
                      friction=arm.friction_model if custom else None,
                      motor_inertia=arm.motor_inertia if custom else None)
    out.notes = tuple(arm.notes)
    return out


def with_scaled_inertia(arm, factor, name=None) -> Manipulator:
    """The arm with each link's mass and inertia multiplied by ``factor``.

    ``factor``: a scalar or one value per link (>= 0).  Centres of mass stay
    where they are (the pseudo-inertia scales as a whole, so a physical link
    stays physical).  Models a mis-estimated arm: e.g. a controller built on
    ``with_scaled_inertia(arm, 0.8)`` underestimates every mass by 20 %.
    """
    arm = _dh_arm(arm, "with_scaled_inertia")
    f = np.array(factor, dtype=np.float64)
    if f.ndim == 0:
        f = np.full(arm.n, float(f))
    if f.shape != (arm.n,) or not np.all(np.isfinite(f)) or np.any(f < 0):
        raise ModelError(f"with_scaled_inertia: factor must be >= 0, a scalar or {arm.n} values, "
                         f"got {np.asarray(factor).tolist()!r}")
    links = tuple(dataclasses.replace(l, mass=l.mass * fi, inertia=l.inertia * fi)
                  for l, fi in zip(arm.links, f))
    default = f"{arm.name or 'arm'}x{f[0]:g}" if np.all(f == f[0]) else f"{arm.name or 'arm'}(scaled)"
    return _rebuild(arm, links, name if name is not None else default)


register_service("with_payload", with_payload)     # arm.with_payload(...)
