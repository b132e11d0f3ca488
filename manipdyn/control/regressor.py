"""The dynamics as linear in the inertial parameters: ``tau = Y pi``.

Layer 6 (control).

Parameters per link (10, Pinocchio's order, ``pin.Inertia.toDynamicParameters``)::

    [m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]

with ``c`` the centre of mass and ``I`` the inertia TENSOR (tensor sign,
``I_xy = -integral x y dm``) about the ORIGIN of the link's URDF frame (the
frame of the joint that moves the link; :meth:`manipdyn.Arm.chain`).  For a
modified-DH arm that frame is DH frame i; for a standard-DH arm it is DH frame
i moved back by ``S_i = Trans_x(a_i) Rot_x(alpha_i)``.  These are the ten
independent entries of the link's pseudo-inertia (eq. 2.20, 2.21)
``J = [[S, m c], [m c^T, m]]`` in that frame, converted by
:func:`manipdyn.model.inertia.parameters_from_pseudo_inertia` and
:func:`manipdyn.model.inertia.pseudo_inertia_from_parameters` (re-exported here).

After the 10 n link parameters come, when the arm has them, one armature
(reflected rotor inertia ``G^2 Jm``) per joint, whose regressor column is
``qdd_j``, and one viscous and one Coulomb friction coefficient per joint
(columns ``qd_j`` and ``sign(qd_j)``): Pinocchio's regressor covers the rigid
bodies only.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .._support.state import as_state
from ..model.inertia import LINK_PARAMETERS, parameters_from_pseudo_inertia, pseudo_inertia_from_parameters
from ..model.parameters import arm_parameters, parameter_count, parameter_names

__all__ = ["Regressor", "parameters_from_pseudo_inertia", "pseudo_inertia_from_parameters",
           "LINK_PARAMETERS"]

class Regressor:
    """Regressors of an arm's inverse dynamics, from Pinocchio's joint-torque regressor.

    Parameters
    ----------
    arm : manipdyn.Arm
        Gives the kinematics (the regressor does not depend on the inertias) and
        :meth:`parameters`, the arm's own parameter vector.
    armature, friction : bool or None
        Append armature columns (n) and friction columns (2n).  ``None``
        (default): when the arm has any armature (friction).

    ``Y(q, qd, qr_d, qr_dd) @ pi = D(q) qr_dd + C(q, qd) qr_d + g(q)`` (+ friction
    ``Fv qd + Fc sign(qd)``), with C the Christoffel Coriolis matrix: the
    regressor of Slotine and Li (1987).  With ``qr = qd`` it is the ordinary
    inverse-dynamics regressor.
    """

    @staticmethod
    def default_flags(arm, armature=None, friction=None) -> tuple[bool, bool]:
        """``(armature, friction)``: the given flags, or by default whether the arm has any."""
        return (bool(np.any(arm.armature)) if armature is None else bool(armature),
                (arm.friction is not None) if friction is None else bool(friction))

    def __init__(self, arm, armature=None, friction=None):
        self.n = n = arm.n
        self._arm = arm
        self.armature, self.friction = self.default_flags(arm, armature, friction)
        model = arm.pinocchio.model
        # Two copies of the model: gravity x4 and gravity 0 (see __call__)
        self._m4, self._m0 = model.copy(), model.copy()
        self._m4.gravity.linear = 4.0 * np.asarray(model.gravity.linear)
        self._m0.gravity.linear = np.zeros(3)
        self._d4, self._d0 = self._m4.createData(), self._m0.createData()
        self.p = parameter_count(n, self.armature, self.friction)
        self._Y = np.zeros((n, self.p))
        self._Ylinks = self._Y[:, :10 * n]
        self._Yflat = self._Y.reshape(-1)            # a view: Y is contiguous
        rows = np.arange(n) * self.p + np.arange(n)  # flat index of Y[j, j]
        col = 10 * n
        if self.armature:
            self._arm_idx = rows + col
            col += n
        if self.friction:
            self._fv_idx, self._fc_idx = rows + col, rows + col + n

    @property
    def names(self) -> list[str]:
        """Parameter names, e.g. ``"link3.mcx"``, ``"joint2.armature"``, ``"joint1.fv"``."""
        return parameter_names(self.n, self.armature, self.friction)

    def parameters(self, arm=None) -> np.ndarray:
        """The parameter vector ``pi`` (p,) of ``arm`` (default: the regressor's own arm).

        :func:`manipdyn.model.parameters.arm_parameters` (the layout both engines'
        ``regressor`` methods use), with armature and friction as configured.
        """
        arm = self._arm if arm is None else arm
        if arm.n != self.n:
            raise ValueError(f"arm: expected {self.n} joints, got {arm.n}")
        return arm_parameters(arm, self.armature, self.friction)

    def __call__(self, q, qd, qr_d, qr_dd) -> np.ndarray:
        """Slotine-Li regressor ``Y`` (n, p) at one state; a new array each call.

        Pinocchio's ``R(v, a) = computeJointTorqueRegressor(q, v, a)`` is
        ``Y_D(q) a + Y_h(q; v, v) + Y_g(q)``, quadratic in v and linear in a
        and in gravity.  Polarisation gives the mixed term
        ``Y_h(q; qd, qr_d) = (Y_h(qd + qr_d) - Y_h(qd - qr_d)) / 4``, which is
        ``C(q, qd) qr_d`` because the chapter's ``D_ijk`` (Christoffel symbols)
        are symmetric in j, k.  With gravity scaled x4 in one model and 0 in
        the other, two calls suffice::

            Y = (R_4g(qd + qr_d, 2 qr_dd) - R_0(qd - qr_d, -2 qr_dd)) / 4.
        """
        n = self.n
        q = as_state(q, "q", n)
        qd = as_state(qd, "qd", n)
        qr_d = as_state(qr_d, "qr_d", n)
        qr_dd = as_state(qr_dd, "qr_dd", n)
        if q.ndim != 1 or qd.ndim != 1 or qr_d.ndim != 1 or qr_dd.ndim != 1:
            raise ValueError("Regressor: one state at a time, each argument of shape (n,)")
        return self._unchecked(q, qd, qr_d, qr_dd).copy()

    def _unchecked(self, q, qd, qr_d, qr_dd) -> np.ndarray:
        """:meth:`__call__` for validated (n,) float arrays; returns the internal buffer
        (valid until the next call): the controllers' hot path."""
        a2 = 2.0 * qr_dd
        R4 = pin.computeJointTorqueRegressor(self._m4, self._d4, q, qd + qr_d, a2)
        R0 = pin.computeJointTorqueRegressor(self._m0, self._d0, q, qd - qr_d, -a2)
        Y = self._Y
        np.subtract(R4, R0, out=self._Ylinks)
        self._Ylinks *= 0.25
        flat = self._Yflat
        if self.armature:
            flat[self._arm_idx] = qr_dd
        if self.friction:
            flat[self._fv_idx] = qd
            flat[self._fc_idx] = np.sign(qd)
        return Y

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """The ordinary regressor: ``Y(q, qd, qdd) @ pi = tau`` of inverse dynamics.

        The same matrix as ``arm.pinocchio.regressor(q, qd, qdd, armature, friction)``
        (one state), which also takes batches.
        """
        return self(q, qd, qd, qdd)
