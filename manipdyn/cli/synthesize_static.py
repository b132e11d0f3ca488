"""``manipdyn synthesize --static-friction RATIO [--stribeck-velocity V]``: a truth that sticks at rest.

Layer 7 (CLI, the top).

The options of :mod:`manipdyn.cli.synthesize` for a truth with static friction
(:mod:`manipdyn.identification.experiments.static_friction`): breakaway ``Fs = RATIO x Fc`` per joint
above the truth's Coulomb level ``Fc``, a Stribeck decay between them of velocity ``V``, and at rest
a held torque within ``[-Fs, Fs]`` of the last motion's sign.  What was drawn is said in the
command's output (``--json``: ``static_friction``) and in the ``--truth`` file's description, whose
``[friction]`` holds the law in motion.
"""

from __future__ import annotations

from .._support.errors import ModelError

__all__ = ["add_options", "apply", "describe", "report"]


def add_options(p) -> None:
    """Add ``--static-friction`` and ``--stribeck-velocity`` to ``synthesize``'s parser ``p``."""
    from ..identification.experiments.static_friction import DEFAULT_STRIBECK_VELOCITY

    p.add_argument("--static-friction", type=float, default=None, metavar="RATIO",
                   help="a truth with static friction: breakaway level Fs = RATIO x the truth's Coulomb level "
                        "(RATIO from 1 to 100; the truth needs Coulomb friction: --perturb adds it), a Stribeck decay from "
                        "Fs to Coulomb as the joint speeds up, and at rest (qd = 0, as on the rests of excite "
                        "--ptp) a held torque within [-Fs, Fs] of the last motion's sign, its level drawn per rest "
                        "from U(0, 1) x Fs (seeded by --seed) (default: none, Coulomb's sign(0) = 0 at rest)")
    p.add_argument("--stribeck-velocity", type=float, default=None, metavar="V",
                   help=f"with --static-friction: the Stribeck velocity, rad/s (m/s): friction "
                        f"Fc + (Fs - Fc) exp(-(v / V)^2) (default {DEFAULT_STRIBECK_VELOCITY:g})")


def apply(args, robot):
    """``robot`` with the static friction the options ask for (itself without them); a ModelError names the
    option."""
    from .._support import limits
    from ..identification.experiments.static_friction import (DEFAULT_STRIBECK_VELOCITY, MAX_RATIO,
                                                              with_static_friction)

    if args.static_friction is None:
        if args.stribeck_velocity is not None:
            raise ModelError("--stribeck-velocity: only with --static-friction RATIO")
        return robot
    if not 1 <= args.static_friction <= MAX_RATIO:
        raise ModelError(f"--static-friction: expected a ratio Fs / Fc from 1 to {MAX_RATIO:g}, got {args.static_friction}")
    if args.stribeck_velocity is None:
        args.stribeck_velocity = DEFAULT_STRIBECK_VELOCITY
    if not limits.MIN_SMOOTHING <= args.stribeck_velocity <= 1e6:
        raise ModelError(f"--stribeck-velocity: expected a velocity from {limits.MIN_SMOOTHING:g} to 1e6 (rad/s or "
                         f"m/s), got {args.stribeck_velocity}")
    return with_static_friction(robot, args.static_friction, args.stribeck_velocity, where="--static-friction")


def describe(args) -> str:
    """The words for the truth file's description ('' without static friction)."""
    if args.static_friction is None:
        return ""
    return (f"; static friction {args.static_friction:g} x Coulomb with a Stribeck decay (velocity "
            f"{args.stribeck_velocity:g}), and at rest a held torque sign(last motion) x U(0, 1) x Fs drawn per rest "
            f"(seed {args.seed}), which no model file holds")


def report(args, robot) -> dict | None:
    """The ``static_friction`` entry of ``--json`` (None without it)."""
    if args.static_friction is None:
        return None
    from ..identification.experiments.static_friction import static_levels

    law = robot.friction_model
    return {"ratio": args.static_friction, "stribeck_velocity": args.stribeck_velocity,
            "coulomb": [float(x) for x in law.coulomb], "static": [float(x) for x in static_levels(robot)],
            "at_rest": "sign(last motion) x U(0, 1) x static, drawn per rest"}
