"""One entry point for every way of describing an arm: ``md.load``.

Layer 2 (formats) loaders.  Dispatches to the model-file reader
(:mod:`manipdyn.formats.modelfile`) and the URDF reader (:mod:`manipdyn.formats.urdf.reader`);
both build models and know nothing of the engines.
"""

from __future__ import annotations

import os
import warnings

from .._support.errors import ModelError, ModelNoteWarning, PhysicalConsistencyWarning, ToolFrameWarning, warn_notes
from .modelfile import close_names, load_bundled, load_model_file, models
from .urdf.reader import load_urdf

__all__ = ["load", "load_with_notes", "models", "did_you_mean", "ERD_PREFIX"]

#: a model spec ``erd:NAME`` names the URDF ``NAME.urdf`` of example-robot-data
ERD_PREFIX = "erd:"


def load(x, tip: str | None = None, **kw):
    """Load an arm: a bundled model's name, a model file (.toml), or a URDF.

    Parameters
    ----------
    x : str or PathLike
        ``"puma560"`` (see :func:`models`), a path to a ``.toml`` model file,
        a path to a ``.urdf`` file (or URDF text), or ``"erd:NAME"``: the URDF
        ``NAME.urdf`` of example-robot-data (:func:`manipdyn.formats.erd.urdf_names`),
        named ``"erd:NAME"`` unless ``name=`` is given.
    tip : str, optional
        URDF only: the link at the end of the chain to keep when the URDF is a
        tree (e.g. an arm with gripper fingers).
    **kw
        Passed on to the loader (``strict=`` for both; ``name=``, ``gravity=``
        for URDFs).

    Returns
    -------
    manipdyn.Arm
        A :class:`~manipdyn.Manipulator` for names and model files, a
        :class:`~manipdyn.formats.urdf.reader.URDFArm` for URDFs.
    """
    if not isinstance(x, (str, os.PathLike)):
        raise ModelError(
            f"load: expected a model name, a .toml model file or a URDF path, got {type(x).__name__}")
    s = os.fspath(x)
    if isinstance(x, str) and s.startswith(ERD_PREFIX):
        from .erd import urdf_path

        kw.setdefault("name", s)        # the label says where the arm came from: erd:ur5_robot, not ur5
        return _load_urdf_with_notes(os.fspath(urdf_path(s[len(ERD_PREFIX):])), tip, **kw)
    if (isinstance(x, str) and s.lstrip().startswith("<")) or s.lower().endswith((".urdf", ".xml")):
        return _load_urdf_with_notes(s, tip, **kw)
    if tip is not None:
        raise ModelError(f"tip: only meaningful for a URDF, not for {s!r}")
    if s.lower().endswith(".toml") or os.sep in s or "/" in s:
        return load_model_file(s, **kw)
    if s in models():
        return load_bundled(s, **kw)
    if os.path.exists(s):
        return load_model_file(s, **kw)
    raise ModelError(f"unknown model {s!r}: not a file, and not a bundled model "
                     f"({', '.join(models())}){did_you_mean(s, models())}; "
                     f"{ERD_PREFIX}NAME names a URDF of example-robot-data (manipdyn models --erd)")


def did_you_mean(name: str, candidates) -> str:
    """``"; did you mean 'x'?"`` for the closest of ``candidates`` to ``name``, or ``""``."""
    close = close_names(name, candidates)
    return f"; did you mean {' or '.join(map(repr, close))}?" if close else ""


def _load_urdf_with_notes(source: str, tip, **kw):
    """:func:`load_urdf`, its physical-consistency warnings and the tool frame's note
    (a default tip that passed over other leaf frames) kept as ``arm.notes`` and warned
    once each kind, at the user's call (not at a line inside manipdyn)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PhysicalConsistencyWarning)
        warnings.simplefilter("always", ToolFrameWarning)
        arm = load_urdf(source, tip=tip, **kw)
    notes, tool_notes = [], []
    for w in caught:
        if issubclass(w.category, PhysicalConsistencyWarning):
            notes.append(str(w.message))
        elif issubclass(w.category, ToolFrameWarning):
            tool_notes.append(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    arm.notes = tuple(tool_notes + notes)
    warn_notes(arm.name or "arm", tool_notes, ToolFrameWarning)
    warn_notes(arm.name or "arm", notes, PhysicalConsistencyWarning)
    return arm


def load_with_notes(x, tip: str | None = None, **kw):
    """:func:`load`, with the model's notes returned instead of warned.

    Returns ``(arm, notes)``: ``notes`` is ``list(arm.notes)``, one line per
    physically impossible link inertia, link that moves no mass, value in
    a suspicious unit, or URDF tool frame chosen where others were passed over
    (the :class:`~manipdyn.ModelNoteWarning` warnings are not shown; other warnings are).  This is how the CLI reports them.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelNoteWarning)
        arm = load(x, tip=tip, **kw)
    return arm, list(arm.notes)
