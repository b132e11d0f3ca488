"""The RNEA's derivatives as a recursion over the chain (Carpentier and Mansard, RSS 2018), in SX.

Layer 3 (engines: c), the generated-C engine.  :func:`rnea_derivatives` writes
``d tau / d q`` and ``d tau / d qd`` of :meth:`ArmGraph.rnea
<manipdyn.engines.c.graph.ArmGraph.rnea>` (plus the rotors, which depend on
neither, and the friction law, on ``qd`` only) as one forward and one backward
pass over the link frames, then an ``O(n^2)`` table of 6-vector dot products;
:func:`derivative_route` builds it and the reverse-mode Jacobian of the unrolled
RNEA and keeps the one with fewer operations.  The derivation is written out in
ARCHITECTURE.md ("Generated C: the RNEA derivatives"); in short, with every
spatial quantity in one frame (the formulas hold in any: each is written in the
frame of its link, and the table's forces are carried between them), ``S_j`` joint j's
axis, ``v_j``, ``a_j`` (gravity as the base's acceleration ``-g``) the link's
velocity and acceleration, ``Sd_j = v_(j-1) x S_j``, ``Yc_j``, ``F_j``, ``Hc_j``
the composite inertia, force and momentum of links j..n, and ``DYc_j`` the sum
over links j..n of ``dY_k/dt + B(h_k)`` (``B(h) m = m x* h``)::

    dAq_j = a_(j-1) x S_j + v_(j-1) x Sd_j
    dFq_j = S_j x* F_j + Yc_j dAq_j + DYc_j Sd_j,   dFv_j = Yc_j (2 Sd_j) + DYc_j S_j
    i <= j:  dtau_i/dq_j = S_i . dFq_j,   dtau_i/dqd_j = S_i . dFv_j
    i >  j:  dtau_i/dq_j = (Yc_i S_i) . dAq_j + (DYc_i^T S_i) . Sd_j
             dtau_i/dqd_j = (Yc_i S_i) . 2 Sd_j + (DYc_i^T S_i) . S_j

``dY_k/dt`` of a rigid body is again of the inertia form, with mass rate 0,
first moment rate ``m vo + w x h`` and rotational rate ``[w]x I - I [w]x +
2 (h . vo) 1 - vo h^T - h vo^T`` (``(w, vo) = v_k``), so that ``DYc_j`` is a
sum of 9 numbers per link plus ``B(Hc_j)``.
"""

from __future__ import annotations

from .emit import has_cse
from .spatial import Body, add as _add, cross as _cross, mtv as _mtv, mv as _mv
from .spatial import scale as _scale, sub as _sub

__all__ = ["rnea_derivatives", "derivative_route", "jacobian_rows", "count_operations", "ROUTES"]

#: the two ways the generated C can hold ``d tau / d (q, qd)``
ROUTES = ("recursive", "reverse")


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def _mcross(m1, m2):
    """Motion cross motion: ``(w1 x w2, w1 x v2 + v1 x w2)``."""
    (w1, v1), (w2, v2) = m1, m2
    return _cross(w1, w2), _add(_cross(w1, v2), _cross(v1, w2))


def _fcross(m, f):
    """Motion cross force: ``(w x n + v x f, w x f)``."""
    (w, v), (n, fl) = m, f
    return _add(_cross(w, n), _cross(v, fl)), _cross(w, fl)


def _madd(a, b):
    return _add(a[0], b[0]), _add(a[1], b[1])


def _mscale(s, a):
    return _scale(s, a[0]), _scale(s, a[1])


def _sdot(m, f):
    """Motion . force (both 6-vectors as pairs of 3-vectors)."""
    return _dot(m[0], f[0]) + _dot(m[1], f[1])


def _rate(body, w, vo):
    """``dY/dt`` of ``body`` moving at ``(w, vo)``: of the inertia form, a :class:`Body` of mass 0
    with first moment ``m vo + w x h`` and rotational part ``[w]x I - I [w]x + 2 (h . vo) 1
    - vo h^T - h vo^T``."""
    h = _add(_scale(body.m, vo), _cross(w, body.h))
    wI = [_cross(w, [body.I[0][c], body.I[1][c], body.I[2][c]]) for c in range(3)]   # columns of [w]x I
    hv = _dot(body.h, vo)
    # [w]x I - I [w]x = [w]x I + ([w]x I)^T (I symmetric, [w]x skew)
    out = Body([0.0] * 10)
    out.h = h
    out.I = [[None] * 3 for _ in range(3)]
    for r in range(3):
        for c in range(r, 3):                                         # symmetric: one triangle, mirrored
            out.I[r][c] = out.I[c][r] = (wI[c][r] + wI[r][c] + (2.0 * hv if r == c else 0.0)
                                         - vo[r] * body.h[c] - body.h[r] * vo[c])
    return out


def _motion_in(E, p, m):
    """Motion ``m`` of the parent frame seen in the child's (child -> parent by ``E``, origin ``p``)."""
    w, v = m
    return _mtv(E, w), _mtv(E, _add(v, _cross(w, p)))


def _force_out(E, p, f):
    """Force ``f`` of the child frame seen in the parent's."""
    n, fl = f
    Ef = _mv(E, fl)
    return _add(_mv(E, n), _cross(p, Ef)), Ef


def _motion_out(E, p, m):
    """Motion ``m`` of the child frame seen in the parent's."""
    Ew = _mv(E, m[0])
    return Ew, _add(_mv(E, m[1]), _cross(p, Ew))


def rnea_derivatives(g, pi, qd, qdd, gravity=True):
    """``(dtau_dq, dtau_dqd)`` of the rigid-body RNEA of :class:`ArmGraph` ``g`` (parameters
    ``pi``, velocities ``qd``, accelerations ``qdd``: SX or numbers), n x n nested lists,
    ``[i][m] = d tau_i / d x_m`` (module docstring).  Rotors and friction are not in it.

    Everything runs in the link frames, where the axes and the bodies are constants: the
    table's forces are carried from frame to frame down the chain, and ``S_i . F`` is then
    one entry of ``F`` (or two, for an axis off the frame's axes)."""
    n = g.n
    kin = g.joint_transforms()
    bodies = g.bodies(pi)
    zero = [0.0, 0.0, 0.0]
    v = (zero, zero)
    a = (zero, [-float(x) for x in g.gravity] if gravity else zero)
    S, Sd, dAq, f, D, H = [], [], [], [], [], []
    for k in range(n):
        E, p = kin[k]
        s = g.subspace(k)
        vp, ap = _motion_in(E, p, v), _motion_in(E, p, a)
        sd = _mcross(vp, s)
        dAq.append(_madd(_mcross(ap, s), _mcross(vp, sd)))
        v = _madd(vp, _mscale(qd[k], s))
        a = _madd(_madd(ap, _mscale(qdd[k], s)), _mscale(qd[k], sd))
        h = bodies[k].times(*v)
        f.append(_madd(bodies[k].times(*a), _fcross(v, h)))
        S.append(s)
        Sd.append(sd)
        H.append(h)
        D.append(_rate(bodies[k], v[0], v[1]))
    # composites of links k..n, in frame k
    Y = list(bodies)
    for k in reversed(range(n - 1)):
        E, p = kin[k + 1]
        Y[k] = Y[k].plus(Y[k + 1].to_parent(E, p))
        D[k] = D[k].plus(D[k + 1].to_parent(E, p))
        f[k] = _madd(f[k], _force_out(E, p, f[k + 1]))
        H[k] = _madd(H[k], _force_out(E, p, H[k + 1]))
    # per joint, in frame j: the columns' forces (i <= j) and the rows' forces (i > j)
    cols, rows = [], []
    for j in range(n):
        dS = D[j].times(*S[j])
        bS = _fcross(S[j], H[j])
        dFq = _madd(_madd(_fcross(S[j], f[j]), Y[j].times(*dAq[j])),
                    _madd(D[j].times(*Sd[j]), _fcross(Sd[j], H[j])))
        dFv = _madd(Y[j].times(*_mscale(2.0, Sd[j])), _madd(dS, bS))
        cols.append((dFq, dFv))
        rows.append((Y[j].times(*S[j]), (_sub(dS[0], bS[0]), _sub(dS[1], bS[1]))))   # DYc^T S = D S - S x* Hc
    # the table: each force carried down the chain one frame at a time (S_i is an axis there)
    dq = [[None] * n for _ in range(n)]
    dv = [[None] * n for _ in range(n)]
    for j in range(n):
        Fq, Fv = cols[j]
        for i in range(j, -1, -1):
            if i < j:
                Fq, Fv = _force_out(*kin[i + 1], Fq), _force_out(*kin[i + 1], Fv)
            dq[i][j] = _sdot(S[i], Fq)
            dv[i][j] = _sdot(S[i], Fv)
    for i in range(n):
        rY, rD = rows[i]
        for j in range(i - 1, -1, -1):
            rY, rD = _force_out(*kin[j + 1], rY), _force_out(*kin[j + 1], rD)
            dq[i][j] = _sdot(dAq[j], rY) + _sdot(Sd[j], rD)
            dv[i][j] = 2.0 * _sdot(Sd[j], rY) + _sdot(S[j], rD)
    return dq, dv


def count_operations(ca, inputs, outputs) -> int:
    """Arithmetic operations of the C :mod:`manipdyn.engines.c.emit` would write for
    ``outputs`` (SX) of ``inputs`` (SX symbols): CasADi's instructions after common
    subexpression elimination, less reads, writes, constants and copies."""
    f = ca.Function("count", list(inputs), [ca.densify(o) for o in outputs], {"cse": True} if has_cse(ca) else {})
    skip = {ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST, ca.OP_ASSIGN}
    return sum(f.instruction_id(k) not in skip for k in range(f.n_instructions()))


def derivative_route(g, num, tau, fr, qdd=None, route=None):
    """``(route, dtau_dq, dtau_dqd)`` (SX, n x n) of :class:`ArmGraph` ``g``: ``tau`` the full
    torque (SX column: rigid + rotors + friction at the symbols ``g.qdd``), ``fr`` the friction
    torques (list), ``num`` the parameters; evaluated at ``qdd`` (a list of SX, default the
    symbols).  ``route`` None builds both of :data:`ROUTES` and keeps the one with fewer
    operations (:func:`count_operations`); a name forces that one."""
    ca, q, qd, n = g.ca, g.q, g.qd, g.n
    if route not in (None,) + ROUTES:
        raise ValueError(f"route: expected one of {ROUTES} or None, got {route!r}")

    def recursive():
        dq, dv = rnea_derivatives(g, num, qd, g.qdd if qdd is None else qdd)
        dfr = ca.jacobian(ca.vertcat(*[ca.SX(x) for x in fr]), qd)
        DQ, DV = ca.SX(n, n), ca.SX(n, n)
        for i in range(n):
            for m in range(n):
                DQ[i, m] = dq[i][m]
                DV[i, m] = dv[i][m] + dfr[i, m]
        return DQ, DV

    def reverse():
        DQ, DV = jacobian_rows(ca, tau, q, qd)
        if qdd is None:
            return DQ, DV
        return tuple(ca.Function("dtau", [q, qd, g.qdd], [DQ, DV])(q, qd, ca.vertcat(*qdd)))

    if route is not None:
        return (route,) + (recursive() if route == "recursive" else reverse())
    rec, rev = recursive(), reverse()
    ins = [q, qd, g.qdd, g.tau_in]
    if count_operations(ca, ins, list(rec)) <= count_operations(ca, ins, list(rev)):
        return ("recursive",) + rec
    return ("reverse",) + rev


def jacobian_rows(ca, f, *xs):
    """``[d f / d x for x in xs]`` (each len(f) x len(x)) by reverse mode, one adjoint sweep per
    output row: on an RNEA (n outputs, 2n inputs) the generated code has a quarter fewer
    operations than ``casadi.jacobian``'s choice (Panda: 7.4k against 9.7k for dtau/dq, dtau/dqd)."""
    x = ca.vertcat(*xs)
    m = f.shape[0]
    rows = ca.vertcat(*[ca.jtimes(f, x, ca.DM.eye(m)[:, i], True).T for i in range(m)])
    out, start = [], 0
    for xi in xs:
        out.append(rows[:, start:start + xi.shape[0]])
        start += xi.shape[0]
    return out
