"""The arm's dynamics as CasADi SX graphs: recursive Newton-Euler, CRBA, an unrolled LDL^T.

Layer 3 (engines: c), the generated-C engine.  Shares no code with the trace form
(:mod:`manipdyn.engines.lagrange`) or with the Pinocchio engine: it reads the model's
public data only (:meth:`manipdyn.Arm.chain`, ``arm.gravity``,
``arm.transmission.R``, ``arm.motor_inertia``, ``arm.friction_model`` and
:meth:`manipdyn.Arm.parameters`) and writes the algorithms out once more.

Conventions.  Every link quantity is expressed in its URDF link frame (the
frame of :meth:`manipdyn.Arm.chain`): spatial motion vectors ``(omega, v)``
with ``v`` the velocity of the frame's origin, spatial forces ``(n, f)``
about the origin.  Joint j maps parent to child by ``E_j = R_origin Rot(axis,
q_j)`` (rotation child -> parent) and ``p_j`` (child origin in the parent
frame).  Gravity enters as the base's acceleration ``-g``.  Each link's 10
inertial parameters are those of :mod:`manipdyn.model.parameters` (about the URDF
frame's origin, tensor sign), here symbols ``pi`` so that the regressor is
``d tau / d pi``; the numbers are substituted (folded) for every other
function.

Rounding residue.  Rotations written from ``rpy`` angles such as pi/2 hold
entries like ``cos(pi/2) = 6.1e-17``: not a property of the arm but the
rounding error of a zero.  Entries of joint origins, axes and the tool
transform under :data:`~manipdyn.engines.c.spatial.SNAP` (1e-15, below float64's resolution of a unit
rotation entry, 2.2e-16 ulp, by a few units, and a femtometre for
translations) are folded as exact zeros, so that CasADi removes the products
they would feed (on the Panda's URDF this halves the derivatives' operations).
The change is within the rounding of the numbers themselves.

What the graph cannot express is refused by name (:class:`ModelError`): a
friction term this module does not know, a joint that is neither revolute nor
prismatic.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError
from ...model.friction import Friction
from ...model.parameters import parameter_names
from .derivatives import derivative_route
from .spatial import Body as _Body, add as _add, cross as _cross, matmul3 as _matmul3, mtv as _mtv, mv as _mv
from .spatial import scale as _scale, snap as _snap

__all__ = ["ArmGraph", "KNOWN_FRICTION_TERMS"]

#: the friction terms the generated C writes out (:mod:`manipdyn.model.friction`)
KNOWN_FRICTION_TERMS = ("viscous", "coulomb", "asymmetric", "offset", "stribeck", "sigmoid")


def _ca():
    from .deps import casadi

    return casadi()


def _rotation(ca, axis, c, s):
    """Rot(axis, angle) from its cosine and sine (Rodrigues), nested lists."""
    x, y, z = (float(a) for a in axis)
    t = 1.0 - c
    return [[c + t * x * x, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, c + t * y * y, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, c + t * z * z]]


class ArmGraph:
    """The SX expressions of one arm's dynamics (module docstring).

    Attributes after construction: ``n``, ``p`` (regressor columns), ``q``,
    ``qd``, ``qdd``, ``tau_in`` (SX symbols (n,)), ``param_names`` (p,),
    ``pi`` (p,) the numbers folded in.
    """

    def __init__(self, arm):
        ca = self.ca = _ca()
        where = arm.name or "arm"
        joints, tool = arm.chain()
        self.n = n = len(joints)
        if n != arm.n:
            raise ModelError(f"{where}: the chain has {n} joints, the arm {arm.n}")
        for j in joints:
            if j.joint not in ("revolute", "prismatic"):
                raise ModelError(f"{where}: joint {j.name!r} of type {j.joint!r} cannot be generated as C "
                                 "(revolute and prismatic only)")
        self.joints, self.tool = joints, np.asarray(tool, dtype=np.float64)
        self.gravity = np.asarray(arm.gravity, dtype=np.float64)
        R = np.asarray(arm.transmission.R, dtype=np.float64)
        if R.shape != (n, n):
            raise ModelError(f"{where}: the transmission's R has shape {R.shape}, expected ({n}, {n})")
        self.R = R
        self.Jm = np.asarray(arm.motor_inertia, dtype=np.float64)
        law = arm.friction_model
        if law is not None:
            if not isinstance(law, Friction):
                raise ModelError(f"{where}: the friction model {type(law).__name__} cannot be generated as C "
                                 "(a manipdyn.Friction only)")
            unknown = [t for t in law.terms if t not in KNOWN_FRICTION_TERMS]
            if unknown:
                raise ModelError(f"{where}: the friction term(s) {unknown} cannot be generated as C "
                                 f"(known: {', '.join(KNOWN_FRICTION_TERMS)})")
            if law.n != n:
                raise ModelError(f"{where}: the friction law is for {law.n} actuators, the arm has {n} joints")
        self.law = law
        self.pi = np.asarray(arm.parameters(armature=True, friction=law if law is not None else False),
                             dtype=np.float64)
        self.param_names = parameter_names(n, armature=True, friction=law if law is not None else False)
        self.p = len(self.pi)
        if self.pi.shape != (self.p,) or not np.all(np.isfinite(self.pi)):
            raise ModelError(f"{where}: the parameter vector is not finite, or not as long as its names")
        self.q = ca.SX.sym("q", n)
        self.qd = ca.SX.sym("qd", n)
        self.qdd = ca.SX.sym("qdd", n)
        self.tau_in = ca.SX.sym("tau", n)
        self.pi_sym = ca.SX.sym("pi", self.p)
        self._kin = None
        #: the derivatives' route (:data:`manipdyn.engines.c.derivatives.ROUTES`), None: the shorter
        self.route = None
        #: the route each derivative function was built by, after :meth:`functions`
        self.routes = {}

    # -- pieces -------------------------------------------------------------------
    def joint_transforms(self):
        """Per joint ``(E, p)``: rotation child -> parent and the child origin in the parent (SX)."""
        if self._kin is None:
            ca, out = self.ca, []
            for k, j in enumerate(self.joints):
                origin, axis = _snap(j.origin), _snap(j.axis)
                Ro = [[float(origin[r, c]) for c in range(3)] for r in range(3)]
                po = [float(origin[r, 3]) for r in range(3)]
                if j.joint == "revolute":
                    E = _matmul3(Ro, _rotation(ca, axis, ca.cos(self.q[k]), ca.sin(self.q[k])))
                    p = po
                else:
                    E = Ro
                    p = _add(po, _scale(self.q[k], _mv(Ro, [float(a) for a in axis])))
                out.append((E, p))
            self._kin = out
        return self._kin

    def bodies(self, pi):
        return [_Body([pi[10 * k + i] for i in range(10)]) for k in range(self.n)]

    def subspace(self, k):
        """Joint k's motion subspace in its link frame, ``(angular, linear)`` 3-vectors of floats."""
        a = [float(x) for x in _snap(self.joints[k].axis)]
        z = [0.0, 0.0, 0.0]
        return (a, z) if self.joints[k].joint == "revolute" else (z, a)

    def rnea(self, pi, qd, qdd, gravity=True):
        """Rigid-body torques (no rotors, no friction): a list of n SX."""
        kin, bodies, n = self.joint_transforms(), self.bodies(pi), self.n
        zero = [0.0, 0.0, 0.0]
        w, v = zero, zero
        aw, av = zero, ([-float(x) for x in self.gravity] if gravity else zero)
        forces = []
        for k in range(n):
            E, p = kin[k]
            sw, sv = self.subspace(k)
            # velocity: X v_parent + S qd
            wc = _mtv(E, w)
            vc = _mtv(E, _add(v, _cross(w, p)))
            awc = _mtv(E, aw)
            avc = _mtv(E, _add(av, _cross(aw, p)))
            w = _add(wc, _scale(qd[k], sw))
            v = _add(vc, _scale(qd[k], sv))
            # acceleration: X a_parent + S qdd + v x (S qd)
            jw, jv = _scale(qd[k], sw), _scale(qd[k], sv)
            aw = _add(_add(awc, _scale(qdd[k], sw)), _cross(w, jw))
            av = _add(_add(avc, _scale(qdd[k], sv)), _add(_cross(w, jv), _cross(v, jw)))
            # f = I a + v x* (I v)
            Iw, Iv = bodies[k].times(w, v)
            Ia_n, Ia_f = bodies[k].times(aw, av)
            fn = _add(Ia_n, _add(_cross(w, Iw), _cross(v, Iv)))
            ff = _add(Ia_f, _cross(w, Iv))
            forces.append([fn, ff])
        tau = [None] * n
        for k in reversed(range(n)):
            fn, ff = forces[k]
            sw, sv = self.subspace(k)
            tau[k] = sum(sw[i] * fn[i] + sv[i] * ff[i] for i in range(3))
            if k > 0:
                E, p = kin[k]
                Ef = _mv(E, ff)
                pn, pf = forces[k - 1]
                forces[k - 1] = [_add(pn, _add(_mv(E, fn), _cross(p, Ef))), _add(pf, Ef)]
        return tau

    def crba(self, pi):
        """The rigid-body mass matrix by composite inertias: n x n nested lists of SX."""
        kin, n = self.joint_transforms(), self.n
        comp = self.bodies(pi)
        for k in reversed(range(1, n)):
            E, p = kin[k]
            comp[k - 1] = comp[k - 1].plus(comp[k].to_parent(E, p))
        M = [[None] * n for _ in range(n)]
        for j in range(n):
            sw, sv = self.subspace(j)
            fn, ff = comp[j].times(sw, sv)
            for i in range(j, -1, -1):
                if i < j:
                    E, p = kin[i + 1]
                    Ef = _mv(E, ff)
                    fn, ff = _add(_mv(E, fn), _cross(p, Ef)), Ef
                si_w, si_v = self.subspace(i)
                M[i][j] = M[j][i] = sum(si_w[r] * fn[r] + si_v[r] * ff[r] for r in range(3))
        return M

    def rotor_torque(self, pi, qdd):
        """``R^T diag(Jm) R qdd`` with motor k's reflected inertia ``pi_a,k = R_kk^2 Jm_k``."""
        n, R = self.n, self.R
        out = [0.0] * n
        for k in range(n):
            Jk = pi[10 * n + k] / float(R[k, k] ** 2)
            vk = sum(float(R[k, c]) * qdd[c] for c in range(n) if R[k, c] != 0.0)
            for j in range(n):
                if R[k, j] != 0.0:
                    out[j] = out[j] + float(R[k, j]) * Jk * vk
        return out

    def _sigma(self, v):
        ca, law = self.ca, self.law
        s = ca.tanh(v / law.smoothing) if law.smoothing else ca.sign(v)
        return ca.if_else(ca.fabs(v) > law.deadband, s, 0.0) if law.deadband else s

    def friction(self, pi, qd):
        """The friction law at the joints (:mod:`manipdyn.model.friction`), parameters from ``pi``."""
        n, law, ca = self.n, self.law, self.ca
        if law is None:
            return [0.0] * n
        R = self.R if law.side == "motor" else None
        vel = [sum(float(R[k, c]) * qd[c] for c in range(n) if R[k, c] != 0.0) if R is not None else qd[k]
               for k in range(n)]
        col = 10 * n + n
        tm = [0.0] * n
        off = [0.0] * n
        for t in law.terms:
            for b in range(2 if t == "asymmetric" else 1):
                for k in range(n):
                    v = vel[k]
                    x = pi[col + k]
                    if R is not None and t != "offset":
                        x = x / float(R[k, k] ** 2 if t == "viscous" else abs(R[k, k]))
                    if t == "viscous":
                        f = v
                    elif t == "coulomb":
                        f = self._sigma(v)
                    elif t == "asymmetric":
                        f = ca.fmax(self._sigma(v), 0.0) if b == 0 else ca.fmin(self._sigma(v), 0.0)
                    elif t == "stribeck":
                        vs, e = float(law.stribeck_velocity[k]), float(law.stribeck_exponent)
                        a = ca.fabs(v / vs)
                        # |v/vs|^e guarded at v == 0 (its derivative there is 0 * inf otherwise)
                        ae = ca.if_else(a > 0, a ** e, 0.0)
                        f = ca.exp(-ae) * self._sigma(v)
                    elif t == "sigmoid":
                        al, p3 = float(law.sigmoid_alpha[k]), float(law.sigmoid_p3[k])
                        f = 1.0 / (1.0 + ca.exp(-al * (v + p3))) - 1.0 / (1.0 + np.exp(-al * p3))
                    else:                                                    # offset, a joint torque
                        off[k] = off[k] + x
                        continue
                    tm[k] = tm[k] + x * f
                col += n
        if R is None:
            return [tm[j] + off[j] for j in range(n)]
        return [sum(float(R[k, j]) * tm[k] for k in range(n) if R[k, j] != 0.0) + off[j] for j in range(n)]

    def tool_pose(self):
        """The tool frame's pose in the base frame, 4x4 nested lists."""
        Rb = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        pb = [0.0, 0.0, 0.0]
        for E, p in self.joint_transforms():
            pb = _add(pb, _mv(Rb, p))
            Rb = _matmul3(Rb, E)
        T = _snap(self.tool)
        pt = _add(pb, _mv(Rb, [float(T[r, 3]) for r in range(3)]))
        Rt = _matmul3(Rb, [[float(T[r, c]) for c in range(3)] for r in range(3)])
        return [Rt[r] + [pt[r]] for r in range(3)] + [[0.0, 0.0, 0.0, 1.0]]

    def potential(self, pi):
        """``P = -sum_j g . (p_j + R_j h_j)`` (J), zero at the base origin's height."""
        Rb = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        pb = [0.0, 0.0, 0.0]
        P = 0.0
        for (E, p), body in zip(self.joint_transforms(), self.bodies(pi)):
            pb = _add(pb, _mv(Rb, p))
            Rb = _matmul3(Rb, E)
            first = _add(_scale(body.m, pb), _mv(Rb, body.h))
            P = P - sum(float(self.gravity[i]) * first[i] for i in range(3))
        return P

    # -- the functions the C gets ------------------------------------------------------
    def functions(self, derivatives: bool = True):
        """``[(name, [(arg name, SX)], [SX outputs (dense column vectors, row-major data)])]``."""
        ca, n = self.ca, self.n
        q, qd, qdd, tau_in = self.q, self.qd, self.qdd, self.tau_in
        num = [float(x) for x in self.pi]
        zeros = [0.0] * n
        V = lambda xs: ca.vertcat(*[ca.SX(x) for x in xs])                       # noqa: E731

        def rowmajor(rows):
            return ca.vertcat(*[ca.SX(x) for r in rows for x in r])

        rigid = self.rnea(num, qd, qdd)
        rot = self.rotor_torque(num, qdd)
        fr = self.friction(num, qd)
        tau = V([a + b + c for a, b, c in zip(rigid, rot, fr)])
        grav = V(self.rnea(num, zeros, zeros))
        cor = V(self.rnea(num, qd, zeros, gravity=False))
        nle = V([a + b for a, b in zip(self.rnea(num, qd, zeros), fr)])
        Mrb = self.crba(num)
        Rt = self.R.T @ np.diag(self.Jm) @ self.R
        Mx = [[Mrb[i][j] + float(Rt[i, j]) if Rt[i, j] != 0.0 else Mrb[i][j] for j in range(n)] for i in range(n)]
        M = ca.SX(n, n)
        for i in range(n):
            for j in range(n):
                M[i, j] = Mx[i][j]
        factor = _ldlt_factor(Mx)
        qdd_fd = _ldlt_solve(Mx, [tau_in[k] - nle[k] for k in range(n)], factor)
        out = [
            ("inverse_dynamics", [("q", q), ("qd", qd), ("qdd", qdd)], [tau]),
            ("mass_matrix", [("q", q)], [rowmajor(Mx)]),
            ("gravity", [("q", q)], [grav]),
            ("nonlinear_effects", [("q", q), ("qd", qd)], [nle]),
            ("forward_dynamics", [("q", q), ("qd", qd), ("tau", tau_in)], [V(qdd_fd)]),
            ("coriolis", [("q", q), ("qd", qd)], [cor]),
            ("friction", [("qd", qd)], [V(fr)]),
            ("tool_pose", [("q", q)], [rowmajor(self.tool_pose())]),
            ("potential_energy", [("q", q)], [V([self.potential(num)])]),
        ]
        if derivatives:
            # d tau/d(q, qd) by the recursion or the reverse-mode Jacobian, whichever is shorter
            # (manipdyn.engines.c.derivatives); self.routes records the choice per function
            route, dtau_dq, dtau_dqd = derivative_route(self, num, tau, fr, route=self.route)
            # forward dynamics' derivatives: d qdd/dx = -M^-1 d tau/dx at qdd = FD(q, qd, tau), d qdd/d tau = M^-1
            fd_route, *at_fd = derivative_route(self, num, tau, fr, qdd=qdd_fd, route=self.route or route)
            self.routes = {"inverse_dynamics_derivatives": route, "forward_dynamics_derivatives": fd_route}
            Minv = _ldlt_inverse(factor)
            fdd = [rowmajor([[-sum(Minv[i][k] * J[k, m] for k in range(n)) for m in range(n)] for i in range(n)])
                   for J in at_fd]
            sym_tau = V([a + b + c for a, b, c in zip(self.rnea(self.pi_sym, qd, qdd),
                                                       self.rotor_torque(self.pi_sym, qdd),
                                                       self.friction(self.pi_sym, qd))])
            out += [
                ("inverse_dynamics_derivatives", [("q", q), ("qd", qd), ("qdd", qdd)],
                 [ca.vec(dtau_dq.T), ca.vec(dtau_dqd.T)]),
                ("forward_dynamics_derivatives", [("q", q), ("qd", qd), ("tau", tau_in)],
                 fdd + [rowmajor(Minv)]),
                ("regressor", [("q", q), ("qd", qd), ("qdd", qdd)], [ca.vec(ca.jacobian(sym_tau, self.pi_sym).T)]),
                ("gravity_derivative", [("q", q)], [ca.vec(ca.jacobian(grav, q).T)]),
                ("friction_derivative", [("qd", qd)], [ca.vec(ca.jacobian(V(fr), qd).T)]),
                ("coriolis_matrix", [("q", q), ("qd", qd)], [ca.vec(_christoffel(ca, M, q, qd).T)]),
            ]
        return out


def _ldlt_factor(M):
    """``(L, d)`` with ``M = L diag(d) L^T`` (L unit lower triangular) of the symmetric n x n ``M``."""
    n = len(M)
    L = [[0.0] * n for _ in range(n)]
    d = [None] * n
    for j in range(n):
        dj = M[j][j]
        for k in range(j):
            dj = dj - L[j][k] * L[j][k] * d[k]
        d[j] = dj
        for i in range(j + 1, n):
            s = M[i][j]
            for k in range(j):
                s = s - L[i][k] * L[j][k] * d[k]
            L[i][j] = s / dj
    return L, d


def _ldlt_solve(M, b, factor=None):
    """x with ``M x = b`` by an unrolled LDL^T of the symmetric n x n ``M`` (nested lists of SX)."""
    n = len(b)
    L, d = factor if factor is not None else _ldlt_factor(M)
    y = list(b)
    for i in range(n):
        for k in range(i):
            y[i] = y[i] - L[i][k] * y[k]
    x = [y[i] / d[i] for i in range(n)]
    for i in reversed(range(n)):
        for k in range(i + 1, n):
            x[i] = x[i] - L[k][i] * x[k]
    return x


def _ldlt_inverse(factor):
    """``M^-1 = L^-T diag(1/d) L^-1`` from ``M``'s LDL^T factor, both triangles (nested lists)."""
    L, d = factor
    n = len(d)
    # W = L^-1, unit lower triangular: W[i][j] = -sum_{j <= k < i} L[i][k] W[k][j]
    W = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    for j in range(n):
        for i in range(j + 1, n):
            s = -L[i][j]
            for k in range(j + 1, i):
                s = s - L[i][k] * W[k][j]
            W[i][j] = s
    inv_d = [1.0 / x for x in d]
    out = [[None] * n for _ in range(n)]
    for i in range(n):
        for j in range(i, n):
            s = W[j][i] * inv_d[j]                             # W[j][j] = 1
            for k in range(j + 1, n):
                s = s + W[k][i] * W[k][j] * inv_d[k]
            out[i][j] = out[j][i] = s
    return out


def _christoffel(ca, M, q, qd):
    """``C = (dD/dt + J - J^T) / 2`` with ``J = d(D qd)/dq``: the Christoffel form, ``C qd = h``."""
    Mdot = ca.jtimes(M, q, qd)
    J = ca.jacobian(ca.mtimes(M, qd), q)
    return 0.5 * (Mdot + J - J.T)
