"""The single-state shortcuts of the Pinocchio engine, and its unchecked view.

Layer 3 (engines: pinocchio), part of :mod:`manipdyn.engines.pinocchio.engine` (which alone uses it).

Single-state calls are the hot path of control loops, so they get shortcuts
(see :func:`install_fast_path`), installed per engine as closures: no method
frame, no attribute look-ups.  A shortcut is taken only for plain 1-D
ndarrays of native float64 (``dtype is float64``: a big-endian or any other
dtype, a subclass such as a masked array, or another rank goes down the
general path, which converts or refuses it).  Pinocchio itself rejects a
wrong length (the general path then explains the error), and eigenpy reads
strided 1-D arrays correctly (tests/test_fast_path_dtypes.py proves both).

Finiteness is read off the answer, which is cheaper than testing the inputs
(``item`` of one element against ``sum(x.tolist())``): a NaN or inf anywhere in
(q, qd, qdd) or (q, qd, tau) reaches the first entry of the RNEA/ABA answer,
because every body's motion is carried through the dense transforms of the
joints before it and every body's force back through those to joint 1
(IEEE: 0 * NaN is NaN, 0 * inf is NaN).  D(q) and g(q) do not depend on q_1,
but q_2..q_n reach D_11 and g_1 (the composite body beyond joint 1), so there
``D_11 * q_1`` is tested (a product that overflows only sends the call down
the general path).  tests/test_fast_path_dtypes.py puts NaN and inf in every
entry of every argument on DH and URDF arms, revolute and prismatic.  A
non-finite answer, or any error, sends the call down the general path, which
names the offending argument.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pinocchio as pin

__all__ = ["install_fast_path", "UncheckedView"]

_isfinite = math.isfinite
_F64 = np.dtype(np.float64)  # native byte order: '>f8' is another object
_ND = np.ndarray  # exactly: a masked array's data would reach Pinocchio without its mask
_crba, _rnea, _aba, _gravity = pin.crba, pin.rnea, pin.aba, pin.computeGeneralizedGravity
_FAST_ERRORS = (AttributeError, TypeError, ValueError)


def install_fast_path(eng) -> None:
    """Shadow the five dynamics methods of ``eng`` by closures with a single-state shortcut.

    Each closure falls back to the class's method (the general path) for
    anything but plain native-float64 ndarrays with finite values (module
    docstring).  Same names, signatures and docstrings.
    """
    cls = type(eng)
    model, data, model0, data0, zeros = eng.model, eng.data, eng._model0, eng._data0, eng._zeros
    ND, F64, isf, errors = _ND, _F64, _isfinite, _FAST_ERRORS
    crba, rnea, aba, grav = _crba, _rnea, _aba, _gravity
    g_mass, g_cor, g_grav, g_id, g_fd = (getattr(cls, nm).__get__(eng) for nm in (
        "mass_matrix", "coriolis_torque", "gravity_torque", "inverse_dynamics", "forward_dynamics"))

    def state_only(call, model, data, general):
        # D and g do not depend on q_1: q_1's finiteness is read off the product
        def f(q):
            try:
                if type(q) is ND and q.dtype is F64 and q.ndim == 1:
                    r = call(model, data, q)
                    # q_2..q_n non-finite -> r_1 non-finite; q_1 (no effect on D or g) by the product
                    if isf(r.item(0) * q.item(0)):
                        return r
            except errors:
                pass
            return general(q)
        return f

    def three_states(call, model, data, general):
        # RNEA / ABA: a NaN or inf in any argument reaches the first output
        def f(q, qd, x):
            try:
                if (type(q) is type(qd) is type(x) is ND and q.dtype is qd.dtype is x.dtype is F64
                        and q.ndim == qd.ndim == x.ndim == 1):
                    r = call(model, data, q, qd, x)
                    if isf(r.item(0)):
                        return r
            except errors:
                pass
            return general(q, qd, x)
        return f

    def coriolis_torque(q, qd):
        try:
            if (type(q) is type(qd) is ND and q.dtype is qd.dtype is F64
                    and q.ndim == qd.ndim == 1):
                h = rnea(model0, data0, q, qd, zeros)
                if isf(h.item(0)):
                    return h
        except errors:
            pass
        return g_cor(q, qd)

    mass_matrix = state_only(crba, model, data, g_mass)
    gravity_torque = state_only(grav, model, data, g_grav)
    inverse_dynamics = three_states(rnea, model, data, g_id)
    forward_dynamics = three_states(aba, model, data, g_fd)

    fast = {"coriolis_torque": coriolis_torque, "gravity_torque": gravity_torque}
    if eng._O is None:  # coupled rotors: the general path adds them
        fast["mass_matrix"] = mass_matrix
    if eng.friction is None and not eng.drive_extras:  # with friction, the general path adds it
        fast.update(inverse_dynamics=inverse_dynamics, forward_dynamics=forward_dynamics)
    for name, fn in fast.items():
        fn.__doc__ = getattr(cls, name).__doc__
        fn.__qualname__ = f"{cls.__name__}.{name}"
        eng.__dict__[name] = fn


class UncheckedView:
    """``engine.unchecked``: the same single-state calls with no validation at all.

    For hot loops that have validated their inputs once (like MuJoCo's
    ``skip_checks``).  Each attribute is Pinocchio's function with the model
    and data bound (``functools.partial``), so a call costs what the raw
    ``pin.rnea`` / ``pin.crba`` costs.  The contract is the caller's:

    * one state at a time, ``(n,)`` ndarrays of native float64 (a big-endian
      or integer array is NOT converted: the answer may be silently wrong);
    * NaN and inf are not detected and propagate into the answer;
    * a wrong size raises Pinocchio's own error (not a :class:`StateError`);
    * the returned array is new (caller-owned), as with the checked path.

    Attributes: ``mass_matrix(q)``, ``coriolis_torque(q, qd)``,
    ``gravity_torque(q)``, ``inverse_dynamics(q, qd, qdd)``,
    ``forward_dynamics(q, qd, tau)``, with the engine's friction applied as
    in the checked path.  With drive extras (coupled rotors or a friction law
    beyond the links' kind, ``engine.drive_extras``) the dynamics calls are the
    checked ones.

    The derivatives (issue 34): ``inverse_dynamics_derivatives(q, qd, qdd)``,
    ``forward_dynamics_derivatives(q, qd, tau)`` and ``gravity_derivative(q)``, the
    checked shortcuts' code without their tests (so the same bits, friction law
    included; :func:`manipdyn.engines.pinocchio.derivatives.install_derivative_shortcuts`).
    They do not detect a singular D(q) either: Minv then holds inf or NaN.  With coupled
    rotors ``forward_dynamics_derivatives`` is the checked call.
    """

    def __init__(self, eng, derivatives=None):
        model, data, model0, data0, zeros = eng.model, eng.data, eng._model0, eng._data0, eng._zeros
        self.n = eng.n
        self.mass_matrix = functools.partial(_crba, model, data)
        self.gravity_torque = functools.partial(_gravity, model, data)

        def coriolis_torque(q, qd):
            return _rnea(model0, data0, q, qd, zeros)

        self.coriolis_torque = coriolis_torque
        fr = eng.friction
        if not not eng.drive_extras:   # coupled rotors or a friction law: the checked calls (one state each)
            self.mass_matrix, self.inverse_dynamics, self.forward_dynamics = (
                getattr(type(eng), nm).__get__(eng) for nm in ("mass_matrix", "inverse_dynamics", "forward_dynamics"))
        elif fr is None:
            self.inverse_dynamics = functools.partial(_rnea, model, data)
            self.forward_dynamics = functools.partial(_aba, model, data)
        else:
            fv, fc = fr[0].copy(), fr[1].copy()
            sign = np.sign

            def inverse_dynamics(q, qd, qdd):
                return _rnea(model, data, q, qd, qdd) + (fv * qd + fc * sign(qd))

            def forward_dynamics(q, qd, tau):
                return _aba(model, data, q, qd, tau - (fv * qd + fc * sign(qd)))

            self.inverse_dynamics = inverse_dynamics
            self.forward_dynamics = forward_dynamics
        for name, fn in (derivatives or {}).items():
            setattr(self, name, fn)

    def __repr__(self) -> str:
        return f"<unchecked Pinocchio calls, {self.n} joints>"
