"""Arm builders for the tests: the random arms of :mod:`manipdyn.model.random_arms`, and Corke's Puma.

* :func:`random_rotation`, :func:`random_physical_inertia`: a rigid body that
  exists (principal moments positive and obeying the triangle inequalities,
  CONVENTIONS.md "Physical consistency"), in randomly rotated axes.
* :func:`random_arm`: a seeded random DH arm, standard or modified, mixed
  revolute/prismatic, with physical inertias and optional rotors.
* :func:`random_state`: joint positions/velocities/accelerations for an arm.
* :func:`puma560`: Corke's standard-DH Puma 560 (the classic data set, with its
  massless link 1 carrying Iyy = 0.35 kg m^2).

Everything takes a ``numpy.random.Generator`` or a seed, so a failing example
is reproduced by its seed alone.
"""

from __future__ import annotations

import math


import manipdyn as md
from manipdyn.model.random_arms import (COM, LENGTH, MASS, MOMENT, as_generator, random_arm,  # noqa: F401 (re-exported)
                                  random_dh_link, random_physical_inertia, random_principal_moments,
                                  random_rotation, random_state)

# ---------------------------------------------------------------------------
# Puma 560 (Corke's Robotics Toolbox, standard DH, "mdl_puma560")
# ---------------------------------------------------------------------------
PUMA560 = dict(
    a=[0.0, 0.4318, 0.0203, 0.0, 0.0, 0.0],
    d=[0.0, 0.0, 0.15005, 0.4318, 0.0, 0.0],
    alpha=[math.pi / 2, 0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, 0.0],
    m=[0.0, 17.4, 4.8, 0.82, 0.34, 0.09],
    r=[[0, 0, 0], [-0.3638, 0.006, 0.2275], [-0.0203, -0.0141, 0.070],
       [0, 0.019, 0], [0, 0, 0], [0, 0, 0.032]],
    I=[[0, 0.35, 0], [0.13, 0.524, 0.539], [0.066, 0.086, 0.0125],
       [1.8e-3, 1.3e-3, 1.8e-3], [0.3e-3, 0.4e-3, 0.3e-3], [0.15e-3, 0.15e-3, 0.04e-3]],
)


def puma560_links(link1_inertia=None) -> list[md.DHLink]:
    """The six DH links of Corke's Puma 560 (no rotors, no friction).

    ``link1_inertia`` replaces link 1's diagonal inertia (the published data
    puts Iyy = 0.35 kg m^2 on a massless link).
    """
    p = PUMA560
    I = [list(v) for v in p["I"]]
    if link1_inertia is not None:
        I[0] = list(link1_inertia)
    return [
        md.DHLink("revolute", a=p["a"][i], alpha=p["alpha"][i], d=p["d"][i],
                  mass=p["m"][i], com=p["r"][i], inertia=I[i], name=f"link{i + 1}")
        for i in range(6)
    ]


def puma560(link1_inertia=None, **kw) -> md.Manipulator:
    """Corke's Puma 560, standard DH.

    Warns (PhysicalConsistencyWarning) about link 1 (massless, Iyy = 0.35) and
    link 3 (Ixx + Izz = 0.0785 < Iyy = 0.086): the published data are not
    those of real rigid bodies.

    Call under ``pytest.warns`` or ``warnings.catch_warnings`` if the warning matters.
    """
    return md.Manipulator(puma560_links(link1_inertia), convention="standard",
                          name="puma560", **kw)
