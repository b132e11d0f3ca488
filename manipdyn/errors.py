"""Exceptions and warnings raised by manipdyn.

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
