"""``manipdyn mjcf``: write the MJCF (MuJoCo's model format) of arms.

Layer 7 (CLI, the top).
"""

from __future__ import annotations

from ..formats.mjcf import mjcf_losses
from ..formats.save import write_mjcf
from .urdf import add_model_arguments, write_models

__all__ = ["register", "run"]


def run(args) -> int:
    return write_models(args, "mjcf", "xml", write_mjcf, mjcf_losses)


def register(sub) -> None:
    """Add ``manipdyn mjcf``."""
    u = sub.add_parser("mjcf", help="write the MJCF (MuJoCo) of arms",
                       usage="manipdyn mjcf [-h] [--all] [--tip LINK] [MODEL_OR_FILE ...] OUTDIR  (options first)",
                       description="Write <name>.xml, MuJoCo's MJCF, for each arm into OUTDIR (created if "
                                   "needed): bodies and inertials at full precision; joints with axis, range, "
                                   "armature (rotor inertia), damping and frictionloss; one motor per joint; a "
                                   "'tool' site; gravity. What MJCF cannot hold of the model (friction terms, "
                                   "limits, non-physical inertias MuJoCo refuses) is written in the file's comment "
                                   "and printed, one 'not held:' line each. Any model `manipdyn load` reads, an "
                                   "identified one included. Exit 0 written, 2 usage or model error.")
    add_model_arguments(u, "xml")
    u.set_defaults(func=run)
