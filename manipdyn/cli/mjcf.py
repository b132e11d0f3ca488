"""``manipdyn mjcf``: write the MJCF (MuJoCo's model format) of arms.

Layer 7 (CLI, the top).
"""

from __future__ import annotations

from ..formats.mjcf import mjcf_losses
from ..formats.save import to_mjcf
from .argblocks import add_writer_command
from .urdf import write_models

__all__ = ["register", "run"]


def run(args) -> int:
    raw = bool(args.as_published)
    return write_models(args, "mjcf", "xml", lambda arm: to_mjcf(arm, as_published=raw),
                        lambda arm: _losses_measured(arm, raw))


def _losses_measured(arm, as_published: bool = False) -> list:
    """The file's losses, and, where the file holds Coulomb friction as frictionloss (a soft
    constraint), MuJoCo's forward dynamics on it measured against the model's (or why not)."""
    lines = mjcf_losses(arm, as_published=as_published)
    law = arm.friction_model
    from ..formats.losses import friction_held

    held = friction_held(arm, "mjcf")[0] if law is not None else None
    if held is None or held.coulomb is None or not held.coulomb.any():
        return lines
    from ..engines.mujoco import available

    if not available():
        return lines + ["frictionloss: MuJoCo's forward dynamics on this file are not measured (the mujoco "
                        "extra is not installed: pip install 'manipdyn[mujoco]')"]
    from ..engines.mujoco.fidelity import forward_dynamics_difference

    r = forward_dynamics_difference(arm)
    names = [j.name for j in arm.chain()[0]]

    def per_joint(values):
        return ", ".join(f"{nm} {float(x):.3g}" for nm, x in zip(names, values))

    return lines + ["frictionloss, measured (the line above compares the laws' formulas): MuJoCo solves it as a soft "
                    f"constraint, so on {r['samples']} seeded sliding states (|qd| >= {r['sliding']:g}) its forward "
                    "dynamics on this file differ from the model's by up to, per joint, in joint torque "
                    f"M (qacc - qdd), N m or N: {per_joint(r['torque'])}; in qdd, rad/s^2 or m/s^2: "
                    f"{per_joint(r['qdd'])}"]


def register(sub) -> None:
    """Add ``manipdyn mjcf``."""
    add_writer_command(sub, "mjcf", "write the MJCF (MuJoCo) of arms",
                       "Write <name>.xml, MuJoCo's MJCF, for each arm into OUTDIR (created if "
                       "needed): bodies and inertials at full precision; joints with axis, range, "
                       "armature (rotor inertia), damping and frictionloss; one motor per joint; a "
                       "'tool' site; gravity. A body MuJoCo's compiler refuses (mass or a principal "
                       "moment at or below 1e-15, a triangle inequality broken) is written completed: a "
                       "physical body with the model's base parameters, so the dynamics are the "
                       "model's (or, where none exists, the nearest physical arm, with its largest "
                       "torque difference); --as-published keeps the raw values. What MJCF cannot hold "
                       "of the model (friction terms, limits, bodies completed) is written in the file's "
                       "comment and printed, one 'not held:' line each. Any model `manipdyn load` reads, an "
                       "identified one included. Exit 0 written, 2 usage or model error.", "xml", run,
                       "MuJoCo's compiler refuses")
