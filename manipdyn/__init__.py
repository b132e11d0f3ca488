"""manipdyn: serial-arm dynamics computed two independent ways, and checked.

Layer: the package top: wires the engines into the model and exports the public names.

* ``arm.lagrange``: the trace-form Lagrange-Euler engine of chapter II;
* ``arm.pinocchio``: Pinocchio's RNEA/CRBA/ABA on the arm's URDF;
* ``arm.engine("mujoco")``: MuJoCo on the arm's MJCF (:func:`to_mjcf`; the ``mujoco`` extra);
* :func:`crosscheck`: proof that the engines agree.

Quick start::

    import manipdyn as md
    arm = md.load("puma560")
    tau = arm.inverse_dynamics(q, qd, qdd)        # fast path (Pinocchio)
    D = arm.lagrange.mass_matrix(q)               # independent trace form
    print(md.crosscheck(arm, samples=200))

The package reads in layers (ARCHITECTURE.md): kinematics, inertia, the
model and its loaders, the two engines, the cross-check, the applications.
Importing it imports both engines, which register themselves with the model.
"""

# first: a Ctrl-C while the command imports the rest prints one line (manipdyn._support.interrupt)
from ._support.interrupt import quiet_interrupt_while_starting as _quiet_interrupt

_quiet_interrupt()
from ._support.errors import (FormatLossWarning, ModelError, ModelNoteWarning, PhysicalConsistencyWarning,
                     SingularMassMatrixError, StateError, SuspiciousValueWarning, UnreachablePoseError)
from .model.inertia import LinkInertia
from .model.kinematics import transform_inverse
from .model.links import ChainJoint, DHLink
from .model.drive import Transmission
from .model.friction import Friction, FrictionTerms
from .model.arm import Arm, Convention, Manipulator, URDFArm
from .model import variants as _variants  # noqa: F401  (registers arm.with_payload)
from .formats.loading import load, load_with_notes, models
from .formats.save import save, to_mjcf, to_toml, to_urdf, write_mjcf, write_urdf
from .engines.protocol import DynamicsEngine, JacobianEngine
from .model.arm import register_engine
from .engines.lagrange.engine import trace_form_engine
from .check.crosscheck import CrosscheckReport, crosscheck
from .engines.linearize import linearize  # also arm.linearize (registered as a service)
# ``compare`` is the function; the package of the same name is manipdyn/check/compare/
# (binding the name here, after the import, makes md.compare the function)
from .check.compare import CompareReport, compare
# the caps a trusted user may raise (README, "Limits"): ``md.limits.MAX_...``
from ._support import limits


def _pinocchio_engine(arm):
    # Pinocchio is imported on first use only: the trace-form path runs without it.
    from .engines.pinocchio.engine import pinocchio_engine

    return pinocchio_engine(arm)


def _c_engine(arm):
    # the generated C, compiled on first use (and cached by the model's hash)
    from .engines.c import compiled_engine

    return compiled_engine(arm)


def codegen(arm, dir, prefix=None):
    """Write ``dir/P.h`` and ``dir/P.c``, the arm's dynamics in C99 (:func:`manipdyn.engines.c.codegen`).

    Returns ``(header path, source path, note)``; needs CasADi (``pip install 'manipdyn[codegen]'``).
    """
    from .engines.c import codegen as _codegen

    return _codegen(arm, dir, prefix)


def _mujoco_engine(arm):
    # MuJoCo on the arm's own MJCF (md.to_mjcf), imported on first use
    from .engines.mujoco import mujoco_engine

    return mujoco_engine(arm)


# The engines plug into the model here, at the top of the package.
register_engine("lagrange", trace_form_engine)
register_engine("pinocchio", _pinocchio_engine)
register_engine("c", _c_engine)
# MuJoCo: served where the ``mujoco`` extra is installed (imported on first use, so ``import manipdyn``
# stays cheap); without it, arm.engine("mujoco") raises MissingExtraError with the install command
register_engine("mujoco", _mujoco_engine)
# ``arm.compiled``, beside ``arm.lagrange`` and ``arm.pinocchio``: wired here, as the engine is
Arm.compiled = property(lambda arm: arm.engine("c"),
                        doc="The generated-C engine (``arm.engine('c')``): the arm's C, compiled on first use "
                            "and cached by the model's hash (manipdyn.engines.c).")


def __getattr__(name):
    if name == "simulate":  # the control package imports Pinocchio (its regressor)
        from .control.simulate import simulate

        return simulate
    if name == "replay":    # the model against a real log over a horizon (control: replay)
        from .control.replay import replay

        return replay
    if name in ("identify", "validate"):   # the identification pipelines need the identify extra
        from . import identification

        return getattr(identification, name)
    if name in ("observe", "MomentumObserver"):   # collision detection (control/collision), imported on first use
        from .control import collision

        return getattr(collision, name)
    if name == "montecarlo":  # ``from manipdyn import montecarlo as mc`` (README); imported on first use
        from .control import montecarlo

        return montecarlo
    raise AttributeError(f"module 'manipdyn' has no attribute {name!r}")


__version__ = "0.1.0"

__all__ = ["Transmission", "Friction", "FrictionTerms", 
    "Arm", "ChainJoint", "Convention", "CompareReport", "CrosscheckReport", "DHLink", "DynamicsEngine", "JacobianEngine",
    "FormatLossWarning", "LinkInertia", "Manipulator", "ModelError", "ModelNoteWarning", "PhysicalConsistencyWarning", "SingularMassMatrixError",
    "StateError", "SuspiciousValueWarning", "URDFArm", "UnreachablePoseError", "codegen", "compare", "crosscheck", "linearize", "load", "load_with_notes", "models", "save",
    "simulate", "replay", "identify", "validate", "observe", "MomentumObserver", "to_mjcf", "to_toml", "to_urdf", "transform_inverse", "write_mjcf", "write_urdf",
]


def __dir__():
    return sorted(set(globals()) | set(__all__))
