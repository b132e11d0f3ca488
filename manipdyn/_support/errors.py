"""Exceptions and warnings raised by manipdyn.

Layer 0 (support): the exceptions every layer raises.

Both error classes subclass the built-in they refine, so callers may catch
either ``manipdyn.ModelError`` or plain ``ValueError``.
"""

from __future__ import annotations

import os
import sys
import warnings

_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep  # manipdyn/, not _support/

__all__ = ["is_solver_panic", "ModelError", "TipError", "UnreachablePoseError", "ModelNoteWarning", "PhysicalConsistencyWarning",
           "SuspiciousValueWarning", "FormatLossWarning", "SingularMassMatrixError", "StateError", "warn_at_caller", "warn_notes",
           "MissingExtraError"]


class ModelError(ValueError):
    """An arm description (DH table, inertia, model file, URDF) is malformed.

    The message always names the place: the link, the field, the file and key
    or URDF element, and the form that was expected.
    """


class TipError(ModelError):
    """A URDF tree needs a tip link (or got one it does not have).

    Attributes: ``source`` (the file, for messages), ``problem`` (what is
    wrong, one sentence), ``leaves`` (leaf links that end a chain of movable
    joints: the candidates), ``links`` (every link of the file) and
    ``suggestions`` (close spellings of an unknown tip).  :meth:`for_option`
    phrases the message for the way the tip was given: ``"tip="`` in
    Python (the default message), ``"--tip"`` on the command line.
    """

    def __init__(self, source: str, problem: str, leaves=(), links=(), suggestions=(), option: str = "tip="):
        self.source, self.problem = source, problem
        self.leaves, self.links, self.suggestions = tuple(leaves), tuple(links), tuple(suggestions)
        super().__init__(self._text(option))

    def _text(self, option: str) -> str:
        how = f"{option}'<link name>'" if option.endswith("=") else f"{option} LINK"
        parts = [f"{self.source}: {self.problem}"]
        if self.suggestions:
            first, *rest = self.suggestions
            parts.append(f"did you mean {first!r}" + (f" (or {', '.join(map(repr, rest))})" if rest else ""))
        if self.leaves:
            parts.append(f"choose the chain with {how}; the leaf links are "
                         + ", ".join(repr(n) for n in self.leaves))
        if self.links and set(self.links) != set(self.leaves):
            parts.append(f"all {len(self.links)} links: " + ", ".join(repr(n) for n in self.links))
        return "; ".join(parts)

    def for_option(self, option: str) -> "TipError":
        """The same error, its message naming ``option`` (e.g. ``"--tip"``, ``"--tip-a"``)."""
        return TipError(self.source, self.problem, self.leaves, self.links, self.suggestions, option)


class StateError(ValueError):
    """A joint state (q, qd, qdd, tau) has the wrong shape or is not finite."""


class UnreachablePoseError(StateError):
    """Inverse kinematics found no joint positions within the limits that reach the pose.

    Attributes: ``q`` (n,) the closest joint positions found, ``position_error`` (m) and
    ``rotation_error`` (rad) of their pose; the message says the same.
    """

    def __init__(self, message: str, q=None, position_error: float = float("nan"),
                 rotation_error: float = float("nan")):
        super().__init__(message)
        self.q, self.position_error, self.rotation_error = q, position_error, rotation_error


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


class FormatLossWarning(ModelNoteWarning):
    """A file was written (``md.write_urdf``, ``md.write_mjcf``) that does not hold all of the model: a
    friction law, rotor inertia, gravity, placeholder limits.  The message lists them, one clause each,
    as the file's opening comment and ``manipdyn urdf`` / ``manipdyn mjcf``'s ``not held:`` lines do.
    """


class ToolFrameWarning(ModelNoteWarning):
    """A URDF's tool frame was chosen by the default rule (the last moving link) while
    fixed frames beyond it (``tool0``, ``ee_link``, ...) sit elsewhere: pass ``tip=`` to
    make one of them the tool.  The note names them, their distance and angle.
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


class MissingExtraError(ImportError):
    """An optional dependency (an extra: ``identify``, ``scale``, ``plot``) is not installed;
    the message says what needs it and the install command.

    ``cli_message``, when given, is the same advice in command-line terms
    (``--scheduler sync`` rather than ``scheduler='sync'``); the CLI prints it.
    """

    def __init__(self, message: str, cli_message: str | None = None):
        super().__init__(message)
        self.cli_message = cli_message if cli_message is not None else message


def is_solver_panic(exc: BaseException) -> bool:
    """Whether ``exc`` is a panic of a solver written in Rust (Clarabel): pyo3's
    ``PanicException``, which derives from ``BaseException``, so ``except Exception`` misses it.

    The solver wrappers (:mod:`manipdyn.model.completion`,
    :mod:`manipdyn.identification.estimation.solvers`) catch ``BaseException``, keep what this
    says is a panic as that solver's failure (the next solver is tried, and a
    :class:`ModelError` says none answered), and raise everything else again (Ctrl-C included).
    """
    t = type(exc)
    return (t.__name__ == "PanicException" and t.__module__ == "pyo3_runtime"
            and not isinstance(exc, (KeyboardInterrupt, SystemExit, GeneratorExit)))
