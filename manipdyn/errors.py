"""Exceptions and warnings raised by manipdyn.

Layer: 0 (utilities): the exceptions every layer raises.

Both error classes subclass the built-in they refine, so callers may catch
either ``manipdyn.ModelError`` or plain ``ValueError``.
"""

from __future__ import annotations

__all__ = ["ModelError", "PhysicalConsistencyWarning", "SingularMassMatrixError", "StateError"]


class ModelError(ValueError):
    """An arm description (DH table, inertia, model file, URDF) is malformed.

    The message always names the place: the link, the field, the file and key
    or URDF element, and the form that was expected.
    """


class StateError(ValueError):
    """A joint state (q, qd, qdd, tau) has the wrong shape or is not finite."""


class PhysicalConsistencyWarning(UserWarning):
    """A well-formed link inertia that no real rigid body can have.

    Raised as an error instead when the model is built with ``strict=True``.
    """


class SingularMassMatrixError(ValueError):
    """Forward dynamics asked of an arm whose mass matrix D(q) is singular.

    This happens when a joint moves no mass and no rotor inertia (a massless
    distal link, say): its acceleration is then undefined.
    """

    @classmethod
    def for_mass_matrix(cls, D) -> "SingularMassMatrixError":
        """The error for singular mass matrices D (B, n, n), naming joints with no inertia."""
        import numpy as np

        diag = np.abs(np.diagonal(D, axis1=-2, axis2=-1)).min(axis=0)
        idle = [int(j) + 1 for j in np.flatnonzero(diag <= 1e-12 * max(1.0, float(diag.max())))]
        which = f": joint(s) {idle} move no mass" if idle else ""
        return cls(
            f"forward dynamics: the mass matrix D(q) is singular{which}; give the links after "
            "them mass or the joints rotor inertia"
        )
