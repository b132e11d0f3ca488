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

import numpy as np

__all__ = ["friction_jacobian"]


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
