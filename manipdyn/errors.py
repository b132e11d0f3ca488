"""Exceptions and warnings raised by manipdyn.

Both error classes subclass the built-in they refine, so callers may catch
either ``manipdyn.ModelError`` or plain ``ValueError``.
"""

from __future__ import annotations

import os
import sys
import warnings

_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep

__all__ = ["ModelError", "ModelNoteWarning", "PhysicalConsistencyWarning", "SuspiciousValueWarning",
           "SingularMassMatrixError", "StateError", "warn_at_caller", "warn_notes"]


class ModelError(ValueError):
    """An arm description (DH table, inertia, model file, URDF) is malformed.

    The message always names the place: the link, the field, the file and key
    or URDF element, and the form that was expected.
    """


class StateError(ValueError):
    """A joint state (q, qd, qdd, tau) has the wrong shape or is not finite."""


class ModelNoteWarning(UserWarning):
    """A model was built, but something in it deserves the user's attention.

    The arm keeps the same notes in ``arm.notes`` (one line each), so reports
    can show them; catch this class to silence both kinds below.
    """


class PhysicalConsistencyWarning(ModelNoteWarning):
    """A well-formed link inertia that no real rigid body can have.

    Raised as an error instead when the model is built with ``strict=True``.
    """


class SuspiciousValueWarning(ModelNoteWarning):
    """A value that is probably in the wrong unit (an angle of 90 in a file in radians,
    lengths that look like millimetres in a file in metres).

    Raised as an error instead when the model is loaded with ``strict=True``.
    """


def warn_at_caller(message: str, category=ModelNoteWarning) -> None:
    """``warnings.warn`` pointed at the first frame outside manipdyn: the user's own call."""
    frame, level = sys._getframe(0), 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(_PACKAGE_DIR):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)


def warn_notes(label: str, notes, category=ModelNoteWarning) -> None:
    """One warning for a model's notes (one line each), pointed at the user's call."""
    notes = list(notes)
    if not notes:
        return
    if len(notes) == 1:
        message = notes[0]
    else:
        message = f"{label}: {len(notes)} notes:\n  " + "\n  ".join(notes)
    warn_at_caller(message, category)


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
