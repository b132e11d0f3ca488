"""The friction law's derivative as both engines read it: :func:`friction_jacobian`.

Layer 1 (model).

The engines' derivatives (:mod:`manipdyn.engines.lagrange.derivatives`,
:mod:`manipdyn.engines.pinocchio.derivatives`) share no code with each other; the one
term they both take from here is ``dF/dqd`` of the friction, which belongs to the
model (:class:`manipdyn.Friction` owns its law and its derivative).  The
cross-check therefore compares their rigid-body derivatives independently, not
this term.
"""

from __future__ import annotations

import math

import numpy as np

from .._support.errors import ModelError

__all__ = ["friction_jacobian", "SingleStateFriction"]


def friction_jacobian(law, table, qd, n: int, transmission=None):
    """``dF/dqd`` (..., n, n) of an engine's friction at velocities ``qd`` (..., n), or None.

    ``law``: a :class:`Friction` (its :meth:`Friction.derivative`, motor side
    ``R^T diag(f') R`` through ``transmission``), else ``table``: the links'
    ``[Fv, Fc]`` (2, n) of viscous plus sharp Coulomb friction, whose derivative is
    ``diag(Fv)`` (the sharp sign has none at 0 and is constant elsewhere), else None.
    Both engines read the friction law's derivative here, from the model layer: the
    cross-check compares their rigid-body derivatives independently, not this one.
    """
    if law is not None:
        return law.derivative(qd, transmission)
    if table is None:
        return None
    return np.zeros(np.shape(qd) + (n,)) + np.diag(table[0])


class SingleStateFriction:
    """The friction law's torque and derivative at ONE velocity, for the engines' fast paths.

    Built once per engine from a frozen :class:`manipdyn.Friction` and the
    transmission; :meth:`__call__` takes a plain ``(n,)`` float64 ``qd`` and
    returns ``(F, J)``: the joint torque ``F`` (n,), N m, and ``dF/dqd`` as ``J``,
    either its diagonal (n,) (a joint-side law: ``dF/dqd = diag(J)``) or the
    full (n, n) (motor side: ``R^T diag(f') R``).

    The laws it writes out itself (viscous, smooth or sharp symmetric Coulomb
    without a deadband, offsets, Gaz's sigmoid) cost a handful of operations
    prepared at construction.  A joint-side law becomes two straight-line Python
    functions of the velocities as floats (``torque_jacobian_floats``,
    ``jacobian_floats``, ``tau_jacobian_floats``: one expression per joint, the law's constants written
    in as exact float literals, no loop, no array), the sigmoid as
    ``(1 + tanh(x / 2)) / 2``: within a few ulp of the law's numbers (tests hold
    it to 1e-14 of the largest entry).  A motor-side law runs the law's own array
    operations in its order (the same bits); any other law (asymmetric, Stribeck,
    with a deadband) answers through :meth:`Friction.torque` and
    :meth:`Friction.derivative`.
    """

    def __init__(self, law, transmission=None):
        self.law, self.transmission = law, transmission
        self.n = n = law.n
        self.R = None
        if law.side != "joint":
            if transmission is None or transmission.n != n:
                raise ModelError("friction: a motor-side law needs the transmission of its "
                                 f"{n} motors (qd_m = R qd)")
            self.R = np.asarray(transmission.R, dtype=np.float64)
        terms = set(law.terms)
        self.general = bool(terms - {"viscous", "coulomb", "offset", "sigmoid"}) or bool(law.deadband)
        z = np.zeros(n)
        self.fv = z + law.viscous if law.viscous is not None else None
        self.fc = z + law.coulomb if law.coulomb is not None else None
        self.eps = float(law.smoothing)
        self.off = z + law.offset if law.offset is not None else None
        if law.sigmoid_A is not None:
            A, al, p3 = (z + x for x in (law.sigmoid_A, law.sigmoid_alpha, law.sigmoid_p3))
            s0 = np.exp(-np.logaddexp(0.0, -(al * p3)))          # the logistic at v = 0 (the law's zero)
            self.sig = (al, p3, A, s0, A * al)
        else:
            self.sig = None
        self.RT = None if self.R is None else self.R.T.copy()
        # a joint-side law: per joint (fv, fc, off, sigmoid constants) as Python floats, written
        # out below as straight-line code; the sigmoid as (1 + tanh(x / 2)) / 2 (no overflow)
        self.floats = self.torque_jacobian_floats = self.jacobian_floats = self.tau_jacobian_floats = None
        if not self.general and self.R is None:
            sg = self.sig
            self.floats = [(float(self.fv[k]) if self.fv is not None else 0.0,
                            float(self.fc[k]) if self.fc is not None else None,
                            float(self.off[k]) if self.off is not None else 0.0,
                            None if sg is None else (0.5 * float(sg[0][k]), 0.5 * float(sg[0][k] * sg[1][k]),
                                                     0.5 * float(sg[2][k]), float(sg[2][k] * (0.5 - sg[3][k])),
                                                     0.25 * float(sg[4][k])))
                           for k in range(n)]
            (self.torque_jacobian_floats, self.jacobian_floats,
             self.tau_jacobian_floats) = _joint_side_functions(self.floats, self.eps)

    def __call__(self, qd: np.ndarray):
        if self.general:
            law, tr = self.law, self.transmission
            F, J = law.torque(qd, tr), law.derivative(qd, tr)
            return F, (J if self.R is not None else J.diagonal().copy())
        if self.floats is not None:
            F, J = self.torque_jacobian_floats(qd.tolist())
            return np.array(F), np.array(J)
        R = self.R
        v = qd if R is None else qd @ self.RT
        # the law's own operations in its own order (Friction.torque, Friction.derivative): the same bits
        f = np.zeros(self.n)
        d = np.zeros(self.n)
        if self.fv is not None:
            f = f + self.fv * v
            d = d + self.fv
        if self.fc is not None:
            if self.eps:
                t = np.tanh(v / self.eps)
                f = f + self.fc * t
                d = d + self.fc * ((1.0 - t ** 2) / self.eps)
            else:
                f = f + self.fc * np.sign(v)                     # the sharp sign: derivative 0
        if self.sig is not None:
            al, p3, A, s0, Aal = self.sig
            s = np.exp(-np.logaddexp(0.0, -(al * (v + p3))))    # the logistic, without overflow
            f = f + A * (s - s0)
            d = d + Aal * s * (1.0 - s)
        if R is not None:
            f = f @ R
            d = (self.RT * d) @ R                                # R^T diag(d) R
        if self.off is not None:
            f = f + self.off
        return f, d

    def jacobian(self, qd: np.ndarray) -> np.ndarray:
        """``dF/dqd`` alone at one plain (n,) velocity, as ``J`` of :meth:`__call__` (same numbers)."""
        if self.floats is None:
            return self(qd)[1]
        return np.array(self.jacobian_floats(qd.tolist()))


def _joint_side_functions(floats, eps: float):
    """``(torque_jacobian, jacobian, tau_jacobian)``: straight-line functions of lists of floats.

    For the joint-side law whose per-joint constants are ``floats``
    (:class:`SingleStateFriction`) and ``v`` the n joint velocities:
    ``torque_jacobian(v)`` returns ``(F, J)``, ``jacobian(v)`` ``J`` and
    ``tau_jacobian(v, t)`` ``([t_k - F_k], J)`` (the torque ABA runs on), lists of n
    floats.  Per joint, the operations of the law's scalar form in its order::

        c   = tanh(x / eps)                      (smooth Coulomb)     sign(x) when eps == 0
        s   = tanh(h x + hp)                     (sigmoid, h = alpha / 2, hp = alpha p3 / 2)
        F   = ((fv x + fc c) + (A/2 s + c0)) + offset
        J   = (fv + fc (1 - c^2) / eps) + c1 (1 - s^2)

    with absent (or zero) terms left out.  The constants are written as ``repr``
    literals (exact: a float's repr reads back to the same float), so a call runs one
    expression per joint and no loop; the source is built here from numbers only,
    never from user text.
    """
    n = len(floats)
    lit = "({!r})".format
    pre, F, J = [], [], []
    for k, (fv, fc, off, sg) in enumerate(floats):
        x = f"x{k}"
        f = [f"{lit(fv)} * {x}"] if fv else []
        d = [lit(fv)] if fv else []
        if fc is not None:
            if eps:
                pre.append(f"c{k} = tanh({x} / {lit(eps)})")
                f.append(f"{lit(fc)} * c{k}")
                d.append(f"{lit(fc)} * ((1.0 - c{k} * c{k}) / {lit(eps)})")
            else:
                f.append(f"{lit(fc)} * (1.0 if {x} > 0.0 else (-1.0 if {x} < 0.0 else 0.0 * {x}))")
        if sg is not None:
            h, hp, A2, c0, c1 = sg
            pre.append(f"s{k} = tanh({lit(h)} * {x} + {lit(hp)})")
            f.append(f"({lit(A2)} * s{k} + {lit(c0)})")
            d.append(f"{lit(c1)} * (1.0 - s{k} * s{k})")
        if off:
            f.append(lit(off))
        F.append(" + ".join(f) or "0.0")          # a + b + c is (a + b) + c: the law's order
        J.append(" + ".join(d) or "0.0")
    unpack = ", ".join(f"x{k}" for k in range(n)) + ", = v"
    body = "".join(f"    {line}\n" for line in [unpack, *pre])
    Fs, Js = ", ".join(F), ", ".join(J)
    minus = ", ".join(f"t{k} - ({F[k]})" for k in range(n))
    src = (f"def torque_jacobian(v):\n{body}    return [{Fs}], [{Js}]\n"
           f"def jacobian(v):\n{body}    return [{Js}]\n"
           f"def tau_jacobian(v, t):\n{body}    {', '.join(f't{k}' for k in range(n))}, = t\n"
           f"    return [{minus}], [{Js}]\n")
    names = {"tanh": math.tanh}
    exec(compile(src, f"<friction law, {n} joints>", "exec"), names)     # numbers only: see the docstring
    return names["torque_jacobian"], names["jacobian"], names["tau_jacobian"]
