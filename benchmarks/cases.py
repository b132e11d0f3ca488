"""What the benchmark times: the operations, their arguments and the implementations."""

from __future__ import annotations

__all__ = ["OPS", "ARGS", "IMPLS", "IMPL_LABEL"]

OPS = ("mass_matrix", "coriolis_torque", "gravity_torque", "inverse_dynamics", "forward_dynamics",
       "dynamics_terms")
ARGS = {
    "mass_matrix": ("q",),
    "coriolis_torque": ("q", "qd"),
    "gravity_torque": ("q",),
    "inverse_dynamics": ("q", "qd", "qdd"),
    "forward_dynamics": ("q", "qd", "tau"),
    "dynamics_terms": ("q", "qd"),
}
#: implementations, in table order
IMPLS = ("manipdyn", "pinocchio", "lagrange", "lagrange_batch", "rtb", "rtb_Cqd")
IMPL_LABEL = {
    "manipdyn": "manipdyn fast path",
    "pinocchio": "raw Pinocchio",
    "lagrange": "trace form, 1 state",
    "lagrange_batch": "trace form, per state in a batch",
    "rtb": "Robotics Toolbox (DHRobot)",
    "rtb_Cqd": "Toolbox coriolis(q, qd) @ qd",
}
