"""Writing arms to files: model files (TOML), URDF and MJCF, always atomically.

Layer 2 (formats) loaders and writers.  The free functions here replace the
methods ``arm.save`` and ``arm.write_urdf`` (kept one release as deprecated
aliases), so that the model layer knows nothing of files.
"""

from __future__ import annotations

from .._support.files import atomic_write_text
from .modelfile import model_to_toml, save_model
from .urdf.writer import arm_to_urdf
from .mjcf import arm_to_mjcf
from ..model.arm import register_service

__all__ = ["save", "write_urdf", "to_urdf", "to_toml", "to_mjcf", "write_mjcf"]


def save(arm, path) -> None:
    """Write ``arm`` (a :class:`~manipdyn.Manipulator`, or a URDF arm with its drive:
    :mod:`manipdyn.formats.modelfile_urdf`) as a model file that
    :func:`manipdyn.load` reads back unchanged.  Atomic: no partial file."""
    save_model(arm, path)


def to_toml(arm) -> str:
    """The model-file (TOML) text of a :class:`~manipdyn.Manipulator`."""
    return model_to_toml(arm)


def to_urdf(arm, as_published: bool = False) -> str:
    """The arm as URDF text (built through yourdfpy's objects).

    For an arm read from a URDF this is the regenerated chain (fixed joints
    lumped), not the original file.  A body MuJoCo's URDF reader refuses is written completed,
    with the model's base parameters (the same dynamics; :func:`to_mjcf`), and the comment says
    so; ``as_published=True`` keeps the raw values.
    """
    return arm_to_urdf(arm, as_published=as_published)


def write_urdf(arm, path, as_published: bool = False) -> None:
    """Write :func:`to_urdf` to ``path`` atomically (no partial file on failure).  What the URDF does not
    hold of the model (the file's opening comment lists it) is also warned, one
    :class:`~manipdyn.FormatLossWarning` naming every item, so a Python caller learns it too."""
    from .urdf.writer import urdf_losses

    atomic_write_text(path, arm_to_urdf(arm, as_published=as_published))
    _warn_losses(arm, path, "URDF", urdf_losses(arm, as_published=as_published))


def _warn_losses(arm, path, kind: str, lines) -> None:
    """One :class:`~manipdyn.FormatLossWarning` listing ``lines`` (what the ``kind`` file at ``path`` does not hold)."""
    import os

    from .._support.errors import FormatLossWarning, warn_at_caller

    if lines:
        warn_at_caller(f"{os.fspath(path)}: the {kind} does not hold all of {arm.name or 'the model'} (its opening "
                       "comment says the same): " + "; ".join(" ".join(str(x).split()) for x in lines),
                       FormatLossWarning)


register_service("save", save)
register_service("write_urdf", write_urdf)
register_service("to_urdf", to_urdf)


def to_mjcf(arm, as_published: bool = False) -> str:
    """The arm as MJCF text, MuJoCo's model format (:mod:`manipdyn.formats.mjcf`): bodies with their
    inertials at full precision, joints with range, ``armature``, ``damping`` and ``frictionloss``,
    one ``motor`` per joint, a ``tool`` site and the model's gravity; its opening comment names the
    model (sha256, source, manipdyn version) and says what MJCF does not hold of it.  A body MuJoCo's
    compiler refuses is written completed, with the model's base parameters (the same dynamics), and
    the comment says per body what was completed and why; ``as_published=True`` keeps the raw values
    and warns (:class:`~manipdyn.PhysicalConsistencyWarning`) for each link MuJoCo will refuse."""
    return arm_to_mjcf(arm, as_published=as_published)


def write_mjcf(arm, path, as_published: bool = False) -> None:
    """Write :func:`to_mjcf` to ``path`` atomically (no partial file on failure); what the MJCF does not
    hold of the model is also warned (:class:`~manipdyn.FormatLossWarning`, as :func:`write_urdf`)."""
    from .mjcf import mjcf_losses

    atomic_write_text(path, arm_to_mjcf(arm, as_published=as_published))
    _warn_losses(arm, path, "MJCF", mjcf_losses(arm, as_published=as_published))
