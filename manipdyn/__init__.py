"""manipdyn: serial-arm dynamics computed two independent ways, and checked.

* ``arm.lagrange``: the trace-form Lagrange-Euler engine of chapter II;
* ``arm.pinocchio``: Pinocchio's RNEA/CRBA/ABA on the arm's URDF;
* :func:`crosscheck`: proof that the two agree.

Quick start::

    import manipdyn as md
    arm = md.load("puma560")
    tau = arm.inverse_dynamics(q, qd, qdd)        # fast path (Pinocchio)
    D = arm.lagrange.mass_matrix(q)               # independent trace form
    print(md.crosscheck(arm, samples=200))
"""

from .errors import (ModelError, ModelNoteWarning, PhysicalConsistencyWarning, SingularMassMatrixError,
                     StateError, SuspiciousValueWarning)
from .inertia import LinkInertia
from .kinematics import ChainJoint, DHLink, transform_inverse
from .arm import Arm, Manipulator
from .check import CrosscheckReport, crosscheck
# ``compare`` is the function; the package of the same name is manipdyn/compare/
# (binding the name here, after the import, makes md.compare the function)
from .compare import CompareReport, compare

__version__ = "0.1.0"

__all__ = [
    "Arm", "ChainJoint", "DHLink", "LinkInertia", "Manipulator", "ModelError", "ModelNoteWarning",
    "PhysicalConsistencyWarning", "SuspiciousValueWarning", "SingularMassMatrixError", "StateError",
    "transform_inverse", "crosscheck", "CrosscheckReport", "compare", "CompareReport",
    "load", "load_with_notes", "models", "simulate",
]

#: names resolved on first use (pinocchio and yourdfpy load only when a function needs them)
_LAZY = {"load": "modelfile", "load_with_notes": "modelfile", "models": "modelfile"}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    if name == "simulate":
        from .control import simulate
        return simulate
    raise AttributeError(f"module 'manipdyn' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
