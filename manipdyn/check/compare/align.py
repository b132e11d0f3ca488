"""Alignment and fitting: joint signs and offsets, base and tool (steps 2, 4, 5).

Layer 4 (checks: compare) (compare).

Flipping joint i's sign is ``J(-q) = F J(q) F`` with ``F = Rx(pi)``, and an
offset is ``J(q + o) = J(o) J(q)``.  Two canonical forms
(:mod:`manipdyn.check.compare.canonical`) give the same forward kinematics exactly
when every joint line of one maps onto the joint line of the other, i.e.
``W^b_i = H_i^-1 (F_i W^a_i J(o_i+1) F_i+1) H_i+1`` with ``H_i = Rz(phi_i) Tz(t_i)``
the freedom of a frame on its own axis (it commutes with the joint motion).

* ``(a, alpha)`` of each link's normal form must agree between the arms: this
  prunes the sign choices (:func:`sign_vectors`, depth-first).
* For one sign vector, the normal forms' angles give ``phi`` and the
  right-hand rotation of every link directly; their difference across a joint
  is the joint offset.  The translations ``t`` come from one small linear
  least-squares problem, which also handles parallel axes (only ``d + e`` is
  then defined) (:func:`solve_signs`).
* Candidates are scored by their forward kinematics; exact ties (kinematic
  symmetries such as the wrist flip) are told apart by the mass distribution
  (:func:`choose_alignment`).
* ``base`` and ``tool`` are refined by alternating closed-form Kabsch steps
  (orthogonal Procrustes on the tool origin and three points along the tool
  axes over all sampled states); each step cannot increase the squared error
  (:func:`refine`).

Gauge: joint 1's offset and a rotation of the base about joint 1's axis are
indistinguishable from the kinematics, as are the last joint's offset and a
rotation of the tool about the last axis: offset 0 is reported for those two
joints and the difference is put into ``base`` and ``tool``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..._support.errors import ModelError
from ...model.kinematics import rot_z, trans, transform_inverse
from .canonical import Chain, flip, split_link, wrap_angle
from .dynamics import dynamics_mismatch
from .report import ROT_TOLERANCE

__all__ = ["Alignment", "kabsch", "rotation_angle", "sign_vectors", "solve_signs", "mapped_fk",
           "pose_errors", "refine", "choose_alignment", "zero_small_offsets"]


@dataclass
class Alignment:
    """``T_b(q) = base @ T_a(signs * q + offsets) @ tool``; ``error`` its probe score (m)."""

    signs: tuple
    offsets: np.ndarray
    base: np.ndarray
    tool: np.ndarray
    error: float = math.inf


def kabsch(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Rigid transform X (4x4, det +1) minimising ``sum |X p_k - q_k|^2``; P, Q (k, 3)."""
    pc, qc = P.mean(axis=0), Q.mean(axis=0)
    H = (P - pc).T @ (Q - qc)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    X = np.eye(4)
    X[:3, :3] = R
    X[:3, 3] = qc - R @ pc
    return X


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) of rotation matrices (..., 3, 3), robust near 0 and pi."""
    tr = np.trace(R, axis1=-2, axis2=-1)
    w = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                  R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    return np.arctan2(np.linalg.norm(w, axis=-1), tr - 1.0)


def _link_invariants_ok(sv, sb, tol_len: float, tol_cos: float) -> bool:
    if (sv.kind == "skew") != (sb.kind == "skew"):
        return False
    if abs(sv.c - sb.c) > tol_cos:
        return False
    return abs(sv.a - sb.a) <= tol_len


def sign_vectors(ca: Chain, cb: Chain, scale: float, tol_len: float, tol_cos: float) -> list:
    """Sign vectors whose link invariants (a, alpha) all agree (depth-first, pruned)."""
    n = len(cb.revolute)
    splits_b = [split_link(cb.W[i + 1], scale) for i in range(n - 1)]
    out = []

    def dfs(prefix):
        k = len(prefix)
        if k == n:
            out.append(tuple(prefix))
            return
        for s in (1, -1):
            if k > 0:
                V = flip(prefix[-1]) @ ca.W[k] @ flip(s)
                if not _link_invariants_ok(split_link(V, scale), splits_b[k - 1], tol_len, tol_cos):
                    continue
            dfs(prefix + [s])

    dfs([])
    return out


def _frame_equations(ca: Chain, cb: Chain, signs, scale: float, idx_left, idx_right, nv):
    """Rotations phi (left) and rho (right) of every joint frame, and the rows of the
    least-squares problem for the translations along the axes."""
    n = len(signs)
    phi, rho = np.zeros(n), np.zeros(n)
    rows, rhs = [], []
    for i in range(n - 1):
        sv = split_link(flip(signs[i]) @ ca.W[i + 1] @ flip(signs[i + 1]), scale)
        sb = split_link(cb.W[i + 1], scale)
        phi[i] = sv.theta - sb.theta
        rho[i + 1] = sb.psi - sv.psi
        if sb.kind == "skew" and sv.kind == "skew":
            for col, value in ((idx_left[i], sv.d - sb.d), (idx_right[i + 1], sb.e - sv.e)):
                r = np.zeros(nv)
                r[col] = 1.0
                rows.append(r)
                rhs.append(value)
        else:
            r = np.zeros(nv)
            r[idx_left[i]] -= 1.0
            r[idx_right[i + 1]] += sb.c
            rows.append(r)
            rhs.append((sb.d - sv.d) + sb.c * (sb.e - sv.e))
    return phi, rho, rows, rhs


def solve_signs(ca: Chain, cb: Chain, signs, scale: float) -> Alignment:
    """Offsets, base and tool for one sign vector, in closed form."""
    n = len(signs)
    rev = cb.revolute
    # translation unknowns: left t_i for every joint; right tau_i = t_i except
    # for interior prismatic joints, which get their own variable
    idx_left, idx_right, nv = list(range(n)), list(range(n)), n
    for i in range(1, n - 1):
        if not rev[i]:
            idx_right[i] = nv
            nv += 1
    phi, rho, rows, rhs = _frame_equations(ca, cb, signs, scale, idx_left, idx_right, nv)
    x = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0] if rows else np.zeros(nv)
    t_left, t_right = x[idx_left], x[idx_right]
    offsets = np.zeros(n)
    for i in range(1, n - 1):
        offsets[i] = (wrap_angle(signs[i] * (rho[i] - phi[i])) if rev[i]
                      else signs[i] * (t_right[i] - t_left[i]))
    H0 = rot_z(phi[0]) @ trans(0.0, 0.0, t_left[0]) if n > 1 else np.eye(4)
    Hn = rot_z(rho[n - 1]) @ trans(0.0, 0.0, t_right[n - 1]) if n > 1 else np.eye(4)
    base = cb.W[0] @ transform_inverse(H0) @ flip(signs[0]) @ transform_inverse(ca.W[0])
    tool = transform_inverse(flip(signs[n - 1]) @ ca.W[n]) @ Hn @ cb.W[n]
    return Alignment(tuple(int(s) for s in signs), offsets, base, tool)


def mapped_fk(arm_a, al: Alignment, q: np.ndarray) -> np.ndarray:
    """``base @ T_a(signs * q + offsets) @ tool`` for b's joint states q (N, n): (N, 4, 4)."""
    qa = np.asarray(al.signs) * q + al.offsets
    return al.base @ arm_a.fkine(qa) @ al.tool


def pose_errors(Tb: np.ndarray, Tm: np.ndarray):
    """Position (m) and orientation (rad) errors between two batches of poses."""
    pos = np.linalg.norm(Tb[..., :3, 3] - Tm[..., :3, 3], axis=-1)
    rot = rotation_angle(np.swapaxes(Tm[..., :3, :3], -1, -2) @ Tb[..., :3, :3])
    return pos, rot


def zero_small_offsets(al: Alignment) -> Alignment:
    """Offsets below :data:`ROT_TOLERANCE` (rad or m) become exactly 0 (rounding noise)."""
    al.offsets = np.where(np.abs(al.offsets) < ROT_TOLERANCE, 0.0, al.offsets)
    return al


def refine(arm_a, Tb: np.ndarray, q: np.ndarray, al: Alignment, scale: float, iters: int = 20):
    """Alternating closed-form (Kabsch) steps on base and tool."""
    A = arm_a.fkine(np.asarray(al.signs) * q + al.offsets)
    E = np.array([[0.0, 0.0, 0.0, 1.0], [scale, 0, 0, 1], [0, scale, 0, 1], [0, 0, scale, 1]]).T  # (4, 4)
    Pb = (Tb @ E)[:, :3, :].transpose(0, 2, 1).reshape(-1, 3)

    def cost(X, Y):
        Pm = (X @ A @ Y @ E)[:, :3, :].transpose(0, 2, 1).reshape(-1, 3)
        return float(np.sum((Pm - Pb) ** 2))

    X, Y = al.base, al.tool
    best = cost(X, Y)
    for _ in range(iters):
        Pa = (A @ Y @ E)[:, :3, :].transpose(0, 2, 1).reshape(-1, 3)
        X = kabsch(Pa, Pb)
        Z = (transform_inverse(A) @ transform_inverse(X) @ Tb @ E)[:, :3, :].transpose(0, 2, 1).reshape(-1, 3)
        Y = kabsch(np.tile(E[:3].T, (len(q), 1)), Z)
        c = cost(X, Y)
        if c < best * (1.0 - 1e-12):
            best = c
            al.base, al.tool = X, Y
        else:
            break
    return al


def _break_ties(a, b, close: list, q_probe: np.ndarray, notes: list) -> Alignment:
    """Among alignments that fit the kinematics equally, the one the masses favour.

    Kinematic symmetries (the wrist flip (q5 + pi, -q6), a flip of joint 1
    with the base, ...) give several exact alignments that put the links'
    bodies in different places.  Keep those whose dynamics match within 10x of
    the best, then prefer the fewest flipped joints and the smallest offsets.
    """
    def convention(c):
        return sum(1 for s in c.signs if s < 0), float(np.sum(np.abs(c.offsets)))

    mism = [dynamics_mismatch(a, b, c, q_probe[:8]) for c in close]
    m0 = min(mism)
    kept = [(c, m) for c, m in zip(close, mism) if m <= max(10.0 * m0, m0 + 1e-9)]
    best = min((c for c, _ in kept), key=convention)
    if len(kept) > 1 and max(m for _, m in kept) > m0 + 1e-9:
        notes.append(f"{len(close) - 1} other joint-sign/offset assignments fit the kinematics equally "
                     "well (kinematic symmetries such as the wrist flip); they place the links' masses "
                     f"differently, but {len(kept) - 1} of them match the dynamics about as well as this "
                     "one, which was chosen for the fewest flipped joints and the smallest offsets")
    return best


def choose_alignment(a, b, ca: Chain, cb: Chain, q: np.ndarray, Tb: np.ndarray, scale: float):
    """The best alignment of a onto b on b's states q (N, n) with tool poses Tb (N, 4, 4).

    Returns ``(alignment, candidates scored, notes)``; the alignment is
    refined, with offsets below tolerance set to 0.
    """
    n = len(cb.revolute)
    q_probe, Tb_probe = q[: min(len(q), 16)], Tb[: min(len(q), 16)]
    notes: list[str] = []
    signs = sign_vectors(ca, cb, scale, tol_len=1e-3 * scale, tol_cos=1e-3)
    if not signs:
        if n > 12:
            raise ModelError(f"compare: no joint-sign assignment makes the link geometry of {a.name!r} "
                             f"and {b.name!r} agree, and {n} joints are too many to try them all")
        signs = [tuple(1 if (k >> i) & 1 == 0 else -1 for i in range(n)) for k in range(2 ** n)]
        notes.append("no joint-sign assignment makes every link's geometry (twist angle and length "
                     "between consecutive axes) agree; the best of all 2^n assignments is shown")
    cands = []
    for s in signs:
        c = solve_signs(ca, cb, s, scale)
        pos, rot = pose_errors(Tb_probe, mapped_fk(a, c, q_probe))
        c.error = float(max(pos.max(), rot.max() * scale))
        cands.append(c)
    best_err = min(c.error for c in cands)
    close = [c for c in cands if c.error <= best_err + 1e-9 * scale]
    best = _break_ties(a, b, close, q_probe, notes) if len(close) > 1 else close[0]
    best = refine(a, Tb, q, zero_small_offsets(best), scale)
    return best, len(cands), notes
