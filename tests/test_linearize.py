"""``arm.linearize``: the continuous and zero-order-hold (A, B) of x = (q, qd).

Tolerances: ROUNDING (1e-12 relative) for the same exact quantity computed two
ways in float64; the finite-difference referee of ``tests/test_derivatives.py``
(FD_TOL = 1e-6 with step 1e-5, scaled by cond(D)/100 for forward dynamics);
1e-12 against SciPy's ``expm`` (both exact to rounding for these small,
well-scaled matrices).
"""

from __future__ import annotations

import numpy as np
import pytest

import manipdyn as md
from manipdyn.engines.linearize import zero_order_hold

import arms
from test_derivatives import FD_TOL, ROUNDING, _central, _friction_arm, _rel


def _setup(seed):
    arm = _friction_arm(seed) if seed % 2 else arms.random_arm(seed)
    q, qd, qdd = arms.random_state(np.random.default_rng([seed, 3]), arm)
    qd = np.where(np.abs(qd) < 1e-3, 0.5, qd)               # off the Coulomb kink
    tau = arm.lagrange.inverse_dynamics(q, qd, qdd)
    return arm, q, qd, tau


@pytest.mark.parametrize("seed", range(6))
def test_continuous_pair_is_the_jacobian_of_the_state_equation(seed):
    arm, q, qd, tau = _setup(seed)
    n = arm.n
    A, B = arm.linearize(q, qd, tau)
    assert A.shape == (2 * n, 2 * n) and B.shape == (2 * n, n)

    def f(x, u=tau):
        return np.concatenate([x[n:], arm.pinocchio.forward_dynamics(x[:n], x[n:], u)])

    x = np.concatenate([q, qd])
    cond = float(np.linalg.cond(arm.mass_matrix(q)))
    tol = FD_TOL * max(1.0, cond / 100)
    fa, fb = _central(f, x), _central(lambda u: f(x, u), tau)
    assert _rel(A, fa, max(1.0, float(np.abs(fa).max()))) <= tol
    assert _rel(B, fb, max(1.0, float(np.abs(fb).max()))) <= tol
    # both engines give the same pair (the cross-check's 1e-9)
    AL, BL = arm.linearize(q, qd, tau, engine="lagrange")
    assert _rel(A, AL) <= 1e-9 and _rel(B, BL) <= 1e-9


def test_zero_order_hold_of_a_double_integrator_is_exact():
    dt = 0.01
    Ad, Bd = zero_order_hold(np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]]), dt)
    np.testing.assert_allclose(Ad, [[1.0, dt], [0.0, 1.0]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(Bd, [[dt * dt / 2], [dt]], rtol=0, atol=1e-15)


@pytest.mark.parametrize("dt", [1e-3, 0.01, 0.5])
def test_discrete_pair_matches_scipy_expm(dt):
    linalg = pytest.importorskip("scipy.linalg", reason="SciPy (the identify extra) is the referee here")
    arm, q, qd, tau = _setup(3)
    n = arm.n
    A, B = arm.linearize(q, qd, tau)
    Ad, Bd = arm.linearize(q, qd, tau, dt=dt)
    M = np.zeros((3 * n, 3 * n))
    M[:2 * n, :2 * n], M[:2 * n, 2 * n:] = A * dt, B * dt
    E = linalg.expm(M)
    assert _rel(Ad, E[:2 * n, :2 * n]) <= ROUNDING
    assert _rel(Bd, E[:2 * n, 2 * n:]) <= ROUNDING


def test_batch_is_a_stack_of_singles():
    arm = arms.random_arm(4, n=5)
    q, qd, qdd = arms.random_state(np.random.default_rng(4), arm, size=6)
    tau = arm.pinocchio.inverse_dynamics(q, qd, qdd)
    for dt in (None, 0.02):
        A, B = md.linearize(arm, q, qd, tau, dt=dt)
        assert A.shape == (6, 10, 10) and B.shape == (6, 10, 5)
        for i in range(6):
            a, b = arm.linearize(q[i], qd[i], tau[i], dt=dt)
            # the stack is scaled by its largest norm: rounding of a few extra squarings
            assert _rel(A[i], a) <= ROUNDING and _rel(B[i], b) <= ROUNDING


@pytest.mark.parametrize("dt", [0, -0.1, float("nan"), float("inf"), "0.1", True])
def test_bad_dt_is_named(dt):
    arm = md.load("ur5")
    z = np.zeros(6)
    with pytest.raises(md.StateError, match="dt: expected a positive finite time step"):
        arm.linearize(z, z, z, dt=dt)


def test_linearize_has_its_docstring():
    assert "zero-order hold" in md.Arm.linearize.__doc__
