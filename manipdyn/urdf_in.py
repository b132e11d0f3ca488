"""URDF to arm: read a serial chain out of a URDF file, safely.

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
  write ``0, 0`` for "none"), get :data:`manipdyn.arm.DEFAULT_QLIM`.  A chain
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

Security: a document whose DOCTYPE declares entities or points at an
external DTD is refused before any expansion (XML external entities, the
"billion laughs" bomb).  Pinocchio (whose XML reader does not guard against
them) only ever sees text that passed this check.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from dataclasses import dataclass

import numpy as np

from .arm import DEFAULT_QLIM, Arm, _gravity, joint_letters
from .errors import ModelError, PhysicalConsistencyWarning
from .inertia import LinkInertia, transform_pseudo_inertia
from .kinematics import ChainJoint, ChainKinematics, rpy_to_matrix

__all__ = ["load_urdf", "URDFArm"]

_MOVABLE = ("revolute", "continuous", "prismatic")
_KNOWN_TYPES = _MOVABLE + ("fixed", "floating", "planar")

# An XML/URDF number: no nan, inf, hex or Python-only forms (underscores).
_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?\Z")


# ---------------------------------------------------------------------------
# Reading the source safely
# ---------------------------------------------------------------------------
def _read_source(source):
    """Return ``(data: bytes or str, label for messages, path or None)``."""
    if isinstance(source, (bytes, bytearray)):
        return bytes(source), "URDF text", None
    if isinstance(source, str) and source.lstrip("\ufeff \t\r\n").startswith("<"):
        return source, "URDF text", None
    if isinstance(source, (str, os.PathLike)):
        path = os.fspath(source)
        label = f"URDF file {os.path.basename(path)}"
        try:
            with open(path, "rb") as fh:
                return fh.read(), label, path
        except OSError as exc:
            raise ModelError(f"{label}: cannot read {path!r}: {exc.strerror or exc}") from None
    raise ModelError(
        f"URDF source: expected a path or URDF text, got {type(source).__name__}"
    )


def _decode(data, label: str) -> str:
    """The document as text (UTF-8 unless a BOM or the XML declaration says otherwise)."""
    if isinstance(data, str):
        text = data
    else:
        text = _decode_bytes(data, label)
    if "\x00" in text:  # XML forbids NUL; also what UTF-16 read as UTF-8 looks like
        raise ModelError(f"{label}: the text contains NUL characters (not XML, or UTF-16 without a BOM)")
    return text.lstrip("\ufeff")


def _decode_bytes(data: bytes, label: str) -> str:
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        codec = "utf-16"
    else:
        codec = "utf-8-sig"
        m = re.match(rb"\s*<\?xml[^>]*encoding\s*=\s*[\"']([A-Za-z0-9._-]+)[\"']", data)
        if m:
            codec = m.group(1).decode("ascii")
            if codec.lower().replace("_", "-") in ("utf-8", "utf8"):
                codec = "utf-8-sig"
    try:
        return data.decode(codec)
    except (LookupError, UnicodeDecodeError) as exc:
        raise ModelError(f"{label}: cannot decode the text ({codec}): {exc}") from None


_DOCTYPE_EXTERNAL = re.compile(r"<!DOCTYPE\s+[^\s\[>]+\s+(?:SYSTEM|PUBLIC)\b")


def _refuse_entities(text: str, label: str) -> None:
    """Refuse a DOCTYPE that declares entities or names an external DTD, BEFORE parsing.

    libxml2 expands internal entities in attribute values even with
    ``resolve_entities=False``, so the check cannot wait for the parse.  It is
    conservative: any ``<!ENTITY`` in a document that has a DOCTYPE refuses it
    (URDF files have no use for either).
    """
    if "<!DOCTYPE" not in text:
        return
    if "<!ENTITY" in text:
        raise ModelError(
            f"{label}: refused: its DOCTYPE declares XML entities (a URDF has no use for "
            "them; they are how external-entity and entity-expansion attacks work). "
            "Nothing was expanded; remove the DOCTYPE"
        )
    if _DOCTYPE_EXTERNAL.search(text):
        raise ModelError(
            f"{label}: refused: its DOCTYPE references an external DTD, which is not loaded "
            "and could declare entities; remove the DOCTYPE"
        )


_XML_DECL = re.compile(r"\s*<\?xml\b[^>]*\?>")


def _parse_xml(text: str, label: str):
    from lxml import etree

    _refuse_entities(text, label)
    # lxml parses a str only without an encoding declaration; the text is already
    # decoded, so drop the declaration (keeping its newlines: line numbers stay right).
    m = _XML_DECL.match(text)
    body = text if m is None else "\n" * m.group(0).count("\n") + text[m.end():]
    parser = etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False,
        dtd_validation=False, remove_comments=False,
    )
    try:
        root = etree.fromstring(body, parser)
    except etree.XMLSyntaxError as exc:
        raise ModelError(f"{label}: not well-formed XML: {exc}") from None
    # Second line of defence, on what libxml2 actually saw.
    info = root.getroottree().docinfo
    dtd = info.internalDTD
    if (dtd is not None and any(True for _ in dtd.iterentities())) or info.system_url or info.public_id:
        raise ModelError(f"{label}: refused: its DOCTYPE declares XML entities or an external DTD")
    return root


# ---------------------------------------------------------------------------
# Strict element readers
# ---------------------------------------------------------------------------
def _where(label: str, el, what: str) -> str:
    line = getattr(el, "sourceline", None)
    return f"{label}, line {line}, {what}" if line else f"{label}, {what}"


def _number(el, attr: str, where: str, default=None) -> float:
    raw = el.get(attr)
    if raw is None:
        if default is None:
            raise ModelError(f"{where}: <{el.tag}> is missing the attribute '{attr}'")
        return default
    s = raw.strip()
    if not _NUMBER.match(s):
        raise ModelError(f"{where}: <{el.tag} {attr}=\"{raw}\">: not a finite number")
    v = float(s)
    if not math.isfinite(v):
        raise ModelError(f"{where}: <{el.tag} {attr}=\"{raw}\">: not a finite number")
    return v


def _vector3(el, attr: str, where: str, default) -> np.ndarray:
    raw = el.get(attr)
    if raw is None:
        return np.array(default, dtype=np.float64)
    parts = raw.split()
    if len(parts) != 3 or not all(_NUMBER.match(p) for p in parts):
        raise ModelError(f"{where}: <{el.tag} {attr}=\"{raw}\">: expected 3 finite numbers")
    v = np.array([float(p) for p in parts])
    if not np.all(np.isfinite(v)):
        raise ModelError(f"{where}: <{el.tag} {attr}=\"{raw}\">: expected 3 finite numbers")
    return v


def _origin(parent_el, where: str) -> np.ndarray:
    """The 4x4 transform of the ``<origin xyz rpy>`` child (identity if absent)."""
    els = parent_el.findall("origin")
    if len(els) > 1:
        raise ModelError(f"{where}: more than one <origin>")
    T = np.eye(4)
    if els:
        o = els[0]
        T[:3, 3] = _vector3(o, "xyz", where, (0.0, 0.0, 0.0))
        T[:3, :3] = rpy_to_matrix(_vector3(o, "rpy", where, (0.0, 0.0, 0.0)))
    return T


def _one_child(el, tag: str, where: str, required: bool):
    els = el.findall(tag)
    if len(els) > 1:
        raise ModelError(f"{where}: more than one <{tag}>")
    if not els:
        if required:
            raise ModelError(f"{where}: missing the <{tag}> element")
        return None
    return els[0]


def _name(el, where: str) -> str:
    n = el.get("name")
    if n is None or not n.strip():
        raise ModelError(f"{where}: <{el.tag}> has no name")
    return n


@dataclass
class _Link:
    name: str
    line: int | None
    body: LinkInertia | None  # in the link frame; None: no <inertial>


@dataclass
class _Joint:
    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float | None
    upper: float | None
    effort: float | None
    velocity: float | None
    damping: float
    friction: float
    mimic: tuple | None  # (leader, multiplier, offset)
    where: str

    @property
    def movable(self) -> bool:
        return self.type in _MOVABLE


def _read_link(el, label: str) -> _Link:
    where0 = _where(label, el, "<link>")
    name = _name(el, where0)
    where = _where(label, el, f"link '{name}'")
    inert = _one_child(el, "inertial", where, required=False)
    body = None
    if inert is not None:
        wi = _where(label, inert, f"link '{name}' <inertial>")
        X = _origin(inert, wi)
        mass = _number(_one_child(inert, "mass", wi, True), "value", wi)
        iel = _one_child(inert, "inertia", wi, True)
        ixx, ixy, ixz, iyy, iyz, izz = (
            _number(iel, a, wi) for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        )
        I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        R = X[:3, :3]
        # URDF: tensor about the COM in the <inertial><origin> frame -> link frame
        body = LinkInertia(mass, X[:3, 3], R @ I @ R.T, name=wi)
    return _Link(name=name, line=el.sourceline, body=body)


def _read_joint(el, label: str) -> _Joint:
    where0 = _where(label, el, "<joint>")
    name = _name(el, where0)
    where = _where(label, el, f"joint '{name}'")
    jtype = el.get("type")
    if jtype is None:
        raise ModelError(f"{where}: <joint> is missing the attribute 'type'")
    if jtype not in _KNOWN_TYPES:
        raise ModelError(f"{where}: unknown joint type {jtype!r} (URDF knows {', '.join(_KNOWN_TYPES)})")
    if jtype in ("floating", "planar"):
        raise ModelError(
            f"{where}: {jtype} joints are not supported: manipdyn models fixed-base serial arms "
            "with revolute, continuous and prismatic joints"
        )
    links = []
    for tag in ("parent", "child"):
        e = _one_child(el, tag, where, required=True)
        ln = e.get("link")
        if ln is None or not ln.strip():
            raise ModelError(f"{where}: <{tag}> is missing the attribute 'link'")
        links.append(ln)
    origin = _origin(el, where)
    axis = np.array([1.0, 0.0, 0.0])
    lower = upper = effort = velocity = None
    damping = friction = 0.0
    mimic = None
    if jtype in _MOVABLE:
        ax_el = _one_child(el, "axis", where, required=False)
        if ax_el is not None:
            axis = _vector3(ax_el, "xyz", where, (1.0, 0.0, 0.0))
        if not np.linalg.norm(axis) > 0:
            raise ModelError(f"{where}: <axis xyz> must be non-zero")
        lim = _one_child(el, "limit", where, required=jtype != "continuous")
        if lim is not None:
            # URDF requires effort and velocity; Pinocchio's reader refuses the file without them
            effort = _number(lim, "effort", where)
            velocity = _number(lim, "velocity", where)
            if jtype != "continuous" and (lim.get("lower") is not None or lim.get("upper") is not None):
                lower = _number(lim, "lower", where, default=0.0)
                upper = _number(lim, "upper", where, default=0.0)
        dyn = _one_child(el, "dynamics", where, required=False)
        if dyn is not None:
            damping = _number(dyn, "damping", where, default=0.0)
            friction = _number(dyn, "friction", where, default=0.0)
            if damping < 0 or friction < 0:
                raise ModelError(f"{where}: <dynamics> damping and friction must be >= 0, "
                                 f"got damping={damping}, friction={friction}")
    mel = _one_child(el, "mimic", where, required=False)
    if mel is not None:
        leader = mel.get("joint")
        if leader is None or not leader.strip():
            raise ModelError(f"{where}: <mimic> is missing the attribute 'joint'")
        mimic = (leader, _number(mel, "multiplier", where, default=1.0),
                 _number(mel, "offset", where, default=0.0))
    return _Joint(name=name, type=jtype, parent=links[0], child=links[1], origin=origin,
                  axis=axis, lower=lower, upper=upper, effort=effort, velocity=velocity,
                  damping=damping, friction=friction, mimic=mimic, where=where)


# ---------------------------------------------------------------------------
# The tree and the chain
# ---------------------------------------------------------------------------
def _some(names, k: int = 12) -> str:
    names = list(names)
    s = ", ".join(repr(n) for n in names[:k])
    return s + (f", ... ({len(names)} in all)" if len(names) > k else "")


class _Tree:
    def __init__(self, root_el, label: str):
        self.label = label
        if root_el.tag != "robot":
            raise ModelError(f"{label}: the root element is <{root_el.tag}>, expected <robot>")
        self.robot_name = root_el.get("name") or ""
        self.links: dict[str, _Link] = {}
        for el in root_el.iterchildren("link"):
            link = _read_link(el, label)
            if link.name in self.links:
                raise ModelError(_where(label, el, f"link '{link.name}'") + ": duplicate link name")
            self.links[link.name] = link
        if not self.links:
            raise ModelError(f"{label}: no <link> in <robot>")
        self.joints: dict[str, _Joint] = {}
        self.parent_joint: dict[str, _Joint] = {}
        self.children: dict[str, list[_Joint]] = {n: [] for n in self.links}
        for el in root_el.iterchildren("joint"):
            j = _read_joint(el, label)
            if j.name in self.joints:
                raise ModelError(f"{j.where}: duplicate joint name")
            for role, ln in (("parent", j.parent), ("child", j.child)):
                if ln not in self.links:
                    raise ModelError(f"{j.where}: {role} link '{ln}' is not defined")
            if j.child in self.parent_joint:
                other = self.parent_joint[j.child]
                raise ModelError(
                    f"{j.where}: link '{j.child}' already has the parent joint '{other.name}': "
                    "a link with two parent joints closes a kinematic loop; URDF describes trees only"
                )
            self.joints[j.name] = j
            self.parent_joint[j.child] = j
            self.children[j.parent].append(j)
        roots = [n for n in self.links if n not in self.parent_joint]
        if not roots:
            raise ModelError(f"{label}: no root link: every link is some joint's child (a kinematic loop)")
        if len(roots) > 1:
            raise ModelError(f"{label}: several root links {_some(roots)}: the links are not one connected tree")
        self.root = roots[0]
        seen = set()
        stack = [self.root]
        while stack:
            ln = stack.pop()
            seen.add(ln)
            stack.extend(j.child for j in self.children[ln])
        if len(seen) != len(self.links):
            cut = [n for n in self.links if n not in seen]
            raise ModelError(
                f"{label}: links {_some(cut)} are not reachable from the root link "
                f"'{self.root}': their joints form a kinematic loop"
            )

    def path(self, link: str) -> list[_Joint]:
        """Joints from the root down to ``link``."""
        out = []
        while link in self.parent_joint:
            j = self.parent_joint[link]
            out.append(j)
            link = j.parent
        return out[::-1]


def _default_tip(tree: _Tree) -> str:
    label = tree.label
    movable = [j for j in tree.joints.values() if j.movable]
    if not movable:
        raise ModelError(f"{label}: no movable joint (revolute, continuous or prismatic)")
    deepest = max(movable, key=lambda j: len(tree.path(j.child)))
    on_path = {j.name for j in tree.path(deepest.child)}
    for m in movable:
        if m.name in on_path:
            continue
        mp = tree.path(m.child)
        k = next(i for i, j in enumerate(mp) if j.name not in on_path)
        branch = mp[k].parent
        ends = [deepest.child, m.child]
        raise ModelError(
            f"{label}: the movable joints are not serial: they branch at link '{branch}' "
            f"(towards joint '{m.name}' and joint '{deepest.name}'). "
            f"Pass tip='<link name>' to choose the chain, e.g. tip={ends[0]!r} or tip={ends[1]!r} "
            f"or tip={branch!r}; the other joints are then locked at 0"
        )
    tip = deepest.child
    while len(tree.children[tip]) == 1 and tree.children[tip][0].type == "fixed":
        tip = tree.children[tip][0].child
    return tip


def _build(tree: _Tree, tip: str | None, strict: bool):
    label = tree.label
    if tip is None:
        tip = _default_tip(tree)
    else:
        tip = str(tip)
        if tip not in tree.links:
            leaves = [n for n in tree.links if not tree.children[n]]
            others = [n for n in tree.links if tree.children[n]]
            raise ModelError(
                f"{label}: unknown tip link {tip!r}; links are {_some(leaves + others)}"
            )
    path = tree.path(tip)
    chain = [j for j in path if j.movable]
    if not chain:
        raise ModelError(
            f"{label}: no movable joint between the root link '{tree.root}' and the tip '{tip}'"
        )
    index = {j.name: k for k, j in enumerate(chain)}
    locked = [j for j in tree.joints.values() if j.movable and j.name not in index]

    # mimic joints
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

    # Origins relative to the previous movable link frame; fixed joints composed in.
    origins = []
    acc = np.eye(4)
    for j in path:
        if j.name in index:
            origins.append(acc @ j.origin)
            acc = np.eye(4)
        else:
            acc = acc @ j.origin  # fixed joint
    tool = acc

    # Lump every link into the moving body it hangs from (locked joints at 0: M(0) = I).
    n = len(chain)
    J = np.zeros((n, 4, 4))
    members: list[list[str]] = [[] for _ in range(n)]
    with_inertial = [False] * n
    stack = [(tree.root, -1, np.eye(4))]
    while stack:
        ln, owner, X = stack.pop()
        if owner >= 0:
            members[owner].append(ln)
            body = tree.links[ln].body
            if body is not None:
                # only moving bodies matter: a base link's inertia is never used
                body.check_physical(strict=strict, where=body.name)
                J[owner] += transform_pseudo_inertia(body.J, X)
                with_inertial[owner] = True
        for j in tree.children[ln]:
            if j.name in index:
                stack.append((j.child, index[j.name], np.eye(4)))
            else:
                stack.append((j.child, owner, X @ j.origin))
    if not any(with_inertial):
        moving = [m for ms in members for m in ms]
        raise ModelError(
            f"{label}: no <inertial> on any moving link ({_some(moving)}): "
            "the dynamics would be identically zero"
        )

    tail = np.cumsum(J[::-1], axis=0)[::-1]  # everything joint k moves
    for k, j in enumerate(chain):
        if not np.any(tail[k]):
            warnings.warn(
                f"{j.where}: moves no mass (no <inertial> from link '{j.child}' to the tip): "
                "the mass matrix is singular and forward dynamics undefined",
                PhysicalConsistencyWarning, stacklevel=3,
            )
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
    return tip, tuple(joints), tool, tuple(j.name for j in locked), members


def _pinocchio_text(root_el, text: str) -> str:
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


# ---------------------------------------------------------------------------
# The arm
# ---------------------------------------------------------------------------
class URDFArm(Arm):
    """A serial arm read from a URDF file; build it with :func:`load_urdf`.

    Attributes
    ----------
    name, gravity, source : as for every :class:`Arm`
    joint_names : tuple of str
        Chain joints, root to tip (the order of q).
    joint_types : tuple of "revolute" | "prismatic"
        ``continuous`` joints are revolute joints without limits.
    link_names : tuple of str
        The child link of each chain joint.
    root, tip : str
        Root link (the fixed base frame) and the link whose pose :meth:`fkine` gives.
    locked_joints : tuple of str
        Movable joints off the chain, held at 0 (their subtrees are lumped).
    urdf_text : str
        The original text.
    armature : (n,) zeros
        URDF has no rotor inertia.
    friction : (2, n) or None
        Viscous (``damping``) and Coulomb (``friction``) coefficients of ``<dynamics>``.
    """

    def __init__(self, *, name, gravity, source, urdf_text, pin_text, root, tip, joints, tool,
                 locked, members, path=None):
        self.name = str(name)
        self.gravity = _gravity(gravity)
        self.source = source
        self.urdf_text = urdf_text
        self._pin_text = pin_text
        self.path = path
        self.root = root
        self.tip = tip
        self._joints = joints
        tool = np.array(tool, dtype=np.float64)
        tool.setflags(write=False)
        self._tool = tool
        self.locked_joints = tuple(locked)
        self.lumped_links = tuple(tuple(m) for m in members)
        self.joint_names = tuple(j.name for j in joints)
        self.link_names = tuple(j.link_name for j in joints)
        self.joint_types = tuple(j.joint for j in joints)
        self._qlim = np.array([j.qlim for j in joints], dtype=np.float64)
        self._qlim.setflags(write=False)
        self.armature = np.zeros(len(joints))
        self.armature.setflags(write=False)
        fr = np.array([[j.friction_viscous for j in joints], [j.friction_coulomb for j in joints]])
        if np.any(fr):
            fr.setflags(write=False)
            self.friction = fr
        else:
            self.friction = None

    @property
    def tool_frame(self) -> str:
        """Name of the frame whose pose :meth:`fkine` gives, in Pinocchio's model: the tip link."""
        return self.tip

    # -- Arm interface --------------------------------------------------------
    def chain(self):
        """``(joints, tool)``: the chain joints and the fixed transform last link -> tip."""
        return self._joints, self._tool.copy()

    def _lagrange_parts(self):
        kin = ChainKinematics(self._joints, self._tool)
        J = np.array([j.body.J for j in self._joints])
        return kin, J, self.armature, self.friction

    def _pinocchio_model(self):
        """Pinocchio's own reading of the URDF text (continuous joints made revolute),
        reduced by locking the off-chain joints at ``pin.neutral`` (0)."""
        import pinocchio as pin

        where = self.source
        model = pin.buildModelFromXML(self._pin_text)
        if self.locked_joints:
            ids = []
            for nm in self.locked_joints:
                if not model.existJointName(nm):
                    raise ModelError(f"{where}: Pinocchio's model has no joint {nm!r} to lock")
                ids.append(model.getJointId(nm))
            model = pin.buildReducedModel(model, ids, pin.neutral(model))
        names = tuple(model.names)[1:]
        if names != self.joint_names:
            raise ModelError(
                f"{where}: Pinocchio's joint order {list(names)} differs from the chain's "
                f"root-to-tip order {list(self.joint_names)}"
            )
        if not (model.nq == model.nv == self.n):
            raise ModelError(f"{where}: Pinocchio's model has nq={model.nq}, nv={model.nv}; expected {self.n}")
        model.gravity.linear = np.array(self.gravity)
        model.armature = np.array(self.armature)
        return model

    # -- comparison and display -------------------------------------------------
    def __eq__(self, other):
        if not isinstance(other, URDFArm):
            return NotImplemented
        return (self.urdf_text == other.urdf_text and self.tip == other.tip
                and self.name == other.name and np.array_equal(self.gravity, other.gravity))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        kinds = joint_letters(self.joint_types)
        s = f"<URDFArm {self.name!r}: {self.n} joints {kinds}, {self.root!r} -> {self.tip!r}"
        if self.locked_joints:
            s += f", {len(self.locked_joints)} locked"
        return s + f" ({self.source})>"


def load_urdf(source, tip=None, *, name=None, gravity=(0.0, 0.0, -9.81), strict=False) -> URDFArm:
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

    Raises
    ------
    ModelError
        Naming the file and the element: unsafe XML (entities), malformed
        numbers or missing attributes, floating/planar joints, loops,
        branching without ``tip``, unknown ``tip``, mimic joints in the chain,
        no ``<inertial>`` on any moving link.
    """
    data, label, path = _read_source(source)
    text = _decode(data, label)
    root_el = _parse_xml(text, label)
    tree = _Tree(root_el, label)
    tip, joints, tool, locked, members = _build(tree, tip, strict)
    if path is None and tree.robot_name:
        label = f"URDF text (robot '{tree.robot_name}')"
    pin_text = _pinocchio_text(root_el, text)
    return URDFArm(
        name=tree.robot_name if name is None else name, gravity=gravity, source=label,
        urdf_text=text, pin_text=pin_text, root=tree.root, tip=tip, joints=joints, tool=tool,
        locked=locked, members=members, path=path,
    )
