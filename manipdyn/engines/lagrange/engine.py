"""The trace-form Lagrange-Euler engine (chapter II, eq. 2.22 to 2.39).

Layer 3 (engines: lagrange).  This is manipdyn's independent slow path.  It shares no code with the
Pinocchio path: it works from the link frames ``T_p`` and the derivatives
``dT_p/dq_j = Delta_j T_p`` and ``d2T_p/dq_j dq_k = Delta_j Delta_k T_p``
(``j <= k <= p``), and the pseudo-inertias ``J_p`` of eq. 2.21.

The sums of eq. 2.37 to 2.39 are evaluated regrouped by link index p
(CONVENTIONS.md, "Computing the trace form fast"); they are the same sums.
A plain-loop transcription of the equations lives in ``tests/reference.py``
and the tests prove the two agree.

Every method takes one state ``(n,)`` or a batch ``(N, n)`` and returns
arrays with the same leading shape.  Units: SI (rad, m, kg, N m, N).
"""

from __future__ import annotations

import math

import numpy as np

from ..._support.state import as_state, check_result, same_batch
from ..._support.errors import ModelError, SingularMassMatrixError
from ...model.kinematics import transform_inverse
from .derivatives import TraceFormDerivatives
from .jacobian import TraceFormJacobian
from ...model.parameters import PARAMETER_BASIS, with_extra_columns
from .drive import coupled_rotor_inertia, friction_torque

__all__ = ["TraceFormEngine", "trace_form_engine", "CHUNK"]

#: states per block in batch calls (see :meth:`TraceFormEngine._run`)
CHUNK = 128


def _link_sum(S: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``out[:, k] = sum_p S[k, p] x[:, p]`` for x of shape (B, n, ...).

    With S the (n, n) upper-triangular matrix of ones this is the tail sum
    ``sum_{p >= k}`` of the chapter's formulas; with the lower one, the head
    sum ``sum_{p <= k}``.  One matmul instead of flip/cumsum/flip, which
    matters for small arrays.
    """
    B, n = x.shape[:2]
    return (S @ x.reshape(B, n, math.prod(x.shape[2:]))).reshape(x.shape)


_isfinite = math.isfinite

class TraceFormEngine(TraceFormDerivatives, TraceFormJacobian):  # .derivatives, .jacobian
    """Trace-form Lagrange-Euler dynamics of one arm.

    Built by :class:`manipdyn.Manipulator`; reach it as ``arm.lagrange``.

    Parameters
    ----------
    kinematics : object
        Provides ``n``, ``frames(q) -> (T, Delta)`` and ``tool(T)``.
    J : (n, 4, 4)
        Pseudo-inertia of each link in its frame ``T_p`` (eq. 2.21).
    gravity : (3,)
        Acceleration of gravity in the base frame, m/s^2.
    armature : (n,)
        Reflected rotor inertia ``G^2 Jm`` per joint (kg m^2 or kg), used when the
        transmission is diagonal (or not given).
    friction : (2, n), Friction or None
        Viscous and Coulomb friction coefficients per joint (joint side, sharp
        sign), or a friction law (:class:`manipdyn.model.drive.Friction`), which this
        engine evaluates with its own code (:meth:`_friction_law`).
    transmission : Transmission or None
        Motors to joints; with a coupled (non-diagonal) R the rotor inertia is the
        full ``R^T diag(motor_inertia) R``, and a motor-side law acts on ``R qd``.
    motor_inertia : (n,) or None
        Rotor inertias ``Jm`` on the motor shafts, kg m^2.
    link_offsets : (n, 4, 4) or None
        ``S_p`` with ``T_p = L_p S_p``, ``L_p`` link p's frame in the arm's URDF
        (:meth:`manipdyn.Arm.urdf_link_offsets`; identity when None).
        Only :meth:`regressor` uses it: its parameters are about ``L_p``.
    """

    name = "lagrange"

    def __init__(self, kinematics, J, gravity, armature=None, friction=None, link_offsets=None,
                 transmission=None, motor_inertia=None):
        self._kin = kinematics
        self.n = kinematics.n
        self.J = np.asarray(J, dtype=np.float64)
        self.J.setflags(write=False)
        self.gravity = np.asarray(gravity, dtype=np.float64)
        # homogeneous gravity vector g = [gx, gy, gz, 0] (eq. 2.23)
        self._g4 = np.append(self.gravity, 0.0)
        # m_p r_bar_p, the last column of J_p (CONVENTIONS: gravity torque)
        self._mr = np.ascontiguousarray(self.J[:, :, 3])
        self.armature = np.zeros(self.n) if armature is None else np.asarray(armature, dtype=np.float64)
        self._has_armature = bool(np.any(self.armature))
        self._armature_diag = np.diag(self.armature)
        self.transmission = transmission
        self._rotor_full = None           # a coupled drive: the full (n, n) rotor inertia
        if transmission is not None and not transmission.is_diagonal and motor_inertia is not None:
            self._rotor_full = self._armature_diag = coupled_rotor_inertia(transmission.R, motor_inertia)
            self._has_armature = bool(np.any(self._rotor_full))
        # states per block: CHUNK, fewer on long chains so that one (B, n, n)
        # temporary stays within about 16 MB (memory linear in N, chunked)
        self._chunk = max(1, min(CHUNK, 2_000_000 // (self.n * self.n)))
        self._chunk3 = max(1, min(CHUNK, 2_000_000 // (16 * self.n ** 3)))
        self._upper = np.triu(np.ones((self.n, self.n), dtype=bool))
        self._tail = np.triu(np.ones((self.n, self.n)))        # sum over p >= k
        self._head = np.tril(np.ones((self.n, self.n)))        # sum over p <= k
        self._head_strict2 = 2.0 * np.tril(np.ones((self.n, self.n)), -1)  # 2 * sum over p < k
        # the friction law: legacy (2, n) array in self.friction, anything else in self._law
        self._law = None
        if friction is not None and hasattr(friction, "viscous_coulomb"):
            legacy = friction.viscous_coulomb()
            if legacy is None:
                self._law = friction
                if friction.side == "motor" and transmission is None:
                    raise ModelError("friction: a motor-side law needs the transmission (qd_m = R qd)")
            friction = legacy
        self.friction = None if friction is None else np.asarray(friction, dtype=np.float64)
        if self.friction is not None and not np.any(self.friction):
            self.friction = None
        # S_p^-1 (T_p S_p^-1 = L_p); None when every S_p is the identity
        self._S_inv = None
        if link_offsets is not None and np.any(np.asarray(link_offsets) != np.eye(4)):
            self._S_inv = transform_inverse(link_offsets)       # eq. 2.2

    # -- internals ---------------------------------------------------------
    def _frames(self, qb):
        T, Delta = self._kin.frames(qb)
        # W_p = T_p J_p T_p^T: link p's pseudo-inertia seen from the base
        # (numpy's batched matmul is about twice as fast on a contiguous T^T)
        W = (T @ self.J) @ np.swapaxes(T, -1, -2).copy()
        return T, Delta, W

    def _D(self, Delta, Wbar):
        """D_ij = sum_{p >= max(i,j)} tr(dT_p/dq_j J_p dT_p/dq_i^T) (eq. 2.39).

        With dT_p/dq_j = Delta_j T_p this is tr(Delta_j Wbar_{max(i,j)} Delta_i^T),
        ``Wbar_k = sum_{p >= k} W_p``.  For i <= j the tail starts at j, so with
        X_j = Delta_j Wbar_j the upper triangle is the Frobenius product
        <Delta_i, X_j>; D is symmetric.  Rotor inertias add to the diagonal.
        """
        B, n = Delta.shape[:2]
        X = Delta @ Wbar                                         # X_j = Delta_j Wbar_j
        G = Delta.reshape(B, n, 16) @ X.reshape(B, n, 16).swapaxes(1, 2)   # <Delta_i, X_j>
        D = np.where(self._upper, G, G.swapaxes(1, 2))
        if self._has_armature:
            D += self._armature_diag
        return D

    def _h(self, Delta, W, qd, qdd=None):
        """h_i = sum_jk D_ijk qd_j qd_k (eq. 2.39), regrouped by link p.

        sum_{j,k<=p} d2T_p/dq_j dq_k qd_j qd_k = A_p T_p with
        A_p = sum_{k<=p} (2 Omega_{k-1} + Delta_k qd_k) Delta_k qd_k, so
        h_i = tr(F_i Delta_i^T), F_i = sum_{p>=i} A_p W_p.

        With ``qdd`` given, ``sum_{j<=p} Delta_j qdd_j`` joins A_p, and the
        same trace is ``(D qdd)_i + h_i`` without the rotor term (the
        ``sum_j D_ij qdd_j`` of eq. 2.37, in the same pass).
        """
        A = self._accel_terms(Delta, qd, qdd)                  # A_p
        F = _link_sum(self._tail, A @ W)                       # F_i
        B, n = qd.shape
        return (F.reshape(B, n, 1, 16) @ Delta.reshape(B, n, 16, 1))[..., 0, 0]

    def _accel_terms(self, Delta, qd, qdd=None):
        """``A_p`` (B, n, 4, 4) of :meth:`_h`: the velocity (and acceleration) terms of link p."""
        V = Delta * qd[:, :, None, None]                       # Delta_k qd_k
        Omega2 = _link_sum(self._head_strict2, V)              # 2 sum_{j<k} Delta_j qd_j
        X = (Omega2 + V) @ V
        if qdd is not None:
            X += Delta * qdd[:, :, None, None]                 # Delta_k qdd_k
        return _link_sum(self._head, X)

    def _g(self, Delta, cbar):
        """g_i = -sum_{p>=i} m_p g^T (dT_p/dq_i) r_bar_p (eq. 2.39, D_i).

        ``cbar`` (B, n, 4, 1) holds the tail sums ``sum_{p>=i} m_p T_p r_bar_p``:
        the last column of ``Wbar_i`` (``W_p e4 = T_p J_p e4``, since
        ``T_p^T e4 = e4``), or :meth:`_cbar` when W is not at hand.
        """
        gD = self._g4 @ Delta                                  # g^T Delta_i, (B, n, 4)
        return -(gD[..., None, :] @ cbar)[..., 0, 0]

    def _cbar(self, T):
        """Tail sums of m_p T_p r_bar_p (the last column of J_p is m_p r_bar_p), (B, n, 4, 1)."""
        return _link_sum(self._tail, T @ self._mr[:, :, None])

    def _friction(self, qd):
        if self._law is not None:
            return self._friction_law(qd)
        if self.friction is None:
            return 0.0
        return self.friction[0] * qd + self.friction[1] * np.sign(qd)

    def _friction_law(self, qd):
        """The friction law, coded for this engine (:func:`manipdyn.engines.lagrange.drive.friction_torque`)."""
        return friction_torque(self._law, None if self.transmission is None else self.transmission.R, qd)

    # -- batching ------------------------------------------------------------
    def _run(self, kernel, single, *arrays, what: str = "trace form", names=(), chunk=None):
        """Apply a batch kernel to (B, n) arrays, :data:`CHUNK` states at a time.

        Small blocks keep every temporary (B * n * 16 doubles) in reused heap
        memory instead of fresh pages: on a batch of 1000 states this is about
        twice as fast as one pass.  ``single`` strips the batch axis again.
        """
        B = arrays[0].shape[0]
        CHUNK = self._chunk if chunk is None else chunk
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported below, by state
            if B <= CHUNK:
                out = kernel(*arrays)
            else:
                parts = [kernel(*(a[k:k + CHUNK] for a in arrays)) for k in range(0, B, CHUNK)]
                if isinstance(parts[0], tuple):
                    out = tuple(np.concatenate(p) for p in zip(*parts))
                else:
                    out = np.concatenate(parts)
        for x in (out if isinstance(out, tuple) else (out,)):
            if not _isfinite(np.add.reduce(x.reshape(-1))):  # finite states in: say where it overflowed
                check_result(x, what, **{nm: (a[0] if single else a) for nm, a in zip(names, arrays)})
        if single:
            return tuple(x[0] for x in out) if isinstance(out, tuple) else out[0]
        return out

    def _call(self, kernel, what: str, chunk=None, **named):
        """Validate the named states and run ``kernel`` on them as a batch (:meth:`_run`).

        ``what`` is the public method's name, for overflow messages.
        """
        single, arrays = self._states(**named)
        return self._run(kernel, single, *arrays, what=what, names=tuple(named), chunk=chunk)

    def _states(self, **named):
        """Validate named states; return ``(single, [batch arrays])`` in order."""
        arrays = [as_state(v, k, self.n) for k, v in named.items()]
        if len(arrays) > 1:
            same_batch(*zip(arrays, named))
        return arrays[0].ndim == 1, [a[None] if a.ndim == 1 else a for a in arrays]

    # -- batch kernels (B, n) -> (B, ...) ---------------------------------------
    def _k_mass(self, q):
        _, Delta, W = self._frames(q)
        return self._D(Delta, _link_sum(self._tail, W))

    def _k_coriolis(self, q, qd):
        _, Delta, W = self._frames(q)
        return self._h(Delta, W, qd)

    def _k_gravity(self, q):
        T, Delta = self._kin.frames(q)
        return self._g(Delta, self._cbar(T))

    def _k_terms(self, q, qd):
        _, Delta, W = self._frames(q)
        Wbar = _link_sum(self._tail, W)
        return self._D(Delta, Wbar), self._h(Delta, W, qd), self._g(Delta, Wbar[..., 3:])

    def _k_inverse(self, q, qd, qdd):
        # tau = D qdd + h + g (eq. 2.39): D qdd and h in one pass (see _h)
        _, Delta, W = self._frames(q)
        Wbar3 = _link_sum(self._tail, W[..., 3:])
        tau = self._h(Delta, W, qd, qdd) + self._g(Delta, Wbar3) + self._friction(qd)
        if self._rotor_full is not None:
            tau += qdd @ self._rotor_full
        elif self._has_armature:
            tau += self.armature * qdd
        return tau

    def _k_forward(self, q, qd, tau):
        _, Delta, W = self._frames(q)
        Wbar = _link_sum(self._tail, W)
        rhs = tau - self._h(Delta, W, qd) - self._g(Delta, Wbar[..., 3:]) - self._friction(qd)
        D = self._D(Delta, Wbar)
        try:
            return np.linalg.solve(D, rhs[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise SingularMassMatrixError.for_mass_matrix(D) from None

    def _k_kinetic(self, q, qd):
        T, Delta = self._kin.frames(q)
        Omega = _link_sum(self._head, Delta * qd[:, :, None, None])  # sum_{j<=i} Delta_j qd_j
        Tdot = Omega @ T                                              # dT_i/dt (eq. 2.13)
        K = 0.5 * np.einsum("biac,icd,biad->b", Tdot, self.J, Tdot)  # eq. 2.22
        if self._rotor_full is not None:                              # coupled rotors
            return K + 0.5 * np.einsum("bi,ij,bj->b", qd, self._rotor_full, qd)
        return K + 0.5 * (qd**2) @ self.armature                     # rotors

    def _k_potential(self, q):
        T, _ = self._kin.frames(q)
        return -np.einsum("a,bpac,pc->b", self._g4, T, self._mr)     # eq. 2.24

    # -- public API ---------------------------------------------------------
    def mass_matrix(self, q) -> np.ndarray:
        """Inertia matrix D(q) (eq. 2.39, D_ij), (n, n) or (N, n, n), SI units."""
        return self._call(self._k_mass, "mass_matrix", q=q)

    def coriolis_torque(self, q, qd) -> np.ndarray:
        """Coriolis and centripetal torque h(q, qd) (eq. 2.39, D_ijk), (n,) or (N, n).

        Friction, if the model has it, is not included (see :meth:`friction_torque`).
        """
        return self._call(self._k_coriolis, "coriolis_torque", q=q, qd=qd)

    def gravity_torque(self, q) -> np.ndarray:
        """Gravity torque g(q) (eq. 2.39, D_i): the torque that holds the arm still."""
        return self._call(self._k_gravity, "gravity_torque", q=q)

    def friction_torque(self, qd) -> np.ndarray:
        """Joint friction ``Fv qd + Fc sign(qd)``, outside the Lagrangian (zero if none)."""
        qd = as_state(qd, "qd", self.n)
        return check_result(np.zeros_like(qd) + self._friction(qd), "friction_torque", qd=qd)

    def dynamics_terms(self, q, qd):
        """``(D, h, g)`` in one pass over the kinematics (the cheap way to get all three)."""
        return self._call(self._k_terms, "dynamics_terms", q=q, qd=qd)

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """Joint torques ``tau = D qdd + h + g`` (eq. 2.39), plus friction if modelled."""
        return self._call(self._k_inverse, "inverse_dynamics", q=q, qd=qd, qdd=qdd)

    def forward_dynamics(self, q, qd, tau) -> np.ndarray:
        """Joint accelerations solving ``D qdd = tau - h - g`` (minus friction)."""
        return self._call(self._k_forward, "forward_dynamics", q=q, qd=qd, tau=tau)

    def kinetic_energy(self, q, qd) -> np.ndarray:
        """Kinetic energy K (eq. 2.22, plus rotors), J; scalar or (N,).

        Computed from the trace of eq. 2.22 directly, ``K = 1/2 sum_i
        tr(Tdot_i J_i Tdot_i^T)`` with ``Tdot_i = (sum_j Delta_j qd_j) T_i``,
        not from D, so that ``K = qd^T D qd / 2`` is a real check.
        """
        return self._call(self._k_kinetic, "kinetic_energy", q=q, qd=qd)

    def potential_energy(self, q) -> np.ndarray:
        """Potential energy P = -sum_i m_i g^T T_i r_bar_i (eq. 2.24), J; scalar or (N,)."""
        return self._call(self._k_potential, "potential_energy", q=q)

    # -- regressor ----------------------------------------------------------------
    def regressor(self, q, qd, qdd, armature: bool = False, friction: bool = False) -> np.ndarray:
        """Inverse-dynamics regressor ``Y`` with ``Y @ pi = tau``, (n, p) or (N, n, p).

        Derived from the trace form, in closed form.  Eq. 2.39 regrouped by
        link (see :meth:`_h`, :meth:`_g`) reads

            tau_i = sum_{p >= i} tr(A_p W_p Delta_i^T) - g^T Delta_i W_p e_4,
            W_p = T_p J_p T_p^T,

        with ``A_p`` holding the velocity and acceleration terms.  Each term is
        linear in ``J_p``: with the Frobenius product ``<X, Y> = tr(X^T Y)``,
        ``tau_i = sum_{p >= i} <M_ip, W_p>``, ``M_ip = A_p^T Delta_i -
        (Delta_i^T g) e_4^T``.  Writing ``J_p = sum_k pi_pk E_k`` (the ten
        basis matrices :data:`manipdyn.model.parameters.PARAMETER_BASIS`, J of a unit
        parameter) in link p's URDF frame ``L_p = T_p S_p^-1`` gives

            dtau_i / dpi_pk = <M_ip, L_p E_k L_p^T> = <L_p^T M_ip L_p, E_k>
                              (p >= i; 0 for p < i),

        no finite differences.  Parameters: :mod:`manipdyn.model.parameters` (10 per
        link, Pinocchio's order, about the URDF link frame's origin), then
        ``armature`` (n columns ``qdd_j``) and ``friction`` (2n columns
        ``qd_j``, ``sign(qd_j)``) when asked for.  SI units.
        """
        single, arrays = self._states(q=q, qd=qd, qdd=qdd)
        Y = self._run(self._k_regressor, single, *arrays, names=("q", "qd", "qdd"))
        qd_, qdd_ = (arrays[1][0], arrays[2][0]) if single else (arrays[1], arrays[2])
        return with_extra_columns(Y, qd_, qdd_, armature, friction, self.transmission)

    def _k_regressor(self, q, qd, qdd):
        T, Delta = self._kin.frames(q)
        B, n = qd.shape
        A = self._accel_terms(Delta, qd, qdd)                      # A_p, (B, n, 4, 4)
        L = T if self._S_inv is None else T @ self._S_inv          # URDF link frames L_p
        # M_ip = A_p^T Delta_i - (Delta_i^T g) e_4^T, indexed [b, p, i]
        M = np.swapaxes(A, -1, -2)[:, :, None] @ Delta[:, None, :]
        M[..., 3] -= (self._g4 @ Delta)[:, None, :, :]
        # <M_ip, L_p E_k L_p^T> = <L_p^T M_ip L_p, E_k>: one product with the constant basis
        N = np.swapaxes(L, -1, -2)[:, :, None] @ M @ L[:, :, None]
        Yp = N.reshape(B, n, n, 16) @ PARAMETER_BASIS.reshape(10, 16).T   # [b, p, i, k]
        Yp *= self._upper.T[None, :, :, None]                      # only p >= i
        return Yp.transpose(0, 2, 1, 3).reshape(B, n, 10 * n)

    # -- kinematics passthrough -------------------------------------------
    def link_poses(self, q) -> np.ndarray:
        """Link frames T_1..T_n in the base frame (eq. 2.7), (n, 4, 4) or (N, n, 4, 4)."""
        return self._call(self._kin.poses, "link_poses", q=q)

    def fkine(self, q) -> np.ndarray:
        """Pose of the tool frame in the base frame, (4, 4) or (N, 4, 4): DH frame n (``T_n``, eq. 2.7), or a
        URDF chain's tip link (its last link frame times the fixed tool transform)."""
        return self._call(lambda x: self._kin.tool(self._kin.poses(x)), "trace form", q=q)

    # -- Coriolis matrix ---------------------------------------------------------
    def christoffel_symbols(self, q) -> np.ndarray:
        """The chapter's ``D_ijk`` (eq. 2.39), ``(n, n, n)`` or ``(N, n, n, n)``, index ``[i, j, k]``.

        ``D_ijk = sum_{p >= max(i,j,k)} tr(d2T_p/dq_j dq_k J_p dT_p/dq_i^T)``.  With
        ``d2T_p/dq_j dq_k = Delta_j Delta_k T_p`` (``j <= k <= p``) this is
        ``<Delta_j Delta_k, Delta_i Wbar_{max(i,k)}>`` (Frobenius product) for
        ``j <= k``, and ``D_ijk = D_ikj`` (mixed partials commute).  These are
        the Christoffel symbols of the first kind of ``D`` (see
        :meth:`coriolis_matrix`; ``tests/test_coriolis.py`` proves it).
        O(n^3) small traces: for tests and analysis, not for control loops.
        """
        # n^3 numbers per state: fewer states per block
        return self._call(self._k_christoffel, "christoffel_symbols", chunk=self._chunk3, q=q)

    def _k_christoffel(self, q):
        _, Delta, W = self._frames(q)
        B, n = Delta.shape[:2]
        Wbar = _link_sum(self._tail, W)
        idx = np.arange(n)
        m = np.maximum(idx[:, None], idx[None, :])                    # max(i, k)
        R = (Delta[:, :, None] @ Wbar[:, m]).reshape(B, n, n, 16)    # Delta_i Wbar_max(i,k)
        P = (Delta[:, :, None] @ Delta[:, None, :]).reshape(B, n, n, 16)  # Delta_j Delta_k
        E = np.einsum("bjkx,bikx->bijk", P, R)
        jk_upper = idx[:, None] <= idx[None, :]
        return np.where(jk_upper, E, E.swapaxes(2, 3))

    def coriolis_matrix(self, q, qd) -> np.ndarray:
        """Coriolis matrix ``C(q, qd)`` (Christoffel form), ``(n, n)`` or ``(N, n, n)``, N m s.

        ``C qd = h`` (eq. 2.39) and ``dD/dt - 2C`` is skew-symmetric.

        Derivation.  Differentiate ``D_ij`` (eq. 2.39) with the product rule and
        move the transpose inside the trace (``tr(A J B^T) = tr(B J A^T)``,
        ``J = J^T``, eq. 2.27 to 2.30)::

            dD_ij/dq_k = D_ijk + D_jik.

        The Christoffel symbols of the first kind of ``D`` are
        ``c_ijk = (dD_ij/dq_k + dD_ik/dq_j - dD_jk/dq_i) / 2``.  Substituting,
        and using ``D_ijk = D_ikj`` (``d2T_p/dq_j dq_k`` is symmetric)::

            c_ijk = (D_ijk + D_jik + D_ikj + D_kij - D_jki - D_kji) / 2
                  = (2 D_ijk + (D_jik - D_jki) + (D_kij - D_kji)) / 2 = D_ijk.

        So the chapter's ``D_ijk`` ARE the Christoffel symbols (a kinetic energy
        that is a sum of ``|r_dot|^2`` over mass points gives
        ``c_ijk = sum <d2r/dq_j dq_k, dr/dq_i> dm``), and the Christoffel
        Coriolis matrix is ``C_ij = sum_k D_ijk qd_k``.  Hence
        ``C qd = sum_jk D_ijk qd_j qd_k = h`` and
        ``(dD/dt)_ij = sum_k (D_ijk + D_jik) qd_k = C_ij + C_ji``, so
        ``dD/dt - 2C = C^T - C`` is skew-symmetric.  The rotor inertias are
        constant and add nothing to C.

        Fast form (CONVENTIONS.md, "Computing the trace form fast").  With
        ``S_m = sum_{k <= m} Delta_k qd_k`` (so ``T_p_dot = S_p T_p``),
        ``sum_k d2T_p/dq_j dq_k qd_k = (S_{j-1} Delta_j + Delta_j (S_p - S_{j-1})) T_p
        = (Delta_j_dot + Delta_j S_p) T_p`` with ``Delta_j_dot = [S_{j-1}, Delta_j]``
        (the time derivative of ``dT_p/dq_j``).  Summing over links ``p >= max(i, j)``
        with ``W_p = T_p J_p T_p^T``, ``Wbar_m = sum_{p >= m} W_p`` and
        ``Ubar_m = sum_{p >= m} S_p W_p``::

            C_ij = <Delta_i, Delta_j_dot Wbar_m + Delta_j Ubar_m>,  m = max(i, j),

        which for ``i <= j`` is ``<Delta_i, Y_j>`` with ``Y_j`` per column, and for
        ``i > j`` is ``<Delta_j_dot, Delta_i Wbar_i> + <Delta_j, Delta_i Ubar_i^T>``
        per row: n^2 traces, every step batched.
        """
        return self._call(self._k_coriolis_matrix, "coriolis_matrix", q=q, qd=qd)

    def _k_coriolis_matrix(self, q, qdb):
        _, Delta, W = self._frames(q)
        B, n = qdb.shape
        V = Delta * qdb[:, :, None, None]                      # Delta_k qd_k
        S = _link_sum(self._head, V)                           # S_p
        Sprev = S - V                                          # S_{j-1}
        Ddot = Sprev @ Delta - Delta @ Sprev                   # Delta_j_dot
        Wbar = _link_sum(self._tail, W)
        Ubar = _link_sum(self._tail, S @ W)
        flat = Delta.reshape(B, n, 16)
        Y = (Ddot @ Wbar + Delta @ Ubar).reshape(B, n, 16)     # column j, i <= j
        upper = flat @ Y.swapaxes(1, 2)
        rows = np.concatenate(((Delta @ Wbar).reshape(B, n, 16),
                               (Delta @ Ubar.swapaxes(-1, -2).copy()).reshape(B, n, 16)), axis=2)
        cols = np.concatenate((Ddot.reshape(B, n, 16), flat), axis=2)
        lower = rows @ cols.swapaxes(1, 2)                     # row i, i > j
        return np.where(self._upper, upper, lower)


def trace_form_engine(arm) -> TraceFormEngine:
    """The trace-form engine of ``arm`` (the factory behind ``arm.lagrange``)."""
    kin, J, armature, friction = arm.trace_form_data()
    # a DH arm's trace form runs in DH frames, its URDF (and regressor) in URDF link frames
    return TraceFormEngine(kin, J, arm.gravity, armature=armature, friction=friction,
                           link_offsets=arm.urdf_link_offsets(), transmission=arm.transmission,
                           motor_inertia=arm.motor_inertia)

