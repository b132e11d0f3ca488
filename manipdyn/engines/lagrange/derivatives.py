"""Closed-form derivatives of the trace-form dynamics (chapter II, eq. 2.39, differentiated).

Layer 3 (engines: lagrange) (engines).  Part of the slow path: :class:`TraceFormDerivatives` is a
base of :class:`manipdyn.engines.lagrange.engine.TraceFormEngine` and works on that engine's
own objects (the link frames ``T_p``, the joint generators ``Delta_j`` in the
base frame, ``W_p = T_p J_p T_p^T`` and its tail sums ``Wbar_k = sum_{p >= k}
W_p``).  It shares no code with the Pinocchio path
(:mod:`manipdyn.engines.pinocchio.derivatives`), and has no finite differences.

What is differentiated.  Eq. 2.39 reads, summed over the links ``p >= i``,

    tau_i = sum_{p >= i} tr(Tddot_p J_p dT_p/dq_i^T) - sum_{p >= i} m_p g^T dT_p/dq_i r_bar_p
            + (D_rotor qdd)_i + F_i(qd),

with ``Tddot_p = sum_{j,k} d2T_p/dq_j dq_k qd_j qd_k + sum_j dT_p/dq_j qdd_j``
(the ``D_ij qdd_j`` and ``D_ijk qd_j qd_k`` terms of eq. 2.39 together).  The
facts used (CONVENTIONS.md, "Computing the trace form fast"):

* ``dT_p/dq_k = Delta_k T_p`` and ``d2T_p/dq_j dq_k = Delta_j Delta_k T_p``
  (``j <= k <= p``, zero beyond ``p``), so ``dW_p`` and the traces stay in
  the base frame;
* ``Delta_j`` depends on ``q_k`` only for ``k < j``: ``dDelta_j/dq_k = [Delta_k, Delta_j]``;
* with ``S_p = sum_{k <= p} Delta_k qd_k``: ``Tdot_p = S_p T_p``,
  ``Tddot_p = A_p T_p``, ``A_p = Sdot_p + S_p^2``, and the time derivatives
  of the generators are ``Deltadot_m = [S_{m-1}, Delta_m]``,
  ``Deltaddot_m = [Sdot_{m-1}, Delta_m] + [S_{m-1}, Deltadot_m]``;
* the partial derivatives of ``Tddot_p`` at fixed ``(qd, qdd)`` are time
  derivatives of ``dT_p/dq_m`` (the mixed partials of a smooth ``T_p(q)``
  commute)::

      d Tddot_p / dq_m  = d2/dt2 (dT_p/dq_m) = (Deltaddot_m + 2 Deltadot_m S_p + Delta_m A_p) T_p
      d Tddot_p / dqd_m = 2 d/dt (dT_p/dq_m) = 2 (Deltadot_m + Delta_m S_p) T_p      (m <= p).

Results (``<X, Y> = tr(X^T Y)``, ``a = min(i, m)``, ``b = max(i, m)``,
``Ubar_k = sum_{p >= k} S_p W_p``, ``Vbar_k = sum_{p >= k} A_p W_p``,
``cbar_k = sum_{p >= k} m_p T_p r_bar_p``, ``g4 = [g, 0]``)::

    dtau_i/dq_m  = <Delta_i, Deltaddot_m Wbar_b + 2 Deltadot_m Ubar_b + Delta_m Vbar_b>   (dTddot_p/dq_m)
                 + <Delta_a Delta_b, Vbar_b>                                           (d2T_p/dq_i dq_m)
                 - g4^T Delta_a Delta_b cbar_b                                         (dg/dq)
    dtau_i/dqd_m = 2 <Delta_i, Deltadot_m Wbar_b + Delta_m Ubar_b> + dF_i/dqd_m = 2 C_im + dF_i/dqd_m
    dtau_i/dqdd_m = D_im (rotors included).

``dg/dq`` is symmetric (``-g^T d2T_p/dq_a dq_b J_p e_4``: the Hessian of the
potential energy, eq. 2.24).  ``dh/dqd = 2 C``: ``h_i = sum_jk D_ijk qd_j qd_k``
with the Christoffel symbols ``D_ijk = D_ikj`` (eq. 2.39, see
:meth:`~manipdyn.engines.lagrange.engine.TraceFormEngine.coriolis_matrix`), so
``dh_i/dqd_m = 2 sum_k D_imk qd_k = 2 C_im``; and ``dh/dq`` is the same
contraction with ``dD_ijk/dq_m``, which is what the first two lines give at
``qdd = 0``.  ``dD_ij/dq_k = D_ijk + D_jik`` (:meth:`mass_matrix_derivative`).

Every step stacks over a leading batch axis; ``(n,)`` in gives ``(n, n)``
out, ``(N, n)`` gives ``(N, n, n)``, index ``[..., i, m] = d out_i / d in_m``.
Units SI: N m/rad, N m s/rad, 1/s^2 ... (N, m for prismatic joints).
"""

from __future__ import annotations

import math

import numpy as np

from ..._support.errors import SingularMassMatrixError
from ...model.friction_jacobian import friction_jacobian

__all__ = ["TraceFormDerivatives"]


def _tail_or_head(S: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``out[:, k] = sum_p S[k, p] x[:, p]`` for x of shape (B, n, ...) (tail or head sums)."""
    B, n = x.shape[:2]
    return (S @ x.reshape(B, n, math.prod(x.shape[2:]))).reshape(x.shape)


def _frob_rows(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """``G[b, i, m] = <X_i, Y_m>`` for X, Y of shape (B, n, 4, 4) (or (B, n, k) flat)."""
    B, n = X.shape[:2]
    return X.reshape(B, n, -1) @ Y.reshape(B, n, -1).swapaxes(1, 2)


def _comm(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """The commutator ``[X, Y] = X Y - Y X`` (batched)."""
    return X @ Y - Y @ X


class TraceFormDerivatives:
    """Derivatives of the trace-form dynamics; a base of :class:`manipdyn.engines.lagrange.engine.TraceFormEngine`.

    Uses the engine's ``_frames``, ``_D``, ``_h``, ``_g``, ``_cbar``,
    ``_friction``, ``_call`` and its tail/head sum matrices, and reads the
    friction law's derivative from :meth:`friction_derivative` only.
    """

    # -- friction: the one place its derivative lives -------------------------------
    def _friction_jacobian(self, qd: np.ndarray):
        """``dF/dqd`` for a batch ``(B, n)``: ``(B, n, n)``, or None without friction.

        A friction law beyond the links' kind gives :meth:`manipdyn.Friction.derivative` (the
        model's own derivative of its law: the cross-check compares the rigid-body parts
        independently, the friction law's derivative is the model layer's)."""
        return friction_jacobian(getattr(self, "_law", None), self.friction, qd, self.n, self.transmission)

    def friction_derivative(self, qd) -> np.ndarray:
        """``dF/dqd`` of the joint friction ``F = Fv qd + Fc sign(qd)``: (n, n) or (N, n, n), N m s/rad.

        ``diag(Fv)``: the Coulomb term ``Fc sign(qd)`` is constant wherever it
        has a derivative (``qd != 0``); at ``qd == 0`` the sharp sign has none,
        and its contribution there is taken as 0 (the one-sided derivatives are
        0 too).  Zero without friction.  Every derivative of the dynamics gets
        its friction term from here.
        """
        def kernel(qd):
            J = self._friction_jacobian(qd)
            return np.zeros(qd.shape + (self.n,)) if J is None else J
        return self._call(kernel, "friction_derivative", qd=qd)

    # -- the rigid-body part ----------------------------------------------------------
    def _gravity_jacobian(self, Delta, cbar):
        """``dg_a/dq_b = -g4^T Delta_a Delta_b cbar_b`` (a <= b), symmetric, (B, n, n)."""
        gD = self._g4 @ Delta                                   # g4^T Delta_a, (B, n, 4)
        u = (Delta @ cbar)[..., 0]                              # Delta_b cbar_b, (B, n, 4)
        K = -(gD @ u.swapaxes(1, 2))                            # [a, b]
        return np.where(self._upper, K, K.swapaxes(1, 2))

    def _rigid_jacobians(self, Delta, W, Wbar, qd, qdd):
        """``(dtau/dq, dtau/dqd)`` of the rigid body (no friction), (B, n, n) each.

        ``qdd`` may be None (then ``dtau/dq = dh/dq + dg/dq``).  Formulas: module docstring.
        """
        V = Delta * qd[:, :, None, None]                        # Delta_k qd_k
        S = _tail_or_head(self._head, V)                        # S_p
        Sp = S - V                                              # S_{m-1}
        Dd = _comm(Sp, Delta)                                   # Deltadot_m
        X = Dd * qd[:, :, None, None]
        if qdd is not None:
            X = X + Delta * qdd[:, :, None, None]
        Sdot = _tail_or_head(self._head, X)                     # Sdot_p
        Ddd = _comm(Sdot - X, Delta) + _comm(Sp, Dd)            # Deltaddot_m
        A = Sdot + S @ S                                        # Tddot_p T_p^-1
        Ubar = _tail_or_head(self._tail, S @ W)
        Vbar = _tail_or_head(self._tail, A @ W)
        # dTddot_p/dq_m: i <= m (b = m) per column m; i > m (b = i) per row i
        upper = _frob_rows(Delta, Ddd @ Wbar + 2.0 * (Dd @ Ubar) + Delta @ Vbar)
        rows = np.concatenate([(Delta @ Wbar).reshape(*Delta.shape[:2], 16),
                               (Delta @ Ubar.swapaxes(-1, -2)).reshape(*Delta.shape[:2], 16),
                               (Delta @ Vbar.swapaxes(-1, -2)).reshape(*Delta.shape[:2], 16)], axis=2)
        cols = np.concatenate([Ddd.reshape(*Delta.shape[:2], 16), 2.0 * Dd.reshape(*Delta.shape[:2], 16),
                               Delta.reshape(*Delta.shape[:2], 16)], axis=2)
        lower = rows @ cols.swapaxes(1, 2)
        # d2T_p/dq_i dq_m with Vbar, and gravity, both <Delta_a Delta_b, .>: one symmetric term
        cbar = Wbar[..., 3:]                                    # W_p e4 = T_p J_p e4 = m_p T_p r_bar_p
        Vg = Vbar - self._g4[:, None] * cbar.swapaxes(-1, -2)   # Vbar_b - g4 cbar_b^T
        K = _frob_rows(Delta, Vg @ Delta.swapaxes(-1, -2))      # <Delta_a, Vg_b Delta_b^T>, [a, b]
        dq = np.where(self._upper, upper + K, lower + K.swapaxes(1, 2))
        # dh/dqd = 2 C (Christoffel form)
        upper_v = _frob_rows(Delta, Dd @ Wbar + Delta @ Ubar)
        lower_v = rows[..., :32] @ cols[..., 16:].swapaxes(1, 2)   # [2 Deltadot_m, Delta_m] . rows
        lower_v += rows[..., 16:32] @ cols[..., 32:].swapaxes(1, 2)  # the second <Delta_m, Delta_i Ubar_i^T>
        dqd = np.where(self._upper, 2.0 * upper_v, lower_v)
        return dq, dqd

    # -- batch kernels --------------------------------------------------------------------
    def _k_inverse_derivatives(self, q, qd, qdd):
        _, Delta, W = self._frames(q)
        dq, dqd = self._rigid_jacobians(Delta, W, _tail_or_head(self._tail, W), qd, qdd)
        dF = self._friction_jacobian(qd)
        return dq, (dqd if dF is None else dqd + dF)

    def _k_forward_derivatives(self, q, qd, tau):
        _, Delta, W = self._frames(q)
        Wbar = _tail_or_head(self._tail, W)
        D = self._D(Delta, Wbar)                                # rotors included
        rhs = tau - self._h(Delta, W, qd) - self._g(Delta, Wbar[..., 3:]) - self._friction(qd)
        try:
            qdd = np.linalg.solve(D, rhs[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise SingularMassMatrixError.for_mass_matrix(D) from None
        dq, dqd = self._rigid_jacobians(Delta, W, Wbar, qd, qdd)
        dF = self._friction_jacobian(qd)
        if dF is not None:
            dqd = dqd + dF
        n = self.n
        eye = np.broadcast_to(np.eye(n), D.shape)
        # D dqdd = -dtau (the implicit function theorem on tau(q, qd, qdd(q, qd, tau)) = tau)
        Xs = np.linalg.solve(D, np.concatenate([dq, dqd, eye], axis=2))
        return -Xs[..., :n], -Xs[..., n:2 * n], Xs[..., 2 * n:]

    def _k_gravity_derivative(self, q):
        T, Delta = self._kin.frames(q)
        return self._gravity_jacobian(Delta, self._cbar(T))

    def _k_mass_matrix_derivative(self, q):
        E = self._k_christoffel(q)                              # D_ijk, [b, i, j, k]
        return E + E.swapaxes(1, 2)                             # dD_ij/dq_k = D_ijk + D_jik

    # -- public API ---------------------------------------------------------------------
    def inverse_dynamics_derivatives(self, q, qd, qdd):
        """``(dtau_dq, dtau_dqd)`` of ``tau = D qdd + h + g + F``: each (n, n) or (N, n, n).

        ``dtau_dq[..., i, m] = d tau_i / d q_m`` (N m/rad; N/m for prismatic
        joints), ``dtau_dqd`` likewise per joint velocity (friction included,
        :meth:`friction_derivative`).  ``dtau/dqdd`` is the mass matrix
        :meth:`TraceFormEngine.mass_matrix` (rotors included) and is not repeated here.
        Closed form from the trace form (module docstring); base frame, SI units.
        """
        return self._call(self._k_inverse_derivatives, "inverse_dynamics_derivatives",
                          q=q, qd=qd, qdd=qdd)

    def forward_dynamics_derivatives(self, q, qd, tau):
        """``(dqdd_dq, dqdd_dqd, dqdd_dtau)`` of the forward dynamics: each (n, n) or (N, n, n).

        With ``qdd`` the forward dynamics of ``tau``: ``dqdd_dq = -D^-1
        dtau_dq``, ``dqdd_dqd = -D^-1 (dh/dqd + dF/dqd)``, ``dqdd_dtau =
        D^-1`` (``D`` with the rotor inertias, derivatives evaluated at that
        ``qdd``).  Raises :class:`~manipdyn.SingularMassMatrixError` when D(q) is singular.
        """
        return self._call(self._k_forward_derivatives, "forward_dynamics_derivatives",
                          q=q, qd=qd, tau=tau)

    def gravity_derivative(self, q) -> np.ndarray:
        """``dg/dq``: (n, n) or (N, n, n), N m/rad, symmetric (the Hessian of the potential energy).

        ``dg_i/dq_m = -sum_{p >= max(i, m)} m_p g^T d2T_p/dq_i dq_m r_bar_p``.
        """
        return self._call(self._k_gravity_derivative, "gravity_derivative", q=q)

    def mass_matrix_derivative(self, q) -> np.ndarray:
        """``dD/dq``: (n, n, n) or (N, n, n, n), index ``[..., i, j, k] = dD_ij/dq_k``.

        ``dD_ij/dq_k = D_ijk + D_jik`` with the chapter's ``D_ijk`` (eq. 2.39,
        second derivatives ``Delta_j Delta_k T_p`` of the link frames; see
        :meth:`christoffel_symbols`).  O(n^3) numbers per state.
        """
        return self._call(self._k_mass_matrix_derivative, "mass_matrix_derivative",
                          chunk=self._chunk3, q=q)
