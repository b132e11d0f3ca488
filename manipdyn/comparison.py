"""Are two descriptions the same arm?  (``md.compare(a, b)``, ``manipdyn compare A B``)

Layer: application (compare).

Typical use: a datasheet DH table against the vendor's URDF.  The two
descriptions may put the base and tool frames elsewhere, count a joint the
other way round, or start it from another zero.  :func:`compare` finds, in
closed form, the joint map and the constant transforms under which

    T_b(q) = base @ T_a(q') @ tool,      q'_i = sign_i * q_i + offset_i,

(``T`` the tool pose in each arm's own base frame, ``q`` arm b's joint
vector, ``q'`` arm a's), reports how well the forward kinematics then
agree, and compares the dynamics at matched states.

Method (no black-box optimiser)
-------------------------------
1. Each arm is brought to one form, ``T(q) = W_0 J(q_1) W_1 J(q_2) ... J(q_n) W_n``,
   with ``J(q) = Rz(q)`` (revolute) or ``Tz(q)`` (prismatic): every joint frame
   gets its z axis on the joint axis.  (A prismatic joint has a direction but
   no line; its line is put, in both arms alike, through the neighbouring
   revolute axes, see :func:`_canonical_prismatic`.)
2. Flipping joint i's sign is ``J(-q) = F J(q) F`` with ``F = Rx(pi)``, and an
   offset is ``J(q + o) = J(o) J(q)``.  Two forms give the same forward
   kinematics exactly when every joint line of one maps onto the joint line of
   the other, i.e. ``W^b_i = H_i^-1 (F_i W^a_i J(o_i+1) F_i+1) H_i+1`` with
   ``H_i = Rz(phi_i) Tz(t_i)`` the freedom of a frame on its own axis
   (it commutes with the joint motion).
3. Each link transform ``W`` (z-line to z-line) is split as
   ``Rz(theta) Tz(d) Tx(a) Rx(alpha) Rz(psi) Tz(e)`` (a DH-like normal form,
   unique for skew axes).  ``(a, alpha)`` must agree between the arms: this
   prunes the sign choices.  The angles give ``phi`` and the right-hand
   rotation of every link directly; their difference across a joint is the
   joint offset.  The translations ``t`` (along each axis) come from one
   small linear least-squares problem, which also handles parallel axes (only
   ``d + e`` is then defined).
4. Signs are searched depth-first over joints, pruned link by link by the
   ``(a, alpha)`` test; the surviving sign vectors (a few; up to ``2^n`` for
   arms whose axes all meet at right angles) are scored by their forward
   kinematics on a few states.  Exact ties are genuine kinematic symmetries
   (the wrist flip ``(q5 + pi, -q6)``, joint 1 reversed with the base turned
   over, ...): they fit the tool pose equally but put the links' bodies in
   different places, so the mass distribution decides between them (D and g
   compared on a few states; every candidate within 10x of the best match
   stays in), and what remains goes to the fewest flipped joints, then the
   smallest offsets.  The report says when that last rule had to choose
   between alignments whose dynamics differ.
5. ``base`` and ``tool`` then follow from the first and last equation, and
   are refined by alternating closed-form Kabsch steps (orthogonal Procrustes
   on the tool origin and three points along the tool axes over all sampled
   states); each step cannot increase the squared error.

Gauge: joint 1's offset and a rotation of the base about joint 1's axis are
indistinguishable from the kinematics, as are the last joint's offset and a
rotation of the tool about the last axis (for prismatic end joints: a
translation along it).  :func:`compare` reports offset 0 for those two joints
and puts the difference into ``base`` and ``tool``.

Dynamics at matched states
--------------------------
At ``q`` (arm b) the matched state of arm a is ``q' = sign*q + offset``,
``qd' = sign*qd``.  D and h are coordinate-free given the joint variables,
so they do not depend on the base transform: ``D_b`` is compared with
``S D_a S`` and ``h_b`` with ``S h_a`` (``S = diag(sign)``).  Gravity does
depend on it: each model states gravity in its own base frame, and a base
rotated by ``base`` sees b's gravity as ``R_base^T g_b``.  To compare the
same physical situation, arm a's gravity torque is computed with b's
gravity expressed in a's base, ``R_base^T g_b``; if that differs from the
gravity arm a declares, the report notes it (the two files then disagree
about which way is up).  Rotor inertia and friction are left out of D, h, g
(a URDF cannot state rotor inertia); the armatures are listed side by side.
Each difference is reported as the largest over the sampled states of
``max|x_b - x_a|`` (absolute) and of that divided by ``max(|x_a|, |x_b|)``
over the entries (relative).  Per link, the report lists both masses and
how far apart the two centres of mass sit once the arms are aligned (at
b's zero configuration).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from .errors import ModelError
from .arm import joint_letters
from .kinematics import rot_x, rot_z, trans, transform_inverse

__all__ = ["compare", "CompareReport", "QuantityDiff", "KIN_TOLERANCE"]

#: max tool position error (m) under which two descriptions are called the same arm
KIN_TOLERANCE = 1e-6
#: max tool orientation error (rad) under which two descriptions are called the same arm
ROT_TOLERANCE = 1e-6

_EZ = np.array([0.0, 0.0, 1.0])
#: axes closer than this angle (rad) are treated as parallel: descriptions round
#: pi/2 to 1.5708 or 1.571, which tilts "parallel" axes by up to ~2e-4 rad, and
#: the common normal of nearly parallel axes is meaningless
_PARALLEL_SIN = 1e-3
#: parallel axes closer than this (relative to the arm's size) are coincident
_COINCIDENT_LEN = 1e-6
_FLIP = np.diag([1.0, -1.0, -1.0, 1.0])  # Rx(pi)


# ---------------------------------------------------------------------------
# Small SE(3) helpers (the elementary transforms are kinematics.py's)
# ---------------------------------------------------------------------------
_rz, _rx, _tr, _inv = rot_z, rot_x, trans, transform_inverse
def _joint(revolute: bool, q: float) -> np.ndarray:
    return _rz(q) if revolute else _tr(0.0, 0.0, q)


def _wrap(a: float) -> float:
    """Angle in (-pi, pi]."""
    a = math.remainder(a, 2.0 * math.pi)
    return math.pi if a == -math.pi else a


def _kabsch(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Rigid transform X (4x4, det +1) minimising sum |X p_k - q_k|^2; P, Q (k, 3)."""
    pc, qc = P.mean(axis=0), Q.mean(axis=0)
    H = (P - pc).T @ (Q - qc)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    X = np.eye(4)
    X[:3, :3] = R
    X[:3, 3] = qc - R @ pc
    return X


def _rot_angle(R: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) of rotation matrices (..., 3, 3), robust near 0 and pi."""
    # angle = 2 atan2(|vee(R - R^T)|/2 ... ) via the quaternion-free formula
    tr = np.trace(R, axis1=-2, axis2=-1)
    w = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                  R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    return np.arctan2(np.linalg.norm(w, axis=-1), tr - 1.0)


# ---------------------------------------------------------------------------
# Step 1: the z-axis chain form of an arm
# ---------------------------------------------------------------------------
def _zframe(axis) -> np.ndarray:
    """A rotation (4x4) whose z axis is the unit ``axis`` (deterministic choice)."""
    u = np.asarray(axis, dtype=np.float64)
    u = u / np.linalg.norm(u)
    h = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(h, u)
    x /= np.linalg.norm(x)
    y = np.cross(u, x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, y, u])
    return T


@dataclass
class _Chain:
    W: list            # n+1 transforms, T(q) = W0 J(q1) W1 ... J(qn) Wn
    revolute: list     # n bools

    def fk(self, q) -> np.ndarray:
        T = self.W[0]
        for i, r in enumerate(self.revolute):
            T = T @ _joint(r, q[i]) @ self.W[i + 1]
        return T

    def lines(self) -> list:
        """Joint lines at q = 0 in the base frame: [(point, direction)]."""
        out, T = [], self.W[0]
        for i in range(len(self.revolute)):
            out.append((T[:3, 3].copy(), T[:3, 2].copy()))
            T = T @ self.W[i + 1]
        return out


def _chain(arm) -> _Chain:
    joints, tool = arm.chain()
    n = len(joints)
    Q = [_zframe(j.axis) for j in joints]
    W = [np.asarray(joints[0].origin, dtype=np.float64) @ Q[0]]
    for k in range(n - 1):
        W.append(_inv(Q[k]) @ np.asarray(joints[k + 1].origin, dtype=np.float64) @ Q[k + 1])
    W.append(_inv(Q[n - 1]) @ np.asarray(tool, dtype=np.float64))
    ch = _Chain(W=W, revolute=[j.joint == "revolute" for j in joints])
    _canonical_prismatic(ch)
    return ch


def _canonical_prismatic(ch: _Chain, eps: float = 1e-9) -> None:
    """Give every prismatic joint a line defined by the arm's geometry alone.

    A prismatic joint moves along a direction; where its 'axis line' sits is
    a free choice of each description.  Put it, in the joint frame's xy plane,
    on a neighbouring revolute axis parallel to it (next joint first), else at
    the crossing of the projections of the previous and next revolute axes on
    the plane normal to the motion.  Without such neighbours it stays where
    the description put it (and a remaining mismatch shows in the report).
    """
    n = len(ch.revolute)
    for k in range(n):
        if ch.revolute[k]:
            continue
        # joint-k frame at q = 0, and its neighbours' lines in that frame
        Tk = ch.W[0]
        for i in range(k):
            Tk = Tk @ ch.W[i + 1]
        Tk_inv = _inv(Tk)
        lines = ch.lines()
        nb = []
        for j in (k + 1, k - 1):
            if 0 <= j < n and ch.revolute[j]:
                p, d = lines[j]
                nb.append(((Tk_inv @ np.append(p, 1.0))[:3], Tk_inv[:3, :3] @ d))
        shift = None
        for p, d in nb:
            if math.hypot(d[0], d[1]) < eps:
                shift = p[:2]
                break
        if shift is None and len(nb) == 2:
            (p1, d1), (p2, d2) = nb
            A = np.column_stack([d1[:2], -d2[:2]])
            if abs(np.linalg.det(A)) > eps:
                s = np.linalg.solve(A, p2[:2] - p1[:2])
                shift = p1[:2] + s[0] * d1[:2]
        if shift is None:
            continue
        S = _tr(shift[0], shift[1], 0.0)
        ch.W[k] = ch.W[k] @ S
        ch.W[k + 1] = _inv(S) @ ch.W[k + 1]


# ---------------------------------------------------------------------------
# Step 3: the normal form of a link transform
# ---------------------------------------------------------------------------
@dataclass
class _Split:
    kind: str      # "skew" | "parallel" | "coincident"
    theta: float
    d: float
    a: float
    alpha: float
    psi: float
    e: float

    @property
    def c(self) -> float:
        return math.cos(self.alpha)


def _split(G: np.ndarray, len_scale: float) -> _Split:
    """``G = Rz(theta) Tz(d) Tx(a) Rx(alpha) Rz(psi) Tz(e)`` for a transform between z-lines.

    Skew axes: the common normal makes the form unique.  Parallel axes (within
    ``_PARALLEL_SIN``; then the form holds to that angle only): theta
    is the direction of the offset between them, d = 0 by convention (only
    d + cos(alpha) e is defined).  Coincident axes: theta = 0, a = 0, d = 0.
    """
    z2 = G[:3, 2]
    p = G[:3, 3]
    cr = np.cross(_EZ, z2)
    s_ang = float(np.linalg.norm(cr))
    cz = float(z2[2])
    if s_ang > _PARALLEL_SIN:
        nvec = cr / s_ang
        theta = math.atan2(nvec[1], nvec[0])
        # feet of the common normal: (0, 0, d) on the z axis, p + t z2 on the other line
        b = cz
        w = -p
        dd, ee = w[2], float(z2 @ w)
        den = 1.0 - b * b
        d = (b * ee - dd) / den
        t = (ee - b * dd) / den
        foot2 = p + t * z2
        a = float((foot2 - np.array([0.0, 0.0, d])) @ nvec)
        alpha = math.atan2(s_ang, cz)
        kind = "skew"
    else:
        alpha = 0.0 if cz > 0 else math.pi
        rxy = math.hypot(p[0], p[1])
        d = 0.0
        if rxy > _COINCIDENT_LEN * len_scale:
            theta, a, kind = math.atan2(p[1], p[0]), rxy, "parallel"
        else:
            theta, a, kind = 0.0, 0.0, "coincident"
    N = _rz(theta) @ _tr(0.0, 0.0, d) @ _tr(a) @ _rx(alpha)
    Rm = _inv(N) @ G
    psi = math.atan2(Rm[1, 0], Rm[0, 0])
    e = float(Rm[2, 3])
    return _Split(kind, theta, d, a, alpha, psi, e)


# ---------------------------------------------------------------------------
# Step 2-5: the alignment
# ---------------------------------------------------------------------------
@dataclass
class _Candidate:
    signs: tuple
    offsets: np.ndarray
    base: np.ndarray
    tool: np.ndarray
    error: float = math.inf


def _flip(s: int) -> np.ndarray:
    return _FLIP if s < 0 else np.eye(4)


def _link_invariants_ok(sv: _Split, sb: _Split, tol_len: float, tol_cos: float) -> bool:
    if (sv.kind == "skew") != (sb.kind == "skew"):
        return False
    if abs(sv.c - sb.c) > tol_cos:
        return False
    return abs(sv.a - sb.a) <= tol_len


def _solve_signs(ca: _Chain, cb: _Chain, signs, scale: float) -> _Candidate:
    """Offsets, base and tool for one sign vector (closed form, steps 2-3 and 5)."""
    n = len(signs)
    rev = cb.revolute
    phi = np.zeros(n)    # left rotation of each joint frame (used in link i)
    rho = np.zeros(n)    # right rotation (used in link i-1)
    # translation unknowns: left t_i for every joint; right tau_i = t_i except
    # for interior prismatic joints, which get their own variable
    idx_left = list(range(n))
    idx_right = list(range(n))
    nv = n
    for i in range(1, n - 1):
        if not rev[i]:
            idx_right[i] = nv
            nv += 1
    rows, rhs = [], []
    for i in range(n - 1):
        V = _flip(signs[i]) @ ca.W[i + 1] @ _flip(signs[i + 1])
        sv, sb = _split(V, scale), _split(cb.W[i + 1], scale)
        phi[i] = sv.theta - sb.theta
        rho[i + 1] = sb.psi - sv.psi
        if sb.kind == "skew" and sv.kind == "skew":
            r = np.zeros(nv)
            r[idx_left[i]] = 1.0
            rows.append(r)
            rhs.append(sv.d - sb.d)
            r = np.zeros(nv)
            r[idx_right[i + 1]] = 1.0
            rows.append(r)
            rhs.append(sb.e - sv.e)
        else:
            c = sb.c
            r = np.zeros(nv)
            r[idx_left[i]] -= 1.0
            r[idx_right[i + 1]] += c
            rows.append(r)
            rhs.append((sb.d - sv.d) + c * (sb.e - sv.e))
    if rows:
        x = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    else:
        x = np.zeros(nv)
    t_left = x[idx_left]
    t_right = x[idx_right]
    offsets = np.zeros(n)
    for i in range(1, n - 1):
        if rev[i]:
            offsets[i] = _wrap(signs[i] * (rho[i] - phi[i]))
        else:
            offsets[i] = signs[i] * (t_right[i] - t_left[i])
    H0 = _rz(phi[0]) @ _tr(0.0, 0.0, t_left[0]) if n > 1 else np.eye(4)
    Hn = _rz(rho[n - 1]) @ _tr(0.0, 0.0, t_right[n - 1]) if n > 1 else np.eye(4)
    base = cb.W[0] @ _inv(H0) @ _flip(signs[0]) @ _inv(ca.W[0])
    tool = _inv(_flip(signs[n - 1]) @ ca.W[n]) @ Hn @ cb.W[n]
    return _Candidate(tuple(int(s) for s in signs), offsets, base, tool)


def _sign_vectors(ca: _Chain, cb: _Chain, scale: float, tol_len: float, tol_cos: float):
    """Sign vectors whose link invariants (a, alpha) all agree (depth-first, pruned)."""
    n = len(cb.revolute)
    splits_b = [_split(cb.W[i + 1], scale) for i in range(n - 1)]
    out = []

    def dfs(prefix):
        k = len(prefix)
        if k == n:
            out.append(tuple(prefix))
            return
        for s in (1, -1):
            if k > 0:
                V = _flip(prefix[-1]) @ ca.W[k] @ _flip(s)
                if not _link_invariants_ok(_split(V, scale), splits_b[k - 1], tol_len, tol_cos):
                    continue
            dfs(prefix + [s])

    dfs([])
    return out


def _mapped_fk(arm_a, cand: _Candidate, q: np.ndarray) -> np.ndarray:
    qa = np.asarray(cand.signs) * q + cand.offsets
    return cand.base @ arm_a.fkine(qa) @ cand.tool


def _pose_errors(Tb: np.ndarray, Tm: np.ndarray):
    pos = np.linalg.norm(Tb[..., :3, 3] - Tm[..., :3, 3], axis=-1)
    rot = _rot_angle(np.swapaxes(Tm[..., :3, :3], -1, -2) @ Tb[..., :3, :3])
    return pos, rot


def _refine(arm_a, Tb: np.ndarray, q: np.ndarray, cand: _Candidate, scale: float, iters: int = 20):
    """Alternating closed-form (Kabsch) steps on base and tool (step 5)."""
    A = arm_a.fkine(np.asarray(cand.signs) * q + cand.offsets)
    E = np.array([[0.0, 0.0, 0.0, 1.0], [scale, 0, 0, 1], [0, scale, 0, 1], [0, 0, scale, 1]]).T  # (4, 4)
    Pb = (Tb @ E)[:, :3, :].transpose(0, 2, 1).reshape(-1, 3)

    def cost(X, Y):
        Pm = (X @ A @ Y @ E)[:, :3, :].transpose(0, 2, 1).reshape(-1, 3)
        return float(np.sum((Pm - Pb) ** 2))

    X, Y = cand.base, cand.tool
    best = cost(X, Y)
    for _ in range(iters):
        Pa = (A @ Y @ E)[:, :3, :].transpose(0, 2, 1).reshape(-1, 3)
        X = _kabsch(Pa, Pb)
        Z = (_inv(A) @ _inv(X) @ Tb @ E)[:, :3, :].transpose(0, 2, 1).reshape(-1, 3)
        Y = _kabsch(np.tile(E[:3].T, (len(q), 1)), Z)
        c = cost(X, Y)
        if c < best * (1.0 - 1e-12):
            best = c
            cand.base, cand.tool = X, Y
        else:
            break
    return cand


# ---------------------------------------------------------------------------
# The report
# ---------------------------------------------------------------------------
@dataclass
class QuantityDiff:
    """Largest difference of one dynamics quantity over the matched states."""

    name: str
    max_abs: float
    max_rel: float
    worst_index: int

    def to_dict(self) -> dict:
        return {"quantity": self.name, "max_abs": self.max_abs, "max_rel": self.max_rel,
                "worst_index": self.worst_index}


@dataclass
class CompareReport:
    """Result of :func:`compare`.

    ``T_b(q) = base @ T_a(q') @ tool`` with ``q'_i = joint_signs[i] * q_i +
    joint_offsets[i]`` (``q`` arm b's joints, ``q'`` arm a's).
    """

    a: str
    b: str
    n: int
    joint_types: tuple
    samples: int
    seed: int
    fk_error: float                  # max tool position error after alignment (m)
    rot_error: float                 # max tool orientation error after alignment (rad)
    base: np.ndarray
    tool: np.ndarray
    joint_signs: tuple
    joint_offsets: np.ndarray
    dynamics: dict = field(default_factory=dict)   # "D", "h", "g" -> QuantityDiff
    masses: list = field(default_factory=list)     # per link: dict(link, name_a, name_b, mass_a, mass_b, diff, com_offset)
    armature_a: np.ndarray | None = None
    armature_b: np.ndarray | None = None
    gravity_a: np.ndarray | None = None            # a's declared gravity (a's base)
    gravity_used_a: np.ndarray | None = None       # b's gravity seen in a's base (used for g)
    candidates: int = 0                            # sign vectors scored
    notes: list = field(default_factory=list)

    @property
    def same_kinematics(self) -> bool:
        """True when the aligned forward kinematics agree within KIN_TOLERANCE / ROT_TOLERANCE."""
        return bool(self.fk_error <= KIN_TOLERANCE and self.rot_error <= ROT_TOLERANCE)

    ok = same_kinematics

    def to_dict(self) -> dict:
        return {
            "a": self.a, "b": self.b, "n": self.n, "joint_types": list(self.joint_types),
            "samples": self.samples, "seed": self.seed,
            "same_kinematics": self.same_kinematics,
            "fk_error_m": self.fk_error, "rot_error_rad": self.rot_error,
            "kin_tolerance_m": KIN_TOLERANCE,
            "base": self.base.tolist(), "tool": self.tool.tolist(),
            "joint_signs": list(self.joint_signs), "joint_offsets": [float(x) for x in self.joint_offsets],
            "dynamics": {k: v.to_dict() for k, v in self.dynamics.items()},
            "masses": self.masses,
            "armature_a": None if self.armature_a is None else self.armature_a.tolist(),
            "armature_b": None if self.armature_b is None else self.armature_b.tolist(),
            "gravity_a": None if self.gravity_a is None else self.gravity_a.tolist(),
            "gravity_used_a": None if self.gravity_used_a is None else self.gravity_used_a.tolist(),
            "candidates": self.candidates, "notes": list(self.notes),
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2)

    @staticmethod
    def _pose_str(T: np.ndarray) -> str:
        from .kinematics import matrix_to_rpy

        rpy = np.degrees(matrix_to_rpy(T[:3, :3]))
        rpy = np.where(np.abs(rpy) < 5e-10, 0.0, rpy)
        p = np.where(np.abs(T[:3, 3]) < 5e-13, 0.0, T[:3, 3])
        return (f"xyz = ({p[0]:.6g}, {p[1]:.6g}, {p[2]:.6g}) m, "
                f"rpy = ({rpy[0]:.6g}, {rpy[1]:.6g}, {rpy[2]:.6g}) deg")

    def __str__(self) -> str:
        kinds = joint_letters(self.joint_types)
        verdict = ("SAME ARM (kinematics agree within "
                   f"{KIN_TOLERANCE:g} m)" if self.same_kinematics else "DIFFERENT kinematics")
        lines = [
            f"compare a = {self.a!r} with b = {self.b!r}: {self.n} joints {kinds}, "
            f"{self.samples} states, seed {self.seed}",
            f"kinematics: {verdict}: max tool position error {self.fk_error:.3e} m, "
            f"orientation {self.rot_error:.3e} rad after alignment",
            "  T_b(q) = base @ T_a(q') @ tool,  q'_i = sign_i * q_i + offset_i",
            "  joint  sign  offset",
        ]
        for i, (s, o, t) in enumerate(zip(self.joint_signs, self.joint_offsets, self.joint_types)):
            unit = f"{math.degrees(o):+.6g} deg" if t == "revolute" else f"{o:+.6g} m"
            gauge = ""
            if i == 0:
                gauge = "  (joint 1's offset is folded into base)"
            elif i == self.n - 1:
                gauge = f"  (joint {self.n}'s offset is folded into tool)"
            lines.append(f"  {i + 1:>5}  {s:+d}    {unit}{gauge}")
        lines.append(f"  base (b's base <- a's base): {self._pose_str(self.base)}")
        lines.append(f"  tool (a's tool -> b's tool): {self._pose_str(self.tool)}")
        if self.dynamics:
            lines.append("dynamics at matched states (rigid bodies; a's g computed with b's gravity "
                         "in a's base):")
            lines.append(f"  {'quantity':<9}{'max abs diff':>14}{'max rel diff':>14}")
            for k, d in self.dynamics.items():
                lines.append(f"  {k:<9}{d.max_abs:14.3e}{d.max_rel:14.3e}")
        if self.masses:
            lines.append(f"  {'link':<5}{'name a':<14}{'name b':<18}{'mass a':>9}{'mass b':>9}"
                         f"{'diff':>10}{'COM offset (m)':>16}")
            for m in self.masses:
                com = "-" if m["com_offset"] is None else f"{m['com_offset']:.4g}"
                lines.append(f"  {m['link']:<5}{m['name_a'][:13]:<14}{m['name_b'][:17]:<18}"
                             f"{m['mass_a']:9.4g}{m['mass_b']:9.4g}{m['diff']:+10.4g}{com:>16}")
            ta = sum(m["mass_a"] for m in self.masses)
            tb = sum(m["mass_b"] for m in self.masses)
            lines.append(f"  total moving mass: a {ta:.6g} kg, b {tb:.6g} kg")
        if self.armature_a is not None and (np.any(self.armature_a) or np.any(self.armature_b)):
            lines.append(f"  rotor inertia G^2 Jm (not in D above): a {np.round(self.armature_a, 6).tolist()}, "
                         f"b {np.round(self.armature_b, 6).tolist()}")
        for note in self.notes:
            lines.append(f"note: {note}")
        return "\n".join(lines)


# ---------------------------------------------------------------------------
# compare()
# ---------------------------------------------------------------------------
def _as_arm(x, which: str):
    from .arm import Arm

    if isinstance(x, Arm):
        return x
    if isinstance(x, str) or hasattr(x, "__fspath__"):
        from .loading import load

        return load(x)
    raise ModelError(f"compare: argument {which} must be an arm or a model name/file, got {type(x).__name__}")


def _rigid_engine(arm, gravity):
    """A trace-form engine of ``arm`` with the given gravity, no rotors, no friction."""
    from .lagrange import TraceFormEngine

    kin, J, _arm, _fr = arm.trace_form_data()
    return TraceFormEngine(kin, J, gravity)


def _dynamics_mismatch(a, b, cand: _Candidate, q: np.ndarray) -> float:
    """Relative D and g mismatch of one alignment on a few states (tie-breaking)."""
    S = np.asarray(cand.signs, dtype=np.float64)
    qa = S * q + cand.offsets
    g_in_a = cand.base[:3, :3].T @ np.asarray(b.gravity, dtype=np.float64)
    eb, ea = _rigid_engine(b, b.gravity), _rigid_engine(a, g_in_a)
    Db, Da = eb.mass_matrix(q), ea.mass_matrix(qa)
    gb, ga = eb.gravity_torque(q), ea.gravity_torque(qa)
    Da = S[:, None] * Da * S[None, :]
    ga = S * ga
    return float(_qdiff("D", Db, Da).max_rel + _qdiff("g", gb, ga).max_rel)


def _fmt_vec(v) -> str:
    return "(" + ", ".join(f"{float(x):.6g}" for x in v) + ")"


def _qdiff(name, xb, xa) -> QuantityDiff:
    N = xb.shape[0]
    diff = np.abs(xb - xa).reshape(N, -1).max(axis=1)
    scale = np.maximum(np.abs(xb).reshape(N, -1).max(axis=1), np.abs(xa).reshape(N, -1).max(axis=1))
    rel = np.where(scale > 1e-12, diff / np.where(scale > 1e-12, scale, 1.0), 0.0)
    i = int(np.argmax(rel))
    return QuantityDiff(name, float(diff.max()), float(rel[i]), i)


def compare(a, b, samples: int = 200, seed: int = 0) -> CompareReport:
    """Are ``a`` and ``b`` two descriptions of the same arm?

    Parameters
    ----------
    a, b : manipdyn.Arm, or a bundled model name / model file / URDF path
    samples : int
        Random states of arm b (uniform within its joint limits, seeded)
        on which the aligned kinematics and the dynamics are compared.
    seed : int

    Returns
    -------
    CompareReport
        ``fk_error`` (m), ``base``, ``tool``, ``joint_signs``,
        ``joint_offsets``, ``dynamics`` (D, h, g differences), ``masses``.

    Raises
    ------
    ModelError
        When the arms differ in number or type of joints.
    """
    a = _as_arm(a, "a")
    b = _as_arm(b, "b")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise ValueError(f"samples: expected a positive integer, got {samples!r}")
    def kinds(arm):
        return arm.joint_letters
    if a.n != b.n:
        raise ModelError(f"compare: {a.name!r} has {a.n} joints ({kinds(a)}) and {b.name!r} has "
                         f"{b.n} ({kinds(b)}): not the same arm")
    for i, (ta, tb) in enumerate(zip(a.joint_types, b.joint_types)):
        if ta != tb:
            raise ModelError(f"compare: joint {i + 1} is {ta} in {a.name!r} and {tb} in {b.name!r} "
                             f"({kinds(a)} vs {kinds(b)}): not the same arm")
    n = a.n
    ca, cb = _chain(a), _chain(b)
    reach = sum(float(np.linalg.norm(W[:3, 3])) for W in ca.W + cb.W)
    scale = max(1.0, reach)

    rng = np.random.default_rng(seed)
    q = b.random_state(rng, int(samples))
    Tb = b.fkine(q)
    q_probe = q[: min(len(q), 16)]
    Tb_probe = Tb[: len(q_probe)]

    def score(cand):
        pos, rot = _pose_errors(Tb_probe, _mapped_fk(a, cand, q_probe))
        return float(max(pos.max(), rot.max() * scale))

    sign_sets = _sign_vectors(ca, cb, scale, tol_len=1e-3 * scale, tol_cos=1e-3)
    notes = []
    if not sign_sets:
        if n > 12:
            raise ModelError(f"compare: no joint-sign assignment makes the link geometry of {a.name!r} "
                             f"and {b.name!r} agree, and {n} joints are too many to try them all")
        sign_sets = [tuple(1 if (k >> i) & 1 == 0 else -1 for i in range(n)) for k in range(2 ** n)]
        notes.append("no joint-sign assignment makes every link's geometry (twist angle and length "
                     "between consecutive axes) agree; the best of all 2^n assignments is shown")
    cands = []
    for s in sign_sets:
        c = _solve_signs(ca, cb, s, scale)
        c.error = score(c)
        cands.append(c)
    tie = 1e-9 * scale
    best_err = min(c.error for c in cands)
    close = [c for c in cands if c.error <= best_err + tie]
    convention = lambda c: (sum(1 for s in c.signs if s < 0), float(np.sum(np.abs(c.offsets))))  # noqa: E731
    if len(close) > 1:
        # Kinematic symmetries (the wrist flip (q5 + pi, -q6), a flip of joint 1
        # with the base, ...) give several exact alignments that put the links'
        # bodies in different places.  The mass distribution tells them apart:
        # keep those whose dynamics match within 10x of the best, then prefer the
        # fewest flipped joints and the smallest offsets.
        mism = [_dynamics_mismatch(a, b, c, q_probe[:8]) for c in close]
        m0 = min(mism)
        kept = [(c, m) for c, m in zip(close, mism) if m <= max(10.0 * m0, m0 + 1e-9)]
        best = min((c for c, _ in kept), key=convention)
        if len(kept) > 1 and max(m for _, m in kept) > m0 + 1e-9:
            notes.append(f"{len(close) - 1} other joint-sign/offset assignments fit the kinematics equally "
                         "well (kinematic symmetries such as the wrist flip); they place the links' masses "
                         f"differently, but {len(kept) - 1} of them match the dynamics about as well as this "
                         "one, which was chosen for the fewest flipped joints and the smallest offsets")
    else:
        best = close[0]
    best = _refine(a, Tb, q, best, scale)

    Tm = _mapped_fk(a, best, q)
    pos, rot = _pose_errors(Tb, Tm)

    # -- dynamics at matched states -----------------------------------------------
    S = np.asarray(best.signs, dtype=np.float64)
    qa = S * q + best.offsets
    qd = rng.uniform(-1.0, 1.0, (len(q), n))
    qda = S * qd
    Rb = best.base[:3, :3]
    g_in_a = Rb.T @ np.asarray(b.gravity, dtype=np.float64)
    eb = _rigid_engine(b, b.gravity)
    ea = _rigid_engine(a, g_in_a)
    Db, hb, gb = eb.dynamics_terms(q, qd)
    Da, ha, ga = ea.dynamics_terms(qa, qda)
    dyn = {
        "D": _qdiff("D", Db, S[:, None] * Da * S[None, :]),
        "h": _qdiff("h", hb, S * ha),
        "g": _qdiff("g", gb, S * ga),
    }
    ga_decl = np.asarray(a.gravity, dtype=np.float64)
    na, nb = float(np.linalg.norm(ga_decl)), float(np.linalg.norm(g_in_a))
    tilt = math.atan2(float(np.linalg.norm(np.cross(ga_decl, g_in_a))), float(ga_decl @ g_in_a)) \
        if na > 0 and nb > 0 else 0.0
    if abs(na - nb) > 1e-9 * max(na, nb) or tilt > 1e-4 or (na == 0) != (nb == 0):
        notes.append(f"gravity: a declares {_fmt_vec(ga_decl)} m/s^2 in its base; b's gravity "
                     f"{_fmt_vec(b.gravity)} is {_fmt_vec(g_in_a)} in a's base ({math.degrees(tilt):.3g} deg "
                     f"apart, magnitudes {na:.6g} and {nb:.6g}); g above uses b's")

    # -- masses, and where each link's centre of mass sits ------------------------
    ja, _ = a.chain()
    jb, _ = b.chain()
    Ja = a.trace_form_data().J
    Jb = b.trace_form_data().J
    Pa = best.base @ a.link_poses(best.offsets)
    Pb = b.link_poses(np.zeros(n))
    masses = []
    for k in range(n):
        ma, mb = float(Ja[k, 3, 3]), float(Jb[k, 3, 3])
        off = None
        if ma > 0 and mb > 0:
            wa = Pa[k] @ (Ja[k, :, 3] / ma)
            wb = Pb[k] @ (Jb[k, :, 3] / mb)
            off = float(np.linalg.norm(wa[:3] - wb[:3]))
        masses.append({"link": k + 1, "name_a": ja[k].link_name or f"link{k + 1}",
                       "name_b": jb[k].link_name or f"link{k + 1}",
                       "mass_a": ma, "mass_b": mb, "diff": mb - ma, "com_offset": off})

    return CompareReport(
        a=a.name or "a", b=b.name or "b", n=n, joint_types=tuple(b.joint_types),
        samples=int(samples), seed=int(seed),
        fk_error=float(pos.max()), rot_error=float(rot.max()),
        base=best.base, tool=best.tool, joint_signs=best.signs,
        joint_offsets=np.array(best.offsets), dynamics=dyn, masses=masses,
        armature_a=np.array(a.armature, dtype=np.float64), armature_b=np.array(b.armature, dtype=np.float64),
        gravity_a=np.array(a.gravity, dtype=np.float64), gravity_used_a=g_in_a,
        candidates=len(cands), notes=notes,
    )
