"""The doors of inertia.py: one function per convention crossing, each undone by its inverse.

A thin rod of mass m and length L along x, centred at (L/2, 0, 0) of its frame,
is the closed-form body (any mechanics text: I_C = m L^2 / 12 about the
transverse axes through the centre, I_O = m L^2 / 3 about the end).
"""

from __future__ import annotations

import numpy as np
import pytest

from manipdyn.model import inertia as mi
from manipdyn.model.random_arms import random_physical_inertia

M, L = 2.0, 0.6
COM = np.array([L / 2, 0.0, 0.0])
I_C = np.diag([0.0, M * L**2 / 12, M * L**2 / 12])


def test_parallel_axis_on_a_rod():
    I_O = mi.inertia_about_origin_from_com(M, COM, I_C)
    np.testing.assert_allclose(I_O, np.diag([0.0, M * L**2 / 3, M * L**2 / 3]), atol=1e-15)
    np.testing.assert_allclose(mi.inertia_about_com_from_origin(M, COM, I_O), I_C, atol=1e-15)


def test_rod_pseudo_inertia_is_its_second_moment():
    # J = integral r r^T dm: only x^2 is non-zero, integral_0^L x^2 (M/L) dx = M L^2 / 3
    J = mi.pseudo_inertia_from_tensor(M, COM, I_C)
    expected = np.zeros((4, 4))
    expected[0, 0] = M * L**2 / 3
    expected[0, 3] = expected[3, 0] = M * L / 2
    expected[3, 3] = M
    np.testing.assert_allclose(J, expected, atol=1e-15)
    m, c, I = mi.tensor_from_pseudo_inertia(J)
    assert m == M
    np.testing.assert_allclose(c, COM, atol=1e-15)
    np.testing.assert_allclose(I, I_C, atol=1e-15)


def test_products_of_inertia_change_sign_between_chapter_and_tensor():
    """A point mass at (1, 1, 0): integral x y dm = m > 0; the tensor's I_xy = -m."""
    m = 3.0
    J = mi.pseudo_inertia_from_tensor(m, (1.0, 1.0, 0.0), np.zeros((3, 3)))
    terms = mi.chapter_terms_from_pseudo_inertia(J)
    assert terms["Ixy"] == pytest.approx(+m)              # the chapter's sign (eq. 2.21)
    p = mi.parameters_from_pseudo_inertia(J)
    assert p[5] == pytest.approx(-m)                        # Pinocchio's Ixy: tensor sign, about the origin
    np.testing.assert_allclose(mi.pseudo_inertia_from_chapter_terms(**terms), J, atol=1e-15)


@pytest.mark.parametrize("seed", range(5))
def test_round_trips_on_random_bodies(seed):
    rng = np.random.default_rng(seed)
    m, c, I = float(rng.uniform(0.1, 5)), rng.uniform(-0.3, 0.3, 3), random_physical_inertia(rng)
    J = mi.pseudo_inertia_from_tensor(m, c, I)
    np.testing.assert_allclose(mi.pseudo_inertia_from_parameters(mi.parameters_from_pseudo_inertia(J)), J,
                               rtol=0, atol=1e-14)
    np.testing.assert_allclose(mi.second_moment_from_tensor(mi.tensor_from_second_moment(J[:3, :3])),
                               J[:3, :3], atol=1e-15)
    # moving J and moving the tensor give the same body
    X = np.eye(4)
    X[:3, :3] = np.linalg.qr(rng.standard_normal((3, 3)))[0] * np.array([1, 1, 1])
    if np.linalg.det(X[:3, :3]) < 0:
        X[:3, 0] *= -1
    X[:3, 3] = rng.uniform(-1, 1, 3)
    moved = mi.LinkInertia(m, c, I).transformed(X)
    np.testing.assert_allclose(mi.transform_pseudo_inertia(J, X), moved.J, atol=1e-13)


def test_batched_parameters():
    Js = np.stack([mi.pseudo_inertia_from_tensor(1.0 + k, (0.1 * k, 0, 0), np.eye(3) * 0.01) for k in range(3)])
    P = mi.parameters_from_pseudo_inertia(Js)
    assert P.shape == (3, 10)
    np.testing.assert_allclose(mi.pseudo_inertia_from_parameters(P), Js, atol=1e-15)
    with pytest.raises(ValueError, match="p: expected 10 parameters"):
        mi.pseudo_inertia_from_parameters(np.zeros(9))
