"""What the cross-check compares, and how one engine computes it on a chunk of states.

Layer 4 (checks), part of :mod:`manipdyn.check.crosscheck`: the quantities by name (what
``manipdyn check --help`` lists), the optional ones (the engines with a Jacobian), and
:func:`engine_results`, which talks to an engine only through
:class:`manipdyn.engines.protocol.DynamicsEngine` and :class:`manipdyn.engines.protocol.JacobianEngine`.
"""

from __future__ import annotations

import numpy as np

from ..engines.protocol import DynamicsEngine, not_offered
from ..model.reach import wrench_torque

__all__ = ["QUANTITIES", "OPTIONAL_QUANTITIES", "TOOL_WRENCH", "engine_results"]

QUANTITIES = {
    "D": "mass matrix D(q)",
    "h": "Coriolis/centripetal torque h(q, qd)",
    "C": "Coriolis matrix C(q, qd) (Christoffel form)",
    "g": "gravity torque g(q)",
    "tau": "inverse dynamics tau",
    "qdd": "forward dynamics qdd",
    "fk": "end pose (forward kinematics)",
    "K": "kinetic energy",
    "P": "potential energy",
    "Y": "inverse-dynamics regressor Y(q, qd, qdd) (10 parameters per link)",
    "dtau_dq": "derivative of inverse dynamics by q, dtau/dq",
    "dtau_dqd": "derivative of inverse dynamics by qd, dtau/dqd (friction included)",
    "dqdd_dq": "derivative of forward dynamics by q, dqdd/dq",
    "dqdd_dqd": "derivative of forward dynamics by qd, dqdd/dqd",
    "dg_dq": "derivative of the gravity torque, dg/dq",
    "J": "geometric Jacobian of the tool frame (6 x n, linear on top, base axes)",
    "Jdot": "time derivative of the tool frame's Jacobian, dJ/dt",
    "J_tool": "the tool frame's Jacobian in its own axes (frame='tool')",
    "J_link": "every link's Jacobian (link=1..n, base axes)",
    "tau_f": "inverse dynamics under a tool wrench, tau - J^T f_tool",
}
#: the wrench ``[force (N); moment (N m)]`` on the tool (base axes, tool origin) of ``tau_f``:
#: every component nonzero and distinct, so a swapped or mis-signed row shows
TOOL_WRENCH = np.array([3.0, -5.0, 7.0, 0.5, -0.2, 0.9])
#: quantities of engine methods that are optional (:data:`manipdyn.engines.protocol.OPTIONAL_ENGINE_METHODS`):
#: compared only when both engines offer the method; otherwise the report's notes say so (an engine
#: without them, such as generated C, is not a disagreement, so they stay out of ``not_compared``)
OPTIONAL_QUANTITIES = {"J": "jacobian", "Jdot": "jacobian_dot", "J_tool": "jacobian", "J_link": "jacobian",
                       "tau_f": "jacobian"}
_OPTIONAL_CALLS = {
    "J": lambda E, q, qd, qdd: E.jacobian(q),
    "Jdot": lambda E, q, qd, qdd: E.jacobian_dot(q, qd),
    "J_tool": lambda E, q, qd, qdd: E.jacobian(q, frame="tool"),
    "J_link": lambda E, q, qd, qdd: np.stack([E.jacobian(q, link=k) for k in range(1, E.n + 1)], axis=1),
    "tau_f": lambda E, q, qd, qdd: E.inverse_dynamics(q, qd, qdd) - wrench_torque(E.jacobian(q), TOOL_WRENCH),
}


def engine_results(E: DynamicsEngine, qs, qds, qdds, referee: bool) -> dict:
    """Everything the cross-check compares but forward dynamics, by one engine on one chunk
    (D, h, g in one call for the referee, by their own methods for the others)."""
    if referee:
        D, h, g = E.dynamics_terms(qs, qds)
    else:
        D, h, g = E.mass_matrix(qs), E.coriolis_torque(qs, qds), E.gravity_torque(qs)
    skip = not_offered(E)       # what the engine does not compute (MuJoCo's C, Y, derivatives): left out, with a note
    r = {"D": D, "h": h, "g": g, "tau": E.inverse_dynamics(qs, qds, qdds), "fk": E.fkine(qs),
         "K": E.kinetic_energy(qs, qds)[:, None], "P": np.asarray(E.potential_energy(qs))[:, None]}
    if "C" not in skip:
        r["C"] = E.coriolis_matrix(qs, qds)
    if "Y" not in skip:
        r["Y"] = E.regressor(qs, qds, qdds)
    if "dtau_dq" not in skip:
        r["dtau_dq"], r["dtau_dqd"] = E.inverse_dynamics_derivatives(qs, qds, qdds)
    if "dg_dq" not in skip:
        r["dg_dq"] = E.gravity_derivative(qs)
    for key, method in OPTIONAL_QUANTITIES.items():      # only where the engine has them
        if key not in skip and callable(getattr(E, method, None)):
            r[key] = _OPTIONAL_CALLS[key](E, qs, qds, qdds)
    return r
