"""The simulated arm of one run: the nominal arm's Pinocchio model, changed by a draw.

Layer 6 (control: montecarlo).

A :class:`Plant` is what :func:`manipdyn.simulate` needs of its ``plant``
argument (``n``, ``name``, ``joint_types``, ``forward_dynamics`` and the
``pinocchio`` engine), built in microseconds from a copy of the nominal
``pin.Model`` rather than from a new URDF, so it works alike for DH and URDF
arms and costs nothing next to a simulation.

For a DH arm it is the same arm as
``with_payload(with_scaled_inertia(arm, scale), mass, com)`` with the drawn
friction added (tests/test_montecarlo.py checks the forward dynamics agree).

For a study in MuJoCo (``simulator="mujoco"``) the same plant becomes an arm of its own,
:func:`plant_arm`: the nominal arm carrying the plant's inertial parameters, rotor inertias
and friction (:func:`manipdyn.identification.estimation.model.arm_with_parameters`), whose
MJCF (:func:`manipdyn.to_mjcf`, compiled by ``arm.engine("mujoco")``) MuJoCo steps
(:mod:`manipdyn.control.mjsim`).  Its forward dynamics are the plant's to rounding
(tests/test_montecarlo_mujoco.py).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ...engines.pinocchio.engine import PinocchioEngine
from .distributions import RunDraw

__all__ = ["Plant", "make_plant", "plant_arm"]


class Plant:
    """One run's plant: a Pinocchio engine with the arm's joint names and types.

    Attributes
    ----------
    n : int
    name : str
        ``"<arm> run <k>"``.
    joint_types : tuple of str
    pinocchio : PinocchioEngine
        The engine on the changed model (friction included).
    forward_dynamics : callable
        ``qdd = forward_dynamics(q, qd, tau)``, checked (the engine's).
    draw : RunDraw
        The variations this plant was built from.
    """

    def __init__(self, arm, engine: PinocchioEngine, draw: RunDraw):
        self.n = arm.n
        self.name = f"{arm.name or 'arm'} run {draw.run}"
        self.joint_types = tuple(arm.joint_types)
        self.pinocchio = engine
        self.forward_dynamics = engine.forward_dynamics
        self.draw = draw

    def __repr__(self) -> str:
        d = self.draw
        return (f"<Plant {self.name!r}: payload {d.payload_mass:.3g} kg at {np.round(d.payload_com, 4).tolist()} m, "
                f"link scale {np.round(d.scale, 3).tolist()}>")


def make_plant(arm, draw: RunDraw) -> Plant:
    """The nominal ``arm`` changed by ``draw``: scaled links, a payload, more friction.

    * each body ``j`` (Pinocchio joint ``j``, chain joint ``j``) keeps its centre
      of mass and has its mass and rotational inertia multiplied by ``scale[j-1]``;
    * a point mass ``payload_mass`` at ``payload_com`` (tool frame) is added to
      the last body: the tool frame is ``arm.chain()[1]`` in the last body's frame;
    * the friction is ``arm.friction + draw.friction`` (zero where the arm has none);
    * rotor inertias (``model.armature``) and gravity are the arm's.
    """
    model = arm.pinocchio.model.copy()
    n = arm.n
    for j in range(1, n + 1):
        body = model.inertias[j]
        s = float(draw.scale[j - 1])
        model.inertias[j] = pin.Inertia(body.mass * s, body.lever.copy(), body.inertia * s)
    if draw.payload_mass > 0:
        tool = np.asarray(arm.chain()[1], dtype=np.float64)
        c = tool[:3, :3] @ draw.payload_com + tool[:3, 3]
        model.inertias[n] = model.inertias[n] + pin.Inertia(draw.payload_mass, c, np.zeros((3, 3)))
    friction = draw.friction.copy()
    if arm.friction is not None:
        friction = friction + arm.friction
    return Plant(arm, PinocchioEngine(model, friction=friction, num_threads=1), draw)


def plant_arm(arm, plant: Plant):
    """The plant ``plant`` of a study on ``arm`` as an arm (DH or URDF, as ``arm``) with an MJCF.

    Each body carries the plant model's inertial parameters (``pin.Inertia.toDynamicParameters``
    of Pinocchio joint ``j``: the URDF link frame ``j``, the layout of ``arm.parameters()``), the
    rotor inertias are the plant model's ``armature`` when they differ from the nominal arm's,
    and the friction is the plant's own, viscous and Coulomb on the joint side with a sharp sign
    (``Fv qd + Fc sign(qd)``, what :class:`Plant` simulates), none when the plant has none.
    Named ``plant.name``.
    """
    from ...identification.estimation.model import arm_with_parameters

    engine = plant.pinocchio
    model, n = engine.model, arm.n
    pi = [np.concatenate([model.inertias[j].toDynamicParameters() for j in range(1, n + 1)])]
    armature = not np.array_equal(np.asarray(model.armature), np.asarray(arm.pinocchio.model.armature))
    if armature:
        pi.append(np.asarray(model.armature, dtype=np.float64))
    fr = np.zeros((2, n)) if engine.friction is None else np.asarray(engine.friction, dtype=np.float64)
    pi += [fr[0], fr[1]]
    import warnings

    from ..._support.errors import PhysicalConsistencyWarning

    with warnings.catch_warnings():      # the nominal arm's own notes (the Puma's links) were said once, at load
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        return arm_with_parameters(arm, np.concatenate(pi), armature=armature, friction=True, name=plant.name)
