"""The A matrices: the batched coefficient form against eq. 2.3 / Craig written out."""

from __future__ import annotations

import math

import numpy as np
import pytest

import manipdyn as md
from manipdyn.model.kinematics import DHKinematics, dh_modified, dh_standard, rot_x, rot_z, trans


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_batched_A_equals_the_written_out_transforms(convention):
    rng = np.random.default_rng(4)
    links = [md.DHLink(joint=j, a=rng.normal(), alpha=rng.uniform(-3, 3), d=rng.normal(),
                       theta=rng.uniform(-3, 3)) for j in ("revolute", "prismatic", "revolute")]
    kin = DHKinematics(links, convention)
    q = rng.uniform(-2, 2, (5, 3))
    A = kin.A(q)
    for b in range(5):
        for i, l in enumerate(links):
            th = q[b, i] + l.theta if l.joint == "revolute" else l.theta
            d = l.d if l.joint == "revolute" else q[b, i] + l.d
            if convention == "standard":   # eq. 2.3: Rz(theta) Tz(d) Tx(a) Rx(alpha)
                expect = rot_z(th) @ trans(0, 0, d) @ trans(l.a, 0, 0) @ rot_x(l.alpha)
                closed = dh_standard(th, d, l.a, l.alpha)
            else:                          # Craig: Rx(alpha) Tx(a) Rz(theta) Tz(d)
                expect = rot_x(l.alpha) @ trans(l.a, 0, 0) @ rot_z(th) @ trans(0, 0, d)
                closed = dh_modified(th, d, l.a, l.alpha)
            np.testing.assert_allclose(A[b, i], expect, atol=1e-14)
            np.testing.assert_allclose(closed, expect, atol=1e-14)
            np.testing.assert_allclose(l.A(q[b, i], convention), expect, atol=1e-14)


def test_prismatic_eq_2_4_is_eq_2_3_with_a_zero():
    l = md.DHLink(joint="prismatic", a=0.0, alpha=0.4, theta=-math.pi / 2, d=0.1)
    A = l.A(0.3)
    assert A[0, 3] == 0.0 and A[1, 3] == 0.0 and A[2, 3] == pytest.approx(0.4)


def test_DHLink_A_refuses_an_unknown_convention():
    with pytest.raises(md.ModelError, match="convention: must be 'standard' or 'modified'"):
        md.DHLink().A(0.0, "craig")
