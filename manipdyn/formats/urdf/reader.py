"""URDF to arm: read a serial chain out of a URDF file, safely.

Layer 2 (formats: urdf) loaders (URDF): chain extraction and lumping of fixed bodies.

:func:`load_urdf` parses the URDF itself (lxml with entity resolution, DTD
loading and network access off) into a chain of :class:`ChainJoint`; the
trace-form engine runs on that chain and shares no code with the Pinocchio
path, which reads the original URDF text with ``pin.buildModelFromXML``.

Rules (CONVENTIONS.md for frames and inertia):

* The root link is the one link that is no joint's child.  Bodies before the
  first movable joint belong to the fixed base and carry no dynamics (as in
  Pinocchio).
* Movable joints are ``revolute``, ``continuous`` (a revolute joint without
  limits) and ``prismatic``; ``fixed`` joints are merged: the bodies after a
  fixed joint are lumped into the moving body they hang from by summing
  pseudo-inertias, ``J = sum X J_link X^T`` (eq. 2.20 in a common frame).
  ``floating`` and ``planar`` joints are refused.
* Joint limits: ``<limit lower upper>`` give :attr:`Arm.qlim`; continuous
  joints, and limits missing or written ``lower == upper`` (CAD exporters
  write ``0, 0`` for "none"), get :data:`manipdyn.model.registry.DEFAULT_QLIM`.  A chain
  joint that moves no mass at all (nothing with ``<inertial>`` from its link
  to the tip) is warned about: the mass matrix is then singular.
* Without ``tip`` the movable joints must form one root-to-leaf path; the tip
  is then the last movable link, followed through fixed joints as long as
  they do not branch.  With ``tip="link"`` the chain is the path from the
  root to that link; every other movable joint is locked at 0 (Pinocchio's
  neutral position) and its subtree is lumped like a fixed one.
* ``<mimic>`` couples two joint variables, which a chain of independent
  joints cannot express: a movable mimic joint in the chain, or mimicking a
  chain joint, is refused.  A locked mimic joint (its leader then locked or
  fixed, at 0) is consistent when its offset is 0, and refused otherwise.  ``<mimic>`` on a ``fixed``
  joint has no variable to couple and is ignored (Talos' gripper).
* ``<dynamics damping friction>`` become viscous and Coulomb joint friction,
  applied outside the Lagrangian by both engines.  URDF has no rotor
  inertia: the armature is zero.

Security and agreement: a document with a DOCTYPE is refused before any
parsing (entities, ATTLIST defaults and external DTDs are read differently
by libxml2 and by urdfdom, and are how XML entity attacks work); numbers are
ASCII, finite and within :data:`manipdyn.limits.MAX_MAGNITUDE`, vectors are
separated by spaces only; files, link counts, chain lengths and runs of
fixed joints are capped (:mod:`manipdyn._support.limits`).  Pinocchio only ever sees
text that passed these checks, and the model it builds is compared with
this reader's chain when the engine is built (both readers must read the
same arm).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..._support import limits
from ...model.arm import DEFAULT_QLIM, URDFArm
from ..._support.errors import ModelError, PhysicalConsistencyWarning, ToolFrameWarning
from ...model.inertia import LinkInertia, transform_pseudo_inertia
from ...model.links import ChainJoint
from .tree import URDFTree, default_tip, some_names, tool_frame_note, unknown_tip
from .xml import decode, parse_xml, read_source
from ..trust import trust_from_urdf

__all__ = ["load_urdf", "URDFArm", "build_chain", "pinocchio_text"]


def build_chain(tree: URDFTree, tip: str | None, strict: bool):
    """The serial chain from the root to ``tip``, in named steps.

    Returns ``(tip, joints, tool, locked, members)``: the tip link, the chain
    joints (:class:`ChainJoint`, bodies lumped), the fixed transform from the
    last chain link to the tip, the movable joints locked at 0, and the links
    lumped into each chain body.
    """
    tip = resolve_tip(tree, tip)
    path = tree.path(tip)
    chain = [j for j in path if j.movable]
    if not chain:
        raise ModelError(
            f"{tree.label}: no movable joint between the root link '{tree.root}' and the tip '{tip}'"
        )
    if len(chain) > limits.MAX_JOINTS:
        raise limits.over_limit(tree.label, f"the number of movable joints from '{tree.root}' to '{tip}'",
                                len(chain), "MAX_JOINTS")
    index = {j.name: k for k, j in enumerate(chain)}
    locked = [j for j in tree.joints.values() if j.movable and j.name not in index]
    refuse_coupled_mimics(tree, index)
    origins, tool = chain_origins(path, index)
    J, members = lump_bodies(tree, index, len(chain), strict)
    warn_joints_moving_no_mass(chain, J)
    joints = chain_joints(tree.label, chain, origins, J)
    return tip, joints, tool, tuple(j.name for j in locked), members


def resolve_tip(tree: URDFTree, tip: str | None) -> str:
    """``tip`` checked against the tree's links, or the default tip when None."""
    if tip is None:
        tip = default_tip(tree)
    else:
        tip = str(tip)
        if tip not in tree.links:
            raise unknown_tip(tree, tip)
    return tip


def refuse_coupled_mimics(tree: URDFTree, index: dict) -> None:
    """Refuse ``<mimic>`` couplings that a chain of independent joints cannot express."""
    for j in tree.joints.values():
        if j.mimic is None or not j.movable:
            continue  # a fixed joint has no variable to couple
        leader, _, offset = j.mimic
        if leader not in tree.joints:
            raise ModelError(f"{j.where}: <mimic joint='{leader}'> names no joint of the file")
        if j.name in index or leader in index:
            raise ModelError(
                f"{j.where}: mimic joints are not supported: '{j.name}' mimics '{leader}', "
                "and a chain of independent joint variables cannot express the coupling; "
                "pass a tip= whose chain contains neither"
            )
        if offset != 0.0:
            raise ModelError(
                f"{j.where}: mimic joints are not supported: '{j.name}' mimics '{leader}' with "
                f"offset {offset}; locked at 0 it would break the coupling (it should sit at {offset})"
            )



def chain_origins(path, index: dict):
    """Each chain joint's origin relative to the previous movable link frame, fixed
    joints composed in; and the fixed transform from the last chain link to the tip."""
    origins = []
    acc = np.eye(4)
    for j in path:
        if j.name in index:
            origins.append(acc @ j.origin)
            acc = np.eye(4)
        else:
            acc = acc @ j.origin  # fixed joint
    return origins, acc



def lump_bodies(tree: URDFTree, index: dict, n: int, strict: bool):
    """Pseudo-inertias (n, 4, 4) of the chain bodies, every link lumped into the moving
    body it hangs from (locked joints at 0: M(0) = I), and the links in each."""
    label = tree.label
    J = np.zeros((n, 4, 4))
    members: list[list[str]] = [[] for _ in range(n)]
    any_inertial = False
    stack = [(tree.root, -1, np.eye(4))]
    while stack:
        ln, owner, X = stack.pop()
        if owner >= 0:
            members[owner].append(ln)
            body = tree.links[ln].body
            if body is not None:
                # only moving bodies matter: a base link's inertia is never used
                body.check_physical(strict=strict)
                J[owner] += transform_pseudo_inertia(body.J, X)
                any_inertial = True
        for j in tree.children[ln]:
            if j.name in index:
                stack.append((j.child, index[j.name], np.eye(4)))
            else:
                stack.append((j.child, owner, X @ j.origin))
    if not any_inertial:
        moving = [m for ms in members for m in ms]
        raise ModelError(
            f"{label}: no <inertial> on any moving link ({some_names(moving)}): "
            "the dynamics would be identically zero"
        )

    return J, members


def warn_joints_moving_no_mass(chain, J) -> None:
    """Warn about a chain joint that moves no mass: D is then singular."""
    tail = np.cumsum(J[::-1], axis=0)[::-1]  # everything joint k moves
    for k, j in enumerate(chain):
        if not np.any(tail[k]):
            warnings.warn(
                f"{j.where}: moves no mass (no <inertial> from link '{j.child}' to the tip): "
                "the mass matrix is singular and forward dynamics undefined",
                PhysicalConsistencyWarning, stacklevel=4,
            )


def chain_joints(label: str, chain, origins, J) -> tuple:
    """The :class:`ChainJoint` records: bodies from the lumped J, limits with defaults."""
    joints = []
    for k, j in enumerate(chain):
        Jk = 0.5 * (J[k] + J[k].T)
        body = LinkInertia.from_pseudo_inertia(Jk, name=f"{label}: body of joint '{j.name}'")
        if j.type == "continuous" or j.lower is None or j.lower == j.upper:
            # lower == upper (CAD exporters write 0, 0 for "no limits"): no range to use
            qlim = DEFAULT_QLIM["prismatic" if j.type == "prismatic" else "revolute"]
        else:
            if not j.lower < j.upper:
                raise ModelError(
                    f"{j.where}: <limit lower={j.lower} upper={j.upper}>: a chain joint needs lower < upper"
                )
            qlim = (j.lower, j.upper)
        joints.append(ChainJoint(
            name=j.name, joint="prismatic" if j.type == "prismatic" else "revolute",
            origin=origins[k], axis=j.axis, body=body, qlim=qlim, armature=0.0,
            friction_viscous=j.damping, friction_coulomb=j.friction,
            effort=j.effort, velocity=j.velocity, link_name=j.child,
        ))
    return tuple(joints)


def pinocchio_text(root_el, text: str) -> str:
    """The text Pinocchio reads: the original, or with ``continuous`` joints made revolute.

    Pinocchio represents a continuous joint by ``(cos q, sin q)`` (nq = 2,
    nv = 1), while the chain uses the angle.  The dynamics of the two are the
    same; rewriting ``type="continuous"`` to ``type="revolute"`` (with limits
    +-pi, never used by the dynamics) gives ``nq == nv`` and the same joint
    order.  Nothing else of the document changes.
    """
    from copy import deepcopy

    from lxml import etree

    conts = [el for el in root_el.iterchildren("joint") if el.get("type") == "continuous"]
    if not conts:
        return text
    root = deepcopy(root_el)
    lo, hi = DEFAULT_QLIM["revolute"]
    for el in root.iterchildren("joint"):
        if el.get("type") != "continuous":
            continue
        el.set("type", "revolute")
        lim = el.find("limit")
        if lim is None:
            lim = etree.SubElement(el, "limit")
        lim.set("lower", repr(lo))
        lim.set("upper", repr(hi))
        lim.set("effort", lim.get("effort", "0"))
        lim.set("velocity", lim.get("velocity", "0"))
    return etree.tostring(root, encoding="unicode")


def load_urdf(source, tip=None, *, name=None, gravity=(0.0, 0.0, -9.81), strict=False, transmission=None,
              friction=None, motor_inertia=None) -> URDFArm:
    """Read a serial arm from a URDF file or text.

    Parameters
    ----------
    source : str or os.PathLike or bytes
        A path, or the URDF text itself (a string starting with ``<``).
    tip : str, optional
        The link where the chain ends.  Required when the movable joints
        branch (a gripper with two fingers); the joints off the root-to-tip
        path are then locked at 0 and their bodies lumped into the chain.
    name : str, optional
        Arm name (default: the ``<robot name>``).
    gravity : (3,)
        Acceleration of gravity in the root link's frame, m/s^2.
    strict : bool
        Raise instead of warning on a physically impossible ``<inertial>``.
    transmission, friction : optional
        The drive (:mod:`manipdyn.model.drive`), which URDF cannot state: identity
        transmission by default; a ``friction`` law replaces ``<dynamics>``.
        (A URDF arm sent to Dask workers travels as its URDF text, without them.)
    motor_inertia : (n,), optional
        Rotor inertia ``Jm`` at each motor, kg m^2 (URDF has none; default zeros).

    Raises
    ------
    ModelError
        Naming the file and the element: unsafe XML (entities), malformed
        numbers or missing attributes, floating/planar joints, loops,
        branching without ``tip``, unknown ``tip``, mimic joints in the chain,
        no ``<inertial>`` on any moving link.
    """
    data, label, path = read_source(source)
    text = decode(data, label)
    root_el = parse_xml(text, label)
    tree = URDFTree(root_el, label)
    chosen = tip is None
    tip, joints, tool, locked, members = build_chain(tree, tip, strict)
    note = tool_frame_note(tree, tip) if chosen else None
    if note is not None:
        warnings.warn(note, ToolFrameWarning, stacklevel=2)
    if path is None and tree.robot_name:
        label = f"URDF text (robot '{tree.robot_name}')"
    pin_text = pinocchio_text(root_el, text)
    trust = trust_from_urdf(root_el, label)
    arm = URDFArm(
        name=tree.robot_name if name is None else name, gravity=gravity, source=label,
        urdf_text=text, pin_text=pin_text, root=tree.root, tip=tip, joints=joints, tool=tool,
        locked=locked, members=members, path=path, transmission=transmission, friction=friction,
        motor_inertia=_rotor_inertias(motor_inertia, len(joints), label),
    )
    arm.trust = trust
    return arm


def _rotor_inertias(value, n: int, where: str):
    """``motor_inertia`` as (n,) finite numbers >= 0 (kg m^2), or None; a ModelError names it."""
    if value is None:
        return None
    try:
        Jm = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: motor_inertia: expected {n} numbers (kg m^2 at each motor), got {value!r:.60}") from None
    if Jm.shape != (n,) or not np.all(np.isfinite(Jm)) or np.any(Jm < 0):
        raise ModelError(f"{where}: motor_inertia: expected {n} finite numbers >= 0 (kg m^2 at each motor), "
                         f"got {Jm.tolist() if Jm.size <= 12 else Jm.shape}")
    return Jm
