"""Identities that every arm obeys, checked on seeded random arms.

Random arms (``tests/arms.py``): 1 to 8 joints, standard or modified DH,
revolute and prismatic joints mixed, physical inertias (positive mass,
principal moments obeying the triangle inequalities, random principal axes),
random COMs, optional rotors, and gravity in a random direction.

Tolerances, stated once (each test says which it uses):

* ROUNDING = 1e-12, relative to ``max(1, |x|)``: for two computations of the
  same exact quantity by different floating-point paths.  The engine and the
  plain-loop reference sum at most n^4 = 4096 products of O(1..100) numbers for
  an 8-joint arm; with eps = 2.2e-16 the accumulated rounding is far below
  1e-12 of the result's scale (measured: < 3e-14 over 300 random arms), and
  any modelling error is O(1) relative.
* Finite differences: a central difference with step ``e`` has truncation
  error ``e^2/6 |f'''|`` and rounding error ``~ k eps |f| / e`` (k the number of
  operations behind f, ~100 here).  Each test derives its bound from the step
  and a scale of f computed from the arm, and keeps 100x margin.
"""

from __future__ import annotations


import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st

import manipdyn as md

import arms
import reference as ref

EPS = np.finfo(float).eps
ROUNDING = 1e-12  # see the module docstring

seeds = st.integers(0, 2**32 - 1)
joint_counts = st.integers(1, 8)
conventions = st.sampled_from(["standard", "modified"])
prismatic_fractions = st.sampled_from([0.0, 0.3, 0.6, 1.0])


def arm_and_state(seed, n, convention, pfrac, size=None):
    arm = arms.random_arm(seed, n=n, convention=convention, prismatic_fraction=pfrac)
    q, qd, qdd = arms.random_state(np.random.default_rng([seed, 1]), arm, size=size)
    return arm, q, qd, qdd


def assert_rounding_close(actual, expected, what=""):
    """|actual - expected| <= ROUNDING * max(1, |expected|), element by element."""
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, (what, actual.shape, expected.shape)
    err = np.abs(actual - expected) / np.maximum(1.0, np.abs(expected))
    worst = float(np.max(err)) if err.size else 0.0
    assert worst <= ROUNDING, f"{what}: relative error {worst:.3g} > {ROUNDING}"


def lever_arm(arm, q) -> float:
    """Largest distance between a joint frame origin and a link COM, in metres (>= 1).

    It bounds every moment arm in the chain at ``q``, hence the size of the
    derivatives of P and D with respect to the joint angles.  Computed with the
    reference kinematics.
    """
    T = ref.link_poses(arm.links, arm.convention, q)
    origins = [Ti[:3, 3] for Ti in T]
    coms = [(T[i] @ np.append(arm.links[i - 1].com, 1.0))[:3] for i in range(1, arm.n + 1)]
    return max(1.0, max(np.linalg.norm(o - c) for o in origins for c in coms))


def inertia_scale(arm, rho) -> float:
    """``sum_p (m_p rho^2 + tr I_p) + sum armature``: bounds every |D_ij| (kg m^2)."""
    return sum(l.mass * rho**2 + float(np.trace(l.inertia)) + l.armature for l in arm.links)


def common_examples(f):
    """The corners Hypothesis must always visit, even with few examples."""
    for n in (1, 8):
        for conv in ("standard", "modified"):
            f = example(seed=n, n=n, convention=conv, pfrac=0.3)(f)
    f = example(seed=11, n=5, convention="standard", pfrac=1.0)(f)  # all prismatic
    f = example(seed=12, n=5, convention="modified", pfrac=0.0)(f)  # all revolute
    return f


# ---------------------------------------------------------------------------
# Mass matrix and kinetic energy
# ---------------------------------------------------------------------------


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_mass_matrix_symmetric_positive_definite(seed, n, convention, pfrac):
    """D is symmetric (eq. 2.30: the trace is invariant to the swap of i and j) and
    positive definite for a physical arm: the first joint j with qd_j != 0 moves
    link j, whose J is positive definite, so qd^T D qd = 2K > 0."""
    arm, q, _, _ = arm_and_state(seed, n, convention, pfrac)
    D = arm.lagrange.mass_matrix(q)
    assert D.shape == (n, n)
    assert np.all(np.isfinite(D))
    # D_ij and D_ji are computed separately: ROUNDING (module docstring)
    assert_rounding_close(D, D.T, "D - D^T")
    np.linalg.cholesky(0.5 * (D + D.T))  # raises LinAlgError unless positive definite
    # and not by a whisker: every body has principal moments >= 1e-3 * 0.05 kg m^2
    # (arms.random_principal_moments), far above rounding (~1e-14 * max|D|)
    assert np.linalg.eigvalsh(0.5 * (D + D.T))[0] > 1e3 * EPS * np.max(np.abs(D)) * n


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_kinetic_energy_is_quadratic_form_of_D(seed, n, convention, pfrac):
    """K (eq. 2.22, traced per link, plus rotors) equals qd^T D qd / 2 (eq. 2.39's D).

    Tolerance: ROUNDING relative to ``1/2 |qd|^T |D| |qd|``, the sum of the
    absolute values of the terms, which bounds the rounding of both sides."""
    arm, q, qd, _ = arm_and_state(seed, n, convention, pfrac)
    D = arm.lagrange.mass_matrix(q)
    K = arm.lagrange.kinetic_energy(q, qd)
    scale = 0.5 * np.abs(qd) @ np.abs(D) @ np.abs(qd)
    assert abs(K - 0.5 * qd @ D @ qd) <= ROUNDING * max(1.0, scale)
    assert K > 0


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_own_speed_exerts_no_torque_on_itself(seed, n, convention, pfrac):
    """D_iii = 0: moving joint i alone carries every later link rigidly about (or
    along) axis i, which leaves D_ii unchanged, and D_iii = 1/2 dD_ii/dq_i.  So with
    only qd_i != 0, h_i = D_iii qd_i^2 = 0.  Tolerance: ROUNDING relative to the
    size of the terms that cancel, ``S_D qd_i^2`` (S_D bounds |D_ij|, see
    :func:`inertia_scale`; rho >= 1 m makes it bound D_ijk as well)."""
    arm, q, qd, _ = arm_and_state(seed, n, convention, pfrac)
    S_D = inertia_scale(arm, lever_arm(arm, q))
    for i in range(n):
        e = np.zeros(n)
        e[i] = qd[i]
        h = arm.lagrange.coriolis_torque(q, e)
        assert abs(h[i]) <= ROUNDING * max(1.0, S_D * qd[i] ** 2)


# ---------------------------------------------------------------------------
# Gravity and Coriolis torques from the energies
# ---------------------------------------------------------------------------


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_gravity_is_gradient_of_potential_energy(seed, n, convention, pfrac):
    """g(q) = dP/dq (eq. 2.23, 2.24 and 2.35's last term), by central differences of P.

    Step e = 1e-5 (rad or m).  Bound: with S = sum_p m_p |g| rho (rho the
    largest moment arm, :func:`lever_arm`), a revolute joint turns the COMs on
    circles of radius <= rho, so |d^3P/dq_i^3| <= S; a prismatic joint moves them
    on lines, P is affine and the truncation error vanishes.  Truncation
    <= e^2/6 S = 1.7e-11 S; rounding <= k eps S / e ~ 2e-9 S (k ~ 100).  So the
    difference is below ~2e-9 S; 1e-7 S keeps 50x margin, while a real error
    in g is O(S).
    """
    arm, q, _, _ = arm_and_state(seed, n, convention, pfrac)
    lag = arm.lagrange
    e = 1e-5
    dP = np.empty(n)
    for i in range(n):
        dq = np.zeros(n)
        dq[i] = e
        dP[i] = (lag.potential_energy(q + dq) - lag.potential_energy(q - dq)) / (2 * e)
    S = sum(l.mass for l in arm.links) * np.linalg.norm(arm.gravity) * lever_arm(arm, q)
    np.testing.assert_allclose(lag.gravity_torque(q), dP, rtol=0, atol=1e-7 * S)


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_coriolis_torque_from_lagrange_equation(seed, n, convention, pfrac):
    """h = dD/dt qd - dK/dq: Lagrange's equation (2.10) applied numerically to L = K - P.

    With L = 1/2 qd^T D(q) qd - P(q), d/dt(dL/dqd) = D qdd + dD/dt qd and
    dL/dq = dK/dq - dP/dq, so the velocity terms of eq. 2.39 are
    ``h = dD/dt qd - dK/dq``.  ``dD/dt = v dD/ds`` is the derivative of D along
    the unit (1-norm) direction ``u = qd / v``, ``v = sum |qd_i|``, by central
    differences ``(D(q + e u) - D(q - e u)) / 2e``; ``dK/dq_i`` by central
    differences of the engine's K (eq. 2.22, computed without D).  Also checks
    the power identity ``qd . h = 1/2 qd^T dD/dt qd`` (dD/dt - 2C skew-symmetric).

    Tolerance, step e = 1e-5 (rad or m).  S_D = sum (m rho^2 + tr I) + armature
    bounds |D_ij| (rho >= 1 m the largest lever arm).  D is a sum of products
    of six q-dependent chains (T_p, T_p^T and the T, T^-1 inside the two
    generators), each with |d/ds| <= |chain| along a unit 1-norm direction, so
    |d^3 D/ds^3| <= 6^3 S_D.  Per unit direction: truncation <= e^2/6 * 216 S_D
    = 3.6e-9 S_D, rounding <= k eps S_D / e ~ 2.2e-9 S_D (k ~ 100): ~6e-9 S_D.
    ``dD/dt qd`` scales that by ``v * n max|qd|``, ``dK/dq`` (K <= S_D v^2 / 2) by
    ``v^2``.  Tolerance 1e-6 S_D v (n max|qd| + v): > 100x margin (measured error
    < 1e-5 of it), while an error in h is O(S_D v^2).
    """
    arm, q, qd, _ = arm_and_state(seed, n, convention, pfrac)
    lag = arm.lagrange
    e = 1e-5
    v = float(np.sum(np.abs(qd)))
    u = qd / v
    Ddot = v * (lag.mass_matrix(q + e * u) - lag.mass_matrix(q - e * u)) / (2 * e)
    dK = np.empty(n)
    for i in range(n):
        dq = np.zeros(n)
        dq[i] = e
        dK[i] = (lag.kinetic_energy(q + dq, qd) - lag.kinetic_energy(q - dq, qd)) / (2 * e)
    h_lagrange = Ddot @ qd - dK
    h = lag.coriolis_torque(q, qd)
    S_D = inertia_scale(arm, lever_arm(arm, q))
    tol = 1e-6 * S_D * v * (n * float(np.max(np.abs(qd))) + v)
    np.testing.assert_allclose(h, h_lagrange, rtol=0, atol=tol)
    assert abs(qd @ h - 0.5 * qd @ Ddot @ qd) <= tol * v


# ---------------------------------------------------------------------------
# Forward dynamics
# ---------------------------------------------------------------------------


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_forward_dynamics_undoes_inverse_dynamics(seed, n, convention, pfrac):
    """qdd -> tau = ID(q, qd, qdd) -> FD(q, qd, tau) gives qdd back.

    Error bound from perturbation theory of D x = b: the right-hand side
    ``tau - h - g`` carries rounding ~ n eps (|D| |qdd| + |h| + |g|) and the solve
    a backward error ~ n eps |D| |qdd|; so |dqdd| <= |D^-1| c n eps (|D||qdd| +
    |h| + |g|), with |D^-1| = 1/lambda_min(D).  c = 100 covers the constants.
    """
    arm, q, qd, qdd = arm_and_state(seed, n, convention, pfrac)
    lag = arm.lagrange
    tau = lag.inverse_dynamics(q, qd, qdd)
    qdd_back = lag.forward_dynamics(q, qd, tau)
    D, h, g = lag.dynamics_terms(q, qd)
    lam_min = np.linalg.eigvalsh(D)[0]
    rhs_scale = np.linalg.norm(D, 2) * np.linalg.norm(qdd) + np.linalg.norm(h) + np.linalg.norm(g)
    bound = 100 * n * EPS * rhs_scale / lam_min
    assert np.linalg.norm(qdd_back - qdd) <= bound
    # and the residual of the equation itself (backward error, no 1/lambda_min)
    resid = D @ qdd_back + h + g - tau
    assert np.linalg.norm(resid) <= 100 * n * EPS * (rhs_scale + np.linalg.norm(tau))


# ---------------------------------------------------------------------------
# The vectorised engine against the plain-loop transcription of chapter II
# ---------------------------------------------------------------------------


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_engine_matches_reference(seed, n, convention, pfrac):
    """D, h, g, tau (eq. 2.39), K (2.22), P (2.24), T_i (2.7) and the end pose:
    the regrouped, batched engine against tests/reference.py; ROUNDING tolerance."""
    arm, q, qd, qdd = arm_and_state(seed, n, convention, pfrac)
    L, conv, grav = arm.links, arm.convention, arm.gravity
    lag = arm.lagrange
    D, h, g = lag.dynamics_terms(q, qd)
    Dr = ref.mass_matrix(L, conv, q)
    hr = ref.coriolis_torque(L, conv, q, qd)
    gr = ref.gravity_torque(L, conv, grav, q)
    assert_rounding_close(D, Dr, "D")
    assert_rounding_close(h, hr, "h")
    assert_rounding_close(g, gr, "g")
    assert_rounding_close(lag.mass_matrix(q), Dr, "mass_matrix")
    assert_rounding_close(lag.coriolis_torque(q, qd), hr, "coriolis_torque")
    assert_rounding_close(lag.gravity_torque(q), gr, "gravity_torque")
    assert_rounding_close(lag.inverse_dynamics(q, qd, qdd),
                          ref.inverse_dynamics(L, conv, grav, q, qd, qdd), "tau")
    assert_rounding_close(lag.kinetic_energy(q, qd), ref.kinetic_energy(L, conv, q, qd), "K")
    assert_rounding_close(lag.potential_energy(q), ref.potential_energy(L, conv, grav, q), "P")
    T = ref.link_poses(L, conv, q)
    assert_rounding_close(arm.link_poses(q), np.array(T[1:]), "link_poses")
    assert_rounding_close(arm.fkine(q), T[n], "fkine")


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_reference_derivatives_match_finite_differences(seed, n, convention, pfrac):
    """The reference's Q-matrix derivatives (CONVENTIONS.md) are the derivatives of its
    own T_p (eq. 2.7): checks the reference independently of the engine.

    dT_p/dq_j by central differences of T_p; d2T_p/dq_j dq_k by central differences
    of the analytic dT_p/dq_k in q_j.  Step e = 1e-5; entries of T and its
    derivatives are bounded by rho (lever arm, >= 1), third derivatives too, so
    truncation <= e^2/6 rho ~ 2e-11 rho and rounding <= k eps rho / e ~ 2e-9 rho
    (k ~ 100); 1e-7 rho keeps 50x margin.
    """
    arm, q, _, _ = arm_and_state(seed, n, convention, pfrac)
    L, conv = arm.links, arm.convention
    e = 1e-5
    rho = lever_arm(arm, q) + max(np.linalg.norm(Ti[:3, 3]) for Ti in ref.link_poses(L, conv, q))
    ch = ref.Chain(L, conv, q)
    for j in range(1, n + 1):
        dq = np.zeros(n)
        dq[j - 1] = e
        plus, minus = ref.Chain(L, conv, q + dq), ref.Chain(L, conv, q - dq)
        for p in range(1, n + 1):
            fd = (plus.T[p] - minus.T[p]) / (2 * e)
            np.testing.assert_allclose(ch.dT(p, j), fd, rtol=0, atol=1e-7 * rho)
            for k in range(1, n + 1):
                fd2 = (plus.dT(p, k) - minus.dT(p, k)) / (2 * e)
                np.testing.assert_allclose(ch.d2T(p, j, k), fd2, rtol=0, atol=1e-7 * rho)


# ---------------------------------------------------------------------------
# Batches
# ---------------------------------------------------------------------------


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_batch_equals_single_states(seed, n, convention, pfrac):
    """Every method on a batch (N, n) returns, row by row, what it returns for each
    state (n,).  Both paths run the same operations per state (a single state is a
    batch of one); numpy may only pick a differently vectorised inner loop, which
    reorders sums of at most n terms: a few ulps.  Tolerance 1e-14 ~ 45 eps
    relative to max(1, |x|) (measured: bitwise equal)."""
    N = 4
    arm, q, qd, qdd = arm_and_state(seed, n, convention, pfrac, size=N)
    lag = arm.lagrange
    tau = lag.inverse_dynamics(q, qd, qdd)
    batch = {
        "mass_matrix": lag.mass_matrix(q),
        "coriolis_torque": lag.coriolis_torque(q, qd),
        "gravity_torque": lag.gravity_torque(q),
        "inverse_dynamics": tau,
        "forward_dynamics": lag.forward_dynamics(q, qd, tau),
        "kinetic_energy": lag.kinetic_energy(q, qd),
        "potential_energy": lag.potential_energy(q),
        "link_poses": arm.link_poses(q),
        "fkine": arm.fkine(q),
    }
    Db, hb, gb = lag.dynamics_terms(q, qd)
    shapes = {"mass_matrix": (N, n, n), "kinetic_energy": (N,), "potential_energy": (N,),
              "link_poses": (N, n, 4, 4), "fkine": (N, 4, 4)}
    for name, value in batch.items():
        assert value.shape == shapes.get(name, (N, n)), name
    for b in range(N):
        single = {
            "mass_matrix": lag.mass_matrix(q[b]),
            "coriolis_torque": lag.coriolis_torque(q[b], qd[b]),
            "gravity_torque": lag.gravity_torque(q[b]),
            "inverse_dynamics": lag.inverse_dynamics(q[b], qd[b], qdd[b]),
            "forward_dynamics": lag.forward_dynamics(q[b], qd[b], tau[b]),
            "kinetic_energy": lag.kinetic_energy(q[b], qd[b]),
            "potential_energy": lag.potential_energy(q[b]),
            "link_poses": arm.link_poses(q[b]),
            "fkine": arm.fkine(q[b]),
        }
        D1, h1, g1 = lag.dynamics_terms(q[b], qd[b])
        single.update(dt_D=D1, dt_h=h1, dt_g=g1)
        batch_b = {k: v[b] for k, v in batch.items()}
        batch_b.update(dt_D=Db[b], dt_h=hb[b], dt_g=gb[b])
        for name in single:
            x, y = np.asarray(single[name]), np.asarray(batch_b[name])
            assert x.shape == y.shape, name
            err = np.max(np.abs(x - y) / np.maximum(1.0, np.abs(y)))
            assert err <= 1e-14, f"{name}: batch row {b} differs by {err:.3g}"


def test_empty_batch_and_batch_of_one():
    """(0, n) and (1, n) keep their leading axis."""
    arm = arms.random_arm(5, n=3, convention="standard")
    lag = arm.lagrange
    for N in (0, 1):
        q = np.zeros((N, 3))
        assert lag.mass_matrix(q).shape == (N, 3, 3)
        assert lag.inverse_dynamics(q, q, q).shape == (N, 3)
        assert lag.kinetic_energy(q, q).shape == (N,)
        D, h, g = lag.dynamics_terms(q, q)
        assert (D.shape, h.shape, g.shape) == ((N, 3, 3), (N, 3), (N, 3))


# ---------------------------------------------------------------------------
# Eq. 2.2
# ---------------------------------------------------------------------------


@common_examples
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_transform_inverse(seed, n, convention, pfrac):
    """transform_inverse(T) @ T = I = T @ transform_inverse(T) (eq. 2.2), one and batched.

    R is a product of up to 8 rotations, orthogonal to ~n eps; the translation
    part cancels terms of size |p|.  Tolerance 1e-13 (1 + |p|) ~ 450 eps (1 + |p|)."""
    arm, q, _, _ = arm_and_state(seed, n, convention, pfrac, size=3)
    T = arm.link_poses(q)  # (3, n, 4, 4)
    Ti = md.transform_inverse(T)
    assert Ti.shape == T.shape
    I = np.broadcast_to(np.eye(4), T.shape)
    tol = 1e-13 * (1 + np.max(np.abs(T[..., :3, 3])))
    np.testing.assert_allclose(Ti @ T, I, rtol=0, atol=tol)
    np.testing.assert_allclose(T @ Ti, I, rtol=0, atol=tol)
    np.testing.assert_allclose(md.transform_inverse(T[0, -1]) @ T[0, -1], np.eye(4), rtol=0, atol=tol)
    # the bottom row is exactly [0, 0, 0, 1]
    assert np.array_equal(Ti[..., 3, :], np.broadcast_to([0.0, 0.0, 0.0, 1.0], Ti[..., 3, :].shape))
    # and it agrees with the reference's element-by-element eq. 2.2
    assert_rounding_close(Ti[0, -1], ref.transform_inverse(T[0, -1]), "eq. 2.2")
