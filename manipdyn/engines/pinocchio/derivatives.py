"""The fast path's derivatives: Pinocchio's analytical RNEA, ABA and gravity derivatives.

Layer 3 (engines: pinocchio) (engines).  :class:`PinocchioDerivatives` is a base of
:class:`manipdyn.engines.pinocchio.engine.PinocchioEngine`; it calls
``pin.computeRNEADerivatives``, ``pin.computeABADerivatives`` and
``pin.computeGeneralizedGravityDerivatives`` on the engine's model and data,
and adds what lies outside Pinocchio's rigid-body model (friction).  It shares
no code with the trace form (:mod:`manipdyn.engines.lagrange.derivatives`).

Conventions (Pinocchio 3 and 4, checked on 4.1): the RNEA and ABA derivatives
return tuples of matrices that are views of ``data`` (``data.dtau_dq``,
``data.dtau_dv``, ``data.M``; ``data.ddq_dq``, ``data.ddq_dv``, ``data.Minv``),
overwritten by the next call, so those answers are copied; the gravity
derivative comes back by value, a new array (tests/test_derivatives_fast.py
holds it to that), and is returned as it is; ``M`` and ``Minv`` come back
full (both triangles) in Python, and ``M`` includes ``model.armature`` (the
rotor inertias).  Index ``[i, m] = d out_i / d in_m``; ``q`` derivatives are
per joint coordinate (``nq == nv`` for the revolute and prismatic joints
manipdyn builds).

Friction ``F(qd)`` is applied outside Pinocchio, as in the engine's dynamics:
``dtau/dqd += dF/dqd``, and the forward dynamics runs ABA on ``tau - F(qd)``,
so ``dqdd/dqd = ddq_dv - Minv dF/dqd``.  The friction law's derivative is read
from the model (:mod:`manipdyn.model.friction_jacobian`) only.

Single states (issue 34) take shortcuts installed on each engine as closures
(:func:`install_derivative_shortcuts`), and ``engine.unchecked`` gets the same
code without its tests; the methods of :class:`PinocchioDerivatives` are the
general path behind them.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..._support.state import as_state, check_result, same_batch
from ..._support.errors import SingularMassMatrixError
from ...model.friction_jacobian import SingleStateFriction, friction_jacobian

__all__ = ["PinocchioDerivatives", "OneStateFriction", "install_derivative_shortcuts", "pivots_positive"]

_F64 = np.dtype(np.float64)
_isfinite = math.isfinite
_add = np.add.reduce
_rnea_d = pin.computeRNEADerivatives
_aba_d = pin.computeABADerivatives
_grav_d = pin.computeGeneralizedGravityDerivatives


#: the shortcut takes states whose entries, together, have a Euclidean norm below
#: this: with the model's numbers capped (:mod:`manipdyn._support.limits`: lengths 1e4 m,
#: masses and inertias 1e9, gravity 1e4, at most 100 joints), the derivatives are
#: polynomials of degree <= 3 in such entries (times sines and cosines) and stay far
#: below float64's 1e308, so a finite input gives a finite answer and the answer need
#: not be read again (reading 2 n^2 numbers would cost more than the checks it saves)
_SHORTCUT_BOUND = 1e50
_hypot = math.hypot
#: what sends a shortcut down the general path: no ``dtype`` (AttributeError: a list), a
#: nested, 0-d or masked ``tolist()`` in ``math.hypot`` (TypeError: a batch, a scalar, a
#: masked entry), Pinocchio refusing an argument (TypeError, ValueError, RuntimeError)
_ERRORS = (AttributeError, TypeError, ValueError, RuntimeError)


_REVOLUTE = frozenset(("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned"))
#: how far above the rounding of ABA's pivots their lower bound must lie (relative to the
#: bound on the articulated inertias' entries, :func:`pivots_positive`)
_PIVOT_MARGIN = 1e-8


def pivots_positive(model) -> bool:
    """True when ABA's pivots are positive at EVERY configuration, by a margin no rounding
    can take away: then D(q) is positive definite for every q and the forward derivatives
    need not test Minv (:func:`install_derivative_shortcuts`).

    ABA's pivot of joint k is ``S_k^T Ia_k S_k + armature_k``, where the articulated inertia
    ``Ia_k`` is body k's own spatial inertia ``I_k`` plus, for the child, ``Ia - U D^-1 U^T``
    (a Schur complement, positive semidefinite when ``Ia`` is and the child's pivot ``D`` is
    positive, whatever its armature >= 0: by induction from the leaf).  So when every body's
    spatial inertia is positive semidefinite (mass >= 0, inertia at the centre of mass PSD),
    ``Ia_k - I_k`` is PSD and the pivot is at least
    ``c_k = S_k^T I_k S_k + armature_k``: body k's moment about its own joint axis plus its
    rotor, a constant of the model.  Checked here for a serial chain of revolute joints (a
    prismatic joint's q moves masses without bound, and with them the rounding), with
    ``c_k > _PIVOT_MARGIN * s_k``, ``s_k`` a bound on the entries of ``Ia_k`` at any q
    (``sum_i>=k m_i (1 + R)^2 + |I_i|``, R the sum of the joint placements' and the largest
    centre-of-mass offsets); ABA's computed pivot is within a few hundred ulp of ``s_k``
    of the exact one, so it stays above ``c_k / 2``.
    """
    n = model.njoints - 1
    if n < 1 or any(model.parents[i] != i - 1 for i in range(1, n + 1)):
        return False
    joints, inertias = model.joints, model.inertias
    if not np.all(np.asarray(model.armature) >= 0.0) or any(
            joints[i].nq != 1 or joints[i].nv != 1 or joints[i].shortname() not in _REVOLUTE for i in range(1, n + 1)):
        return False
    data = model.createData()
    pin.computeJointJacobians(model, data, pin.neutral(model))
    R = (sum(float(np.linalg.norm(model.jointPlacements[i].translation)) for i in range(1, n + 1))
         + max(float(np.linalg.norm(inertias[i].lever)) for i in range(1, n + 1)))
    size = []
    for i in range(1, n + 1):
        Y = inertias[i]
        w = np.linalg.eigvalsh(np.asarray(Y.inertia))
        if not (Y.mass >= 0.0 and w[0] >= 0.0):
            return False                         # not PSD: no bound from below
        size.append(Y.mass * (1.0 + R) ** 2 + float(w[-1]))
    for i in range(1, n + 1):
        S = np.asarray(pin.getJointJacobian(model, data, i, pin.LOCAL)).reshape(6, -1)[:, joints[i].idx_v]
        c = float(S @ inertias[i].matrix() @ S) + float(model.armature[joints[i].idx_v])
        if not c > _PIVOT_MARGIN * sum(size[i - 1:]):
            return False
    return True


class OneStateFriction:
    """The engine's friction at ONE validated state, for its single-state derivatives.

    Shared by the shortcuts (:func:`install_derivative_shortcuts`), ``engine.unchecked`` and
    the general path's single states, so that all three give the same bits.  ``vl`` is
    ``qd.tolist()`` and ``tl`` ``tau.tolist()`` (the shortcut has them already: it tested
    them); ``qd``, ``tau`` the (n,) arrays.

    * the links' table ``[Fv, Fc]`` (viscous plus sharp Coulomb): ``dF/dqd = diag(Fv)``;
    * a friction law: :class:`~manipdyn.model.friction_jacobian.SingleStateFriction`; a
      joint-side law runs as straight-line float code (``floats``: its ``jacobian``
      and ``tau_jacobian``), ``J`` the diagonal of dF/dqd; a motor-side law gives the
      full ``J = R^T diag(f') R``.

    A diagonal ``J`` is added through ``self.D``, an (n, n) zero matrix whose diagonal
    is overwritten with J (``r1 + D``: one array operation that also makes the copy);
    the column scaling ``Minv diag(J)`` of the forward derivatives is ``Minv * J``.
    """

    def __init__(self, eng):
        n = eng.n
        self.D = np.zeros((n, n))
        self.Ddiag = self.D.reshape(-1)[::n + 1]          # a view: writing it writes D's diagonal
        self.table = self.plan = self.floats = None
        if eng._law is not None:
            self.plan = SingleStateFriction(eng._law, eng.transmission)
            if self.plan.jacobian_floats is not None:        # a joint-side law as straight-line code
                self.floats = self.plan.jacobian_floats, self.plan.tau_jacobian_floats
        else:
            self.table = eng.friction                       # (2, n): Fv, Fc
            self.Ddiag[:] = self.table[0]
            self.Fv = self.table[0].copy()

    def dv(self, r1, vl, qd) -> np.ndarray:
        """``dtau/dqd``: Pinocchio's ``r1`` plus ``dF/dqd``, a new array."""
        if self.floats is not None:
            self.Ddiag[:] = self.floats[0](vl)
        elif self.plan is not None:
            J = self.plan.jacobian(qd)
            if J.ndim == 2:
                return r1 + J
            self.Ddiag[:] = J
        return r1 + self.D

    def tau(self, tau, vl, tl, qd):
        """``(tau - F(qd), J)``: the torque ABA runs on, and what :meth:`dqdd_dqd` takes."""
        if self.floats is not None:
            T, J = self.floats[1](vl, tl)
            return np.array(T), np.array(J)
        if self.plan is not None:
            F, J = self.plan(qd)
            return tau - F, J
        fr = self.table
        return tau - (fr[0] * qd + fr[1] * np.sign(qd)), self.Fv

    @staticmethod
    def dqdd_dqd(b, Minv, J) -> np.ndarray:
        """``ddq_dv - Minv dF/dqd`` (a new array) for ``J`` of :meth:`tau`."""
        return b - (Minv * J if J.ndim == 1 else Minv @ J)


def install_derivative_shortcuts(eng) -> dict:
    """Shadow the engine's three derivative methods by single-state shortcuts; return the
    unchecked calls (for ``engine.unchecked``).

    Each shortcut is a closure in the engine's ``__dict__`` (as
    :func:`manipdyn.engines.pinocchio.fast.install_fast_path` does for the dynamics): no
    method frame, no attribute look-ups.  It takes native-float64 arrays of one state,
    tested by two expressions:

    * ``x.dtype is float64`` for each argument (the native float64 dtype object: a
      big-endian, integer or bool array goes down the general path, which converts or
      refuses it; a list has no dtype);
    * ``math.hypot(*q.tolist(), *qd.tolist(), *x.tolist()) < _SHORTCUT_BOUND``, one C call
      on the entries as floats: NaN, inf and huge entries fail the comparison (hypot is NaN
      or inf, and never overflows on the way), and an argument that is not 1-D makes
      ``tolist()`` nested (or a float) and hypot raise TypeError, as does a masked entry
      (None); a wrong length makes Pinocchio raise.  Either way the general path then names
      the argument.  (A subclass with nothing masked, or a strided array, holds the numbers
      Pinocchio reads: tests/test_fast_path_dtypes.py.)

    The forward derivatives also read the diagonal of ``Minv``: a singular D(q) gives a
    zero pivot ``S^T Ia_k S`` in ABA, so ``Dinv_k = 1 / 0``, and Pinocchio's backward pass
    sets ``Minv[k, k] = Dinv_k`` and afterwards only subtracts from it (its forward pass
    and the symmetrisation leave the diagonal so), and a non-finite number minus
    anything is non-finite: a finite diagonal means every pivot was inverted.  Then the
    general path explains it (:class:`~manipdyn.SingularMassMatrixError`).  With every
    pivot finite and the inputs bounded, the off-diagonal entries are bounded by the
    diagonal (``|Minv_ij| <= sqrt(Minv_ii Minv_jj)`` for a positive definite D), so the
    diagonal, n numbers, stands for the n^2 (summed in one C call, ``sum`` of a list).  A
    model whose pivots are bounded away from zero at every q (:func:`pivots_positive`,
    decided once here: all bundled arms) skips even that.  The unchecked calls are the
    same code without any of the tests (the same bits: tests/test_derivatives_fast.py).
    """
    cls = type(eng)
    g_inv, g_fwd, g_grav = (getattr(cls, nm).__get__(eng) for nm in (
        "inverse_dynamics_derivatives", "forward_dynamics_derivatives", "gravity_derivative"))
    m, d = eng.model, eng.data
    F64, isf, hypot, B, errors = _F64, _isfinite, _hypot, _SHORTCUT_BOUND, _ERRORS
    rnea_d, aba_d, grav_d = _rnea_d, _aba_d, _grav_d
    fr = eng._friction_one
    #: D(q) positive definite at every q (pivots_positive): Minv needs no test
    pd = pivots_positive(m)

    def gravity_derivative(q):
        try:
            if q.dtype is F64 and hypot(*q.tolist()) < B:
                return grav_d(m, d, q)      # Pinocchio returns this one by value: a new array
        except errors:
            pass
        return g_grav(q)

    def u_grav(q):
        return grav_d(m, d, q)

    if fr is None:
        def inverse_dynamics_derivatives(q, qd, qdd):
            try:
                if (q.dtype is qd.dtype is qdd.dtype is F64
                        and hypot(*q.tolist(), *qd.tolist(), *qdd.tolist()) < B):
                    r = rnea_d(m, d, q, qd, qdd)
                    return r[0].copy(), r[1].copy()
            except errors:
                pass
            return g_inv(q, qd, qdd)

        def forward_dynamics_derivatives(q, qd, tau):
            try:
                if (q.dtype is qd.dtype is tau.dtype is F64
                        and hypot(*q.tolist(), *qd.tolist(), *tau.tolist()) < B):
                    r = aba_d(m, d, q, qd, tau)
                    c = r[2]
                    if pd or isf(sum(c.diagonal().tolist())):      # singular D: see the docstring
                        return r[0].copy(), r[1].copy(), c.copy()
            except errors:
                pass
            return g_fwd(q, qd, tau)

        def u_inv(q, qd, qdd):
            r = rnea_d(m, d, q, qd, qdd)
            return r[0].copy(), r[1].copy()

        def u_fwd(q, qd, tau):
            r = aba_d(m, d, q, qd, tau)
            return r[0].copy(), r[1].copy(), r[2].copy()
    else:                                   # friction: OneStateFriction's code, one state
        fr_dv, fr_tau, fr_b = fr.dv, fr.tau, fr.dqdd_dqd

        def inverse_dynamics_derivatives(q, qd, qdd):
            try:
                if q.dtype is qd.dtype is qdd.dtype is F64:
                    vl = qd.tolist()
                    if hypot(*q.tolist(), *vl, *qdd.tolist()) < B:
                        r = rnea_d(m, d, q, qd, qdd)
                        return r[0].copy(), fr_dv(r[1], vl, qd)
            except errors:
                pass
            return g_inv(q, qd, qdd)

        def forward_dynamics_derivatives(q, qd, tau):
            try:
                if q.dtype is qd.dtype is tau.dtype is F64:
                    vl, tl = qd.tolist(), tau.tolist()
                    if hypot(*q.tolist(), *vl, *tl) < B:
                        t, J = fr_tau(tau, vl, tl, qd)
                        r = aba_d(m, d, q, qd, t)
                        c = r[2]
                        if pd or isf(sum(c.diagonal().tolist())):      # singular D: see the docstring
                            return r[0].copy(), fr_b(r[1], c, J), c.copy()
            except errors:
                pass
            return g_fwd(q, qd, tau)

        def u_inv(q, qd, qdd):
            r = rnea_d(m, d, q, qd, qdd)
            return r[0].copy(), fr_dv(r[1], qd.tolist(), qd)

        def u_fwd(q, qd, tau):
            t, J = fr_tau(tau, qd.tolist(), tau.tolist(), qd)
            r = aba_d(m, d, q, qd, t)
            c = r[2]
            return r[0].copy(), fr_b(r[1], c, J), c.copy()

    fast = {"inverse_dynamics_derivatives": inverse_dynamics_derivatives, "gravity_derivative": gravity_derivative}
    unchecked = {"inverse_dynamics_derivatives": u_inv, "gravity_derivative": u_grav}
    if eng._O is None:      # coupled rotors: ABA knows only the diagonal armature (the drive path)
        fast["forward_dynamics_derivatives"] = forward_dynamics_derivatives
        unchecked["forward_dynamics_derivatives"] = u_fwd
    else:
        unchecked["forward_dynamics_derivatives"] = g_fwd
    for name, fn in fast.items():
        fn.__doc__ = getattr(cls, name).__doc__
        fn.__qualname__ = f"{cls.__name__}.{name}"
        eng.__dict__[name] = fn
    return unchecked


class PinocchioDerivatives:
    """Derivatives of the Pinocchio engine's dynamics (a base of ``PinocchioEngine``).

    These methods are the general path: they validate every argument and name the
    offending one.  Single states of plain ``(n,)`` native-float64 ndarrays with finite
    entries of moderate size take the shortcuts :func:`install_derivative_shortcuts`
    puts on each engine, which call Pinocchio directly and fall back here for anything
    else.  A single state here gives the shortcut's numbers (the same friction code,
    :class:`OneStateFriction`); batches are a loop over states on the engine's own ``data``.
    """

    # -- friction: the one place its derivative lives -------------------------------
    def _friction_jacobian(self, qd: np.ndarray):
        """``dF/dqd`` for ``(n,)`` or ``(N, n)`` velocities, or None without friction.

        A friction law beyond the links' kind (smooth or asymmetric Coulomb, motor side, ...)
        gives :meth:`manipdyn.Friction.derivative` (motor side ``R^T diag(f') R``)."""
        return friction_jacobian(getattr(self, "_law", None), self.friction, qd, self.n, self.transmission)

    def friction_derivative(self, qd) -> np.ndarray:
        """``dF/dqd`` of the joint friction ``F = Fv qd + Fc sign(qd)``: (n, n) or (N, n, n), N m s/rad.

        ``diag(Fv)``: the Coulomb term ``Fc sign(qd)`` is constant wherever it
        has a derivative (``qd != 0``); at ``qd == 0`` the sharp sign has none,
        and its contribution there is taken as 0.  Zero without friction.
        """
        qd = as_state(qd, "qd", self.n)
        J = self._friction_jacobian(qd)
        return np.zeros(qd.shape + (self.n,)) if J is None else J

    # -- public API ---------------------------------------------------------------------
    def inverse_dynamics_derivatives(self, q, qd, qdd):
        """``(dtau_dq, dtau_dqd)`` by ``pin.computeRNEADerivatives``: each (n, n) or (N, n, n).

        With drive extras (coupled rotors, a friction law), the rotor term ``O qdd`` does not
        depend on q or qd and the friction law enters ``dtau_dqd`` only.

        ``dtau_dq[..., i, m] = d tau_i / d q_m``; ``dtau_dqd`` includes the
        friction term :meth:`friction_derivative`.  ``dtau/dqdd`` is the mass
        matrix (rotors included).  SI units; new arrays.
        """
        m, d = self.model, self.data
        q, qd, qdd = (as_state(x, nm, self.n) for x, nm in ((q, "q"), (qd, "qd"), (qdd, "qdd")))
        same_batch((q, "q"), (qd, "qd"), (qdd, "qdd"))
        single = q.ndim == 1
        qb, vb, ab = (x[None] if single else x for x in (q, qd, qdd))
        dq = np.empty((len(qb), self.n, self.n))
        dv = np.empty_like(dq)
        for k in range(len(qb)):
            r = _rnea_d(m, d, qb[k], vb[k], ab[k])
            dq[k], dv[k] = r[0], r[1]
        fr = self._friction_one
        if single and fr is not None:   # one state: the shortcut's friction numbers, whatever the input's form
            dv[0] = fr.dv(dv[0], vb[0].tolist(), vb[0])
        elif fr is not None:
            dv += self._friction_jacobian(vb)
        names = {"q": q, "qd": qd, "qdd": qdd}
        out = (dq[0], dv[0]) if single else (dq, dv)
        return tuple(check_result(x, "inverse_dynamics_derivatives", **names) for x in out)

    def forward_dynamics_derivatives(self, q, qd, tau):
        """``(dqdd_dq, dqdd_dqd, dqdd_dtau)`` by ``pin.computeABADerivatives``: each (n, n) or (N, n, n).

        ABA runs on ``tau - F(qd)`` (any friction law: F depends on qd alone);
        ``dqdd_dqd = ddq_dv - D^-1 dF/dqd``; ``dqdd_dtau = D^-1`` (``Minv``,
        rotors included).  Coupled rotors (which ABA does not know) take
        ``-D^-1 dtau/dx`` with the full D.  Raises
        :class:`~manipdyn.SingularMassMatrixError` when D(q) is singular.
        """
        m, d = self.model, self.data
        if self._O is not None:
            return self._forward_derivatives_drive(q, qd, tau)
        fr = self._friction_one
        q, qd, tau = (as_state(x, nm, self.n) for x, nm in ((q, "q"), (qd, "qd"), (tau, "tau")))
        same_batch((q, "q"), (qd, "qd"), (tau, "tau"))
        single = q.ndim == 1
        qb, vb, tb = (x[None] if single else x for x in (q, qd, tau))
        J = None
        if single and fr is not None:         # one state: the shortcut's friction numbers
            t0, J = fr.tau(tb[0], vb[0].tolist(), tb[0].tolist(), vb[0])
            tb = t0[None]
        elif fr is not None:
            tb = tb - self._friction(vb)
        out = np.empty((3, len(qb), self.n, self.n))
        for k in range(len(qb)):
            r = _aba_d(m, d, qb[k], vb[k], tb[k])
            out[0, k], out[1, k], out[2, k] = r
        if not _isfinite(_add(out.reshape(-1))):
            D = self.mass_matrix(qb)          # a zero articulated inertia: D(q) singular?
            w = np.linalg.eigvalsh(D)
            if np.any(w[:, 0] <= 1e-12 * np.maximum(1.0, np.abs(w[:, -1]))):
                raise SingularMassMatrixError.for_mass_matrix(D)
        if J is not None:
            out[1, 0] = fr.dqdd_dqd(out[1, 0], out[2, 0], J)
        elif fr is not None:
            out[1] -= out[2] @ self._friction_jacobian(vb)
        names = {"q": q, "qd": qd, "tau": tau}
        return tuple(check_result(x[0] if single else x, "forward_dynamics_derivatives", **names)
                     for x in out)

    def _forward_derivatives_drive(self, q, qd, tau):
        """Forward derivatives with coupled rotors (ABA knows only the diagonal armature).

        ``qdd = D^-1 (tau - h - g - F)`` with the full ``D`` (CRBA plus the rotor coupling), so
        ``dqdd/dx = -D^-1 dtau/dx`` at ``(q, qd, qdd)`` for x = q, qd, and ``dqdd/dtau = D^-1``.
        """
        D = self.mass_matrix(q)                               # one CRBA: qdd and the derivatives share it
        try:
            Dinv = np.linalg.inv(D)
        except np.linalg.LinAlgError:
            raise SingularMassMatrixError.for_mass_matrix(D) from None
        rhs = as_state(tau, "tau", self.n) - self.inverse_dynamics(q, qd, np.zeros(np.shape(qd)))
        qdd = (Dinv @ rhs[..., None])[..., 0]                 # D qdd = tau - h - g - F
        dq, dv = self.inverse_dynamics_derivatives(q, qd, qdd)
        return -(Dinv @ dq), -(Dinv @ dv), Dinv

    def gravity_derivative(self, q) -> np.ndarray:
        """``dg/dq`` by ``pin.computeGeneralizedGravityDerivatives``: (n, n) or (N, n, n), N m/rad."""
        m, d = self.model, self.data
        q = as_state(q, "q", self.n)
        qb = q[None] if q.ndim == 1 else q
        G = np.empty((len(qb), self.n, self.n))
        for k in range(len(qb)):
            G[k] = _grav_d(m, d, qb[k])
        return check_result(G[0] if q.ndim == 1 else G, "gravity_derivative", q=q)
