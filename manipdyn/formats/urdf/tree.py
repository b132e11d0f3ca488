"""The link/joint tree of a URDF document: links with their bodies, joints, paths.

Layer 2 (formats: urdf) loaders (URDF).  Reads ``<link>`` and ``<joint>`` elements into
plain records and checks the tree (one root, no loops, known joint types).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError, TipError
from ...model.inertia import LinkInertia
from ...model.links import check_name
from .xml import (KNOWN_TYPES, MOVABLE, check_numbers, one_child, read_name, read_number, read_origin,
                       read_vector3, where_in)

__all__ = ["URDFLink", "URDFJoint", "URDFTree", "read_link", "read_joint", "some_names", "default_tip",
           "tip_candidates", "unknown_tip"]

@dataclass
class URDFLink:
    name: str
    body: LinkInertia | None  # in the link frame; None: no <inertial>


@dataclass
class URDFJoint:
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
        return self.type in MOVABLE


def read_link(el, label: str) -> URDFLink:
    where0 = where_in(label, el, "<link>")
    name = read_name(el, where0)
    where = where_in(label, el, f"link '{name}'")
    check_numbers(el, where)
    inert = one_child(el, "inertial", where, required=False)
    body = None
    if inert is not None:
        wi = where_in(label, inert, f"link '{name}' <inertial>")
        X = read_origin(inert, wi)
        mass = read_number(one_child(inert, "mass", wi, True), "value", wi)
        iel = one_child(inert, "inertia", wi, True)
        ixx, ixy, ixz, iyy, iyz, izz = (
            read_number(iel, a, wi) for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        )
        I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        R = X[:3, :3]
        # URDF: tensor about the COM in the <inertial><origin> frame -> link frame
        body = LinkInertia(mass, X[:3, 3], R @ I @ R.T, name=wi)
    return URDFLink(name=name, body=body)


def read_joint(el, label: str) -> URDFJoint:
    where0 = where_in(label, el, "<joint>")
    name = read_name(el, where0)
    where = where_in(label, el, f"joint '{name}'")
    check_numbers(el, where)
    jtype = el.get("type")
    if jtype is None:
        raise ModelError(f"{where}: <joint> is missing the attribute 'type'")
    if jtype not in KNOWN_TYPES:
        raise ModelError(f"{where}: unknown joint type {jtype!r} (URDF knows {', '.join(KNOWN_TYPES)})")
    if jtype in ("floating", "planar"):
        raise ModelError(
            f"{where}: {jtype} joints are not supported: manipdyn models fixed-base serial arms "
            "with revolute, continuous and prismatic joints"
        )
    links = []
    for tag in ("parent", "child"):
        e = one_child(el, tag, where, required=True)
        ln = e.get("link")
        if ln is None or not ln.strip():
            raise ModelError(f"{where}: <{tag}> is missing the attribute 'link'")
        links.append(ln)
    origin = read_origin(el, where)
    axis = np.array([1.0, 0.0, 0.0])
    lower = upper = effort = velocity = None
    damping = friction = 0.0
    mimic = None
    if jtype in MOVABLE:
        ax_el = one_child(el, "axis", where, required=False)
        if ax_el is not None:
            axis = read_vector3(ax_el, "xyz", where, (1.0, 0.0, 0.0))
        if not np.linalg.norm(axis) >= 1e-9:  # a tinier axis loses digits when normalised
            raise ModelError(f"{where}: <axis xyz=\"{ax_el.get('xyz') if ax_el is not None else ''}\">: "
                             "must be a direction of length >= 1e-9")
        lim = one_child(el, "limit", where, required=jtype != "continuous")
        if lim is not None:
            # URDF requires effort and velocity; Pinocchio's reader refuses the file without them
            effort = read_number(lim, "effort", where)
            velocity = read_number(lim, "velocity", where)
            if effort < 0 or velocity < 0:
                raise ModelError(f"{where}: <limit effort={effort} velocity={velocity}>: both must be >= 0 "
                                 "(they are magnitudes; Pinocchio's reader refuses negative ones)")
            if jtype != "continuous" and (lim.get("lower") is not None or lim.get("upper") is not None):
                lower = read_number(lim, "lower", where, default=0.0)
                upper = read_number(lim, "upper", where, default=0.0)
                limits.check_range((lower, upper), f"{where} <limit>", "lower/upper",
                                   "length" if jtype == "prismatic" else "angle")
        dyn = one_child(el, "dynamics", where, required=False)
        if dyn is not None:
            damping = read_number(dyn, "damping", where, default=0.0)
            friction = read_number(dyn, "friction", where, default=0.0)
            if damping < 0 or friction < 0:
                raise ModelError(f"{where}: <dynamics> damping and friction must be >= 0 (a negative one drives the "
                                 f"joint along its motion), got damping={damping}, friction={friction}; without the "
                                 f"<dynamics> tags the rigid part loads (docs/guide/trust.md adds such tags' torques)")
    mel = one_child(el, "mimic", where, required=False)
    if mel is not None:
        leader = mel.get("joint")
        if leader is None or not leader.strip():
            raise ModelError(f"{where}: <mimic> is missing the attribute 'joint'")
        mimic = (leader, read_number(mel, "multiplier", where, default=1.0),
                 read_number(mel, "offset", where, default=0.0))
    return URDFJoint(name=name, type=jtype, parent=links[0], child=links[1], origin=origin,
                  axis=axis, lower=lower, upper=upper, effort=effort, velocity=velocity,
                  damping=damping, friction=friction, mimic=mimic, where=where)


# ---------------------------------------------------------------------------
# The tree and the chain
# ---------------------------------------------------------------------------
def some_names(names, k: int = 12) -> str:
    names = list(names)
    s = ", ".join(repr(n) for n in names[:k])
    return s + (f", ... ({len(names)} in all)" if len(names) > k else "")


class URDFTree:
    def __init__(self, root_el, label: str):
        self.label = label
        if root_el.tag != "robot":
            raise ModelError(f"{label}: the root element is <{root_el.tag}>, expected <robot>")
        self.robot_name = check_name(root_el.get("name") or "", label, "<robot name>")
        for tag in ("link", "joint"):
            count = sum(1 for _ in root_el.iterchildren(tag))
            if count > limits.MAX_LINKS:
                raise limits.over_limit(label, f"the number of <{tag}> elements", count, "MAX_LINKS")
        self.links: dict[str, URDFLink] = {}
        for el in root_el.iterchildren("link"):
            link = read_link(el, label)
            if link.name in self.links:
                raise ModelError(where_in(label, el, f"link '{link.name}'") + ": duplicate link name")
            self.links[link.name] = link
        if not self.links:
            raise ModelError(f"{label}: no <link> in <robot>")
        self.joints: dict[str, URDFJoint] = {}
        self.parent_joint: dict[str, URDFJoint] = {}
        self.children: dict[str, list[URDFJoint]] = {n: [] for n in self.links}
        for el in root_el.iterchildren("joint"):
            j = read_joint(el, label)
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
            raise ModelError(f"{label}: several root links {some_names(roots)}: the links are not one connected tree")
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
                f"{label}: links {some_names(cut)} are not reachable from the root link "
                f"'{self.root}': their joints form a kinematic loop"
            )
        self.check_fixed_runs()

    def check_fixed_runs(self) -> None:
        """Refuse more than :data:`manipdyn.limits.MAX_FIXED_RUN` fixed joints in a row."""
        stack = [(self.root, 0)]
        while stack:
            ln, run = stack.pop()
            for j in self.children[ln]:
                r = run + 1 if j.type == "fixed" else 0
                if r > limits.MAX_FIXED_RUN:
                    raise limits.over_limit(f"{j.where}", "the number of fixed joints in a row ending here",
                                            r, "MAX_FIXED_RUN")
                stack.append((j.child, r))

    def path(self, link: str) -> list[URDFJoint]:
        """Joints from the root down to ``link``."""
        out = []
        while link in self.parent_joint:
            j = self.parent_joint[link]
            out.append(j)
            link = j.parent
        return out[::-1]


def tip_candidates(tree: URDFTree) -> list[str]:
    """Leaf links with at least one movable joint between them and the root: possible tips."""
    return [n for n in tree.links if not tree.children[n] and any(j.movable for j in tree.path(n))]


def unknown_tip(tree: URDFTree, tip: str) -> TipError:
    """The error for a tip that is not a link of the tree: close spellings and every link."""
    import difflib

    close = difflib.get_close_matches(tip, list(tree.links), n=3, cutoff=0.6)
    return TipError(tree.label, f"unknown tip link {tip!r}", leaves=tip_candidates(tree),
                    links=list(tree.links), suggestions=close)


def default_tip(tree: URDFTree) -> str:
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
        raise TipError(
            label, f"the movable joints are not serial: they branch at link '{branch}' "
                   f"(towards joint '{m.name}' and joint '{deepest.name}'); the joints off the chosen "
                   "chain are then locked at 0",
            leaves=tip_candidates(tree), links=list(tree.links))
    tip = deepest.child
    while len(tree.children[tip]) == 1 and tree.children[tip][0].type == "fixed":
        tip = tree.children[tip][0].child
    return tip


def passed_over_frames(tree: URDFTree, tip: str) -> list[tuple[str, np.ndarray]]:
    """The leaf links hanging from ``tip`` through fixed joints only, with the fixed
    transform (4, 4) from ``tip`` to each: the tool frames a default tip passed over."""
    out = []
    stack = [(tip, np.eye(4))]
    while stack:
        link, T = stack.pop()
        kids = tree.children[link]
        if not kids and link != tip:
            out.append((link, T))
        for j in kids:
            if j.type == "fixed":
                stack.append((j.child, T @ j.origin))
    return sorted(out, key=lambda x: x[0])


def tool_frame_note(tree: URDFTree, tip: str) -> str | None:
    """A one-line note when the default ``tip`` is not the only tool frame the URDF offers:
    the leaf frames beyond it at another pose (distance in m, rotation in degrees), or None."""
    others = []
    for name, T in passed_over_frames(tree, tip):
        dist = float(np.linalg.norm(T[:3, 3]))
        angle = float(np.degrees(np.arccos(np.clip((np.trace(T[:3, :3]) - 1) / 2, -1.0, 1.0))))
        if dist > 1e-9 or angle > 1e-7:        # a frame at the tip's own pose is the same tool
            others.append(f"'{name}' ({dist:.4g} m, {angle:.3g} deg away)")
    if not others:
        return None
    return (f"{tree.label}: the tool frame is link '{tip}', the last moving link (no tip= given); "
            f"the URDF's leaf frames beyond it were passed over: {', '.join(others)}; fkine, "
            f"jacobian(frame='tool') and inverse_kinematics use '{tip}': pass tip='<link>' "
            "(--tip on the command line) to make one of them the tool")
