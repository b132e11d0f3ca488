"""The fast path's derivatives: Pinocchio's analytical RNEA, ABA and gravity derivatives.

Layer 3 (engines: pinocchio) (engines).  :class:`PinocchioDerivatives` is a base of
:class:`manipdyn.engines.pinocchio.engine.PinocchioEngine`; it calls
``pin.computeRNEADerivatives``, ``pin.computeABADerivatives`` and
``pin.computeGeneralizedGravityDerivatives`` on the engine's model and data,
and adds what lies outside Pinocchio's rigid-body model (friction).  It shares
no code with the trace form (:mod:`manipdyn.engines.lagrange.derivatives`).

Conventions (Pinocchio 3 and 4, checked on 4.1): each call returns a tuple of
matrices that are views of ``data`` (``data.dtau_dq``, ``data.dtau_dv``,
``data.M``; ``data.ddq_dq``, ``data.ddq_dv``, ``data.Minv``), overwritten by
the next call, so every answer here is copied; ``M`` and ``Minv`` come back
full (both triangles) in Python, and ``M`` includes ``model.armature`` (the
rotor inertias).  Index ``[i, m] = d out_i / d in_m``; ``q`` derivatives are
per joint coordinate (``nq == nv`` for the revolute and prismatic joints
manipdyn builds).

Friction ``F(qd)`` is applied outside Pinocchio, as in the engine's dynamics:
``dtau/dqd += dF/dqd``, and the forward dynamics runs ABA on ``tau - F(qd)``,
so ``dqdd/dqd = ddq_dv - Minv dF/dqd``.  The friction law's derivative is read
from :meth:`PinocchioDerivatives.friction_derivative` only.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..._support.state import as_state, check_result, same_batch
from ..._support.errors import SingularMassMatrixError
from ...model.friction_jacobian import SingleStateFriction, friction_jacobian

__all__ = ["PinocchioDerivatives"]

_ND = np.ndarray
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


def _plain(q, qd=None, x=None) -> bool:
    """True for plain 1-D native-float64 ndarrays, finite, of norm below :data:`_SHORTCUT_BOUND`.

    Anything else (lists, other dtypes or byte orders, subclasses, batches,
    NaN, inf, huge values) takes the general path, which converts or refuses
    it and names the argument.  One C call decides finiteness and size:
    ``math.hypot`` of every entry is NaN or inf when one is (so the comparison
    is False) and never overflows on its way to a huge value.
    """
    if type(q) is not _ND or q.dtype is not _F64 or q.ndim != 1:
        return False
    if qd is None:
        return _hypot(*q.tolist()) < _SHORTCUT_BOUND
    if (type(qd) is not _ND or type(x) is not _ND or qd.dtype is not _F64 or x.dtype is not _F64
            or qd.ndim != 1 or x.ndim != 1):
        return False
    return _hypot(*q.tolist(), *qd.tolist(), *x.tolist()) < _SHORTCUT_BOUND


class PinocchioDerivatives:
    """Derivatives of the Pinocchio engine's dynamics (a base of ``PinocchioEngine``).

    Single states take a shortcut: plain ``(n,)`` native-float64 ndarrays
    with finite entries of moderate size (:func:`_plain`) go straight to
    Pinocchio and the answer is copied; a wrong length makes Pinocchio raise,
    and that, like anything else, goes down the general path, which validates
    every argument and names the offending one.  Batches are a loop
    over states on the engine's own ``data``.
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

    def _law_one(self, qd):
        """``(F, J)`` of the friction law at one plain (n,) velocity (:class:`SingleStateFriction`,
        built on first use: the law is frozen): J is dF/dqd's diagonal (n,) or the full (n, n)."""
        plan = self.__dict__.get("_law_plan")
        if plan is None:
            plan = self._law_plan = SingleStateFriction(self._law, self.transmission)
        return plan(qd)

    def _add_friction_jacobian(self, dv, qd) -> None:
        """``dv += dF/dqd`` in place for one plain state (the law's or the links' table)."""
        if self._law is not None:
            plan = self.__dict__.get("_law_plan")
            if plan is None:
                self._law_one(qd)
                plan = self._law_plan
            J = plan.jacobian(qd)
            if J.ndim == 1:
                dv.reshape(-1)[::self.n + 1] += J          # the diagonal, in place (a view: dv is contiguous)
            else:
                dv += J
        elif self.friction is not None:
            dv.reshape(-1)[::self.n + 1] += self.friction[0]

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
        if _plain(q, qd, qdd):
            try:
                r = _rnea_d(m, d, q, qd, qdd)
                dq, dv = r[0].copy(), r[1].copy()
                self._add_friction_jacobian(dv, qd)
                return dq, dv
            except (TypeError, ValueError, RuntimeError):
                pass
        q, qd, qdd = (as_state(x, nm, self.n) for x, nm in ((q, "q"), (qd, "qd"), (qdd, "qdd")))
        same_batch((q, "q"), (qd, "qd"), (qdd, "qdd"))
        single = q.ndim == 1
        qb, vb, ab = (x[None] if single else x for x in (q, qd, qdd))
        dq = np.empty((len(qb), self.n, self.n))
        dv = np.empty_like(dq)
        for k in range(len(qb)):
            r = _rnea_d(m, d, qb[k], vb[k], ab[k])
            dq[k], dv[k] = r[0], r[1]
        if single:                      # one state: the shortcut's friction numbers, whatever the input's form
            self._add_friction_jacobian(dv[0], vb[0])
        elif self.friction is not None or self._law is not None:
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
        law, fr = self._law, self.friction
        if _plain(q, qd, tau):
            try:
                if law is not None:
                    F, J = self._law_one(qd)
                    r = _aba_d(m, d, q, qd, tau - F)
                else:
                    r = _aba_d(m, d, q, qd, tau if fr is None else tau - (fr[0] * qd + fr[1] * np.sign(qd)))
                a, b, c = r[0].copy(), r[1].copy(), r[2].copy()
                # a singular D gives a non-finite Minv: the general path then explains
                if _isfinite(_add(c.reshape(-1))):
                    if law is not None:
                        b -= c * J if J.ndim == 1 else c @ J
                    elif fr is not None:
                        b -= c * fr[0]
                    return a, b, c
            except (TypeError, ValueError, RuntimeError):
                pass
        q, qd, tau = (as_state(x, nm, self.n) for x, nm in ((q, "q"), (qd, "qd"), (tau, "tau")))
        same_batch((q, "q"), (qd, "qd"), (tau, "tau"))
        single = q.ndim == 1
        qb, vb, tb = (x[None] if single else x for x in (q, qd, tau))
        J = None
        if single and law is not None:        # one state: the shortcut's friction numbers
            F, J = self._law_one(vb[0])
            tb = tb - F
        elif law is not None or fr is not None:
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
            out[1, 0] -= out[2, 0] * J if J.ndim == 1 else out[2, 0] @ J
        elif law is not None or fr is not None:
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
        if _plain(q):
            try:
                return _grav_d(m, d, q).copy()
            except (TypeError, ValueError, RuntimeError):
                pass
        q = as_state(q, "q", self.n)
        qb = q[None] if q.ndim == 1 else q
        G = np.empty((len(qb), self.n, self.n))
        for k in range(len(qb)):
            G[k] = _grav_d(m, d, qb[k])
        return check_result(G[0] if q.ndim == 1 else G, "gravity_derivative", q=q)
