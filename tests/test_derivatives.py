"""Derivatives of the dynamics (issue 18): both engines against a finite-difference referee,
against each other, and against the identities every arm obeys.

Arms: the bundled models, seeded random arms (``tests/arms.py``: 1 to 8 joints,
standard or modified DH, revolute and prismatic, optional rotors, gravity in a
random direction) and random arms given viscous and Coulomb friction.

Tolerances (each test says which it uses):

* ROUNDING = 1e-12 relative to ``max(1, |x|)``: two computations of the same
  exact quantity in float64 (as in ``tests/test_identities.py``).
* AGREE = 1e-9: the cross-check's own tolerance (``manipdyn.check.crosscheck.TOLERANCE``).
* The finite-difference referee, FD_TOL: a central difference with step ``h``
  has truncation error ``h^2/6 |f'''|`` and rounding error about ``k eps |f| / h``
  (k ~ 100 operations behind f).  With ``h = 1e-5`` (rad or m; the arms'
  lengths are O(0.1..1) m, so ``|f'''|`` is O(|f|) per unit of q) that is
  ``2e-11 |f| + 2.2e-9 |f|``; 1e-6 relative to ``max(1, |f|, |df|)`` keeps a
  400x margin, while any wrong term (a dropped or transposed contribution) is
  O(1e-2) or more.  Forward dynamics solves with D: its rounding grows with
  cond(D), so its bound is scaled by ``max(1, cond(D) / 100)``.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import manipdyn as md

import arms

ROUNDING = 1e-12
AGREE = 1e-9
FD_STEP = 1e-5
FD_TOL = 1e-6
RANDOM_SEEDS = range(24)


def _friction_arm(seed):
    """A random arm with viscous and Coulomb friction on every joint (and rotors)."""
    arm = arms.random_arm(seed, rotors=True)
    rng = np.random.default_rng([seed, 7])
    links = [dataclasses.replace(link, friction_viscous=float(rng.uniform(0.1, 3.0)),
                                 friction_coulomb=float(rng.uniform(0.1, 2.0))) for link in arm.links]
    return md.Manipulator(links, convention=arm.convention, gravity=arm.gravity, name=f"friction{seed}")


def _state(arm, seed, size=None):
    q, qd, qdd = arms.random_state(np.random.default_rng([seed, 1]), arm, size=size)
    return q, qd, qdd


def _central(f, x, h=FD_STEP):
    """Central differences of f at x, column m = df/dx_m."""
    cols = []
    for m in range(len(x)):
        e = np.zeros_like(x)
        e[m] = h
        cols.append((f(x + e) - f(x - e)) / (2 * h))
    return np.stack(cols, axis=-1)


def _rel(a, b, scale=None):
    scale = max(1.0, float(np.abs(b).max()) if scale is None else scale)
    return float(np.abs(np.asarray(a) - np.asarray(b)).max()) / scale


def _random_arms():
    return [arms.random_arm(s) for s in RANDOM_SEEDS] + [_friction_arm(s) for s in range(6)]


ENGINES = ("lagrange", "pinocchio")


# -- the referee: central finite differences --------------------------------------------------

@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("seed", range(12))
def test_derivatives_match_central_differences(engine, seed):
    arm = _friction_arm(seed) if seed % 3 == 0 else arms.random_arm(seed)
    E = arm.engine(engine)
    q, qd, qdd = _state(arm, seed)
    qd = np.where(np.abs(qd) < 10 * FD_STEP, 0.5, qd)       # off the Coulomb kink
    tau = E.inverse_dynamics(q, qd, qdd)
    scale = max(float(np.abs(tau).max()), 1.0)
    dq, dqd = E.inverse_dynamics_derivatives(q, qd, qdd)
    for what, got, fd in (
            ("dtau_dq", dq, _central(lambda x: E.inverse_dynamics(x, qd, qdd), q)),
            ("dtau_dqd", dqd, _central(lambda x: E.inverse_dynamics(q, x, qdd), qd)),
            ("dg_dq", E.gravity_derivative(q), _central(E.gravity_torque, q))):
        assert _rel(got, fd, max(scale, np.abs(fd).max())) <= FD_TOL, (what, arm.name)
    D = E.mass_matrix(q)
    cond = float(np.linalg.cond(D))
    a, b, c = E.forward_dynamics_derivatives(q, qd, tau)
    tol = FD_TOL * max(1.0, cond / 100)
    for what, got, fd in (
            ("dqdd_dq", a, _central(lambda x: E.forward_dynamics(x, qd, tau), q)),
            ("dqdd_dqd", b, _central(lambda x: E.forward_dynamics(q, x, tau), qd)),
            ("dqdd_dtau", c, _central(lambda x: E.forward_dynamics(q, qd, x), tau))):
        assert _rel(got, fd, max(1.0, float(np.abs(fd).max()))) <= tol, (what, arm.name, cond)


def test_mass_matrix_derivative_matches_central_differences():
    for seed in range(8):
        arm = arms.random_arm(seed)
        q, _, _ = _state(arm, seed)
        dD = arm.lagrange.mass_matrix_derivative(q)
        fd = _central(arm.lagrange.mass_matrix, q)
        assert _rel(dD, fd, max(1.0, float(np.abs(fd).max()))) <= FD_TOL, arm.name


# -- the two engines agree --------------------------------------------------------------------

@pytest.mark.parametrize("name", md.models())
def test_bundled_arms_agree_through_crosscheck(name):
    with warnings.catch_warnings():   # the bundled Pumas and Stanford carry known inertia notes
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        arm = md.load(name)
    report = md.crosscheck(arm, samples=100, seed=3)
    for key in ("dtau_dq", "dtau_dqd", "dqdd_dq", "dqdd_dqd", "dg_dq"):
        assert report[key].ok, (key, report[key].max_rel)


def test_random_arms_agree_single_and_batch():
    for arm in _random_arms():
        L, P = arm.lagrange, arm.pinocchio
        q, qd, qdd = _state(arm, 5, size=7)
        tau = L.inverse_dynamics(q, qd, qdd)
        batch = {"inv": (L.inverse_dynamics_derivatives(q, qd, qdd), P.inverse_dynamics_derivatives(q, qd, qdd)),
                 "fwd": (L.forward_dynamics_derivatives(q, qd, tau), P.forward_dynamics_derivatives(q, qd, tau)),
                 "g": ((L.gravity_derivative(q),), (P.gravity_derivative(q),)),
                 "F": ((L.friction_derivative(qd),), (P.friction_derivative(qd),))}
        for key, (ls, ps) in batch.items():
            for k, (l, p) in enumerate(zip(ls, ps)):
                assert l.shape == p.shape == (7, arm.n, arm.n)
                for i in range(7):
                    assert _rel(p[i], l[i]) <= AGREE, (arm.name, key, k, i)
        # a single state is row i of the batch
        for E in (L, P):
            one = E.inverse_dynamics_derivatives(q[2], qd[2], qdd[2])
            two = E.forward_dynamics_derivatives(q[2], qd[2], tau[2])
            for x, X in zip(one + two + (E.gravity_derivative(q[2]),),
                            E.inverse_dynamics_derivatives(q, qd, qdd) + E.forward_dynamics_derivatives(q, qd, tau)
                            + (E.gravity_derivative(q),)):
                assert x.shape == (arm.n, arm.n)
                assert _rel(x, X[2]) <= ROUNDING, (arm.name, E.name)


# -- identities ------------------------------------------------------------------------------

@pytest.mark.parametrize("engine", ENGINES)
def test_identities_on_random_arms(engine):
    for arm in _random_arms():
        E = arm.engine(engine)
        n = arm.n
        q, qd, qdd = _state(arm, 11)
        D = E.mass_matrix(q)
        tau = E.inverse_dynamics(q, qd, qdd)
        dq, dqd = E.inverse_dynamics_derivatives(q, qd, qdd)
        a, b, c = E.forward_dynamics_derivatives(q, qd, tau)
        G = E.gravity_derivative(q)
        C = E.coriolis_matrix(q, qd)
        F = E.friction_derivative(qd)
        cond = float(np.linalg.cond(D))
        # dqdd/dtau = D^-1, i.e. dtau/dqdd = D (rounding grows with cond(D) in the solve)
        assert _rel(c @ D, np.eye(n)) <= ROUNDING * max(1.0, cond), arm.name
        # implicit function theorem: D dqdd/dq = -dtau/dq, D dqdd/dqd = -dtau/dqd
        assert _rel(D @ a, -dq, max(1.0, float(np.abs(dq).max()))) <= ROUNDING * max(1.0, cond), arm.name
        assert _rel(D @ b, -dqd, max(1.0, float(np.abs(dqd).max()))) <= ROUNDING * max(1.0, cond), arm.name
        # gravity is the gradient of a potential: its Jacobian is symmetric
        assert _rel(G, G.T) <= ROUNDING, arm.name
        # dtau/dqd = 2 C + dF/dqd (Christoffel C: D_ijk = D_ikj)
        assert _rel(dqd, 2 * C + F) <= ROUNDING, arm.name
        # dD/dq through the public API: d(D e_j)/dq = dtau_dq(q, 0, e_j) - dg/dq, so
        # Ddot = sum_k dD/dq_k qd_k column by column; Ddot - 2C is skew-symmetric
        zero = np.zeros(n)
        Ddot = np.stack([(E.inverse_dynamics_derivatives(q, zero, np.eye(n)[j])[0] - G) @ qd
                         for j in range(n)], axis=1)
        N = Ddot - 2 * C
        assert _rel(N, -N.T, max(1.0, float(np.abs(Ddot).max()))) <= ROUNDING, arm.name
        # dtau/dq is linear in qdd: its qdd part is (dD/dq) qdd
        lin = sum(qdd[j] * (E.inverse_dynamics_derivatives(q, zero, np.eye(n)[j])[0] - G) for j in range(n))
        h_part = E.inverse_dynamics_derivatives(q, qd, zero)[0] - G
        assert _rel(dq, G + h_part + lin, max(1.0, float(np.abs(dq).max()))) <= ROUNDING, arm.name


def test_ddot_from_the_christoffel_symbols_matches():
    """The trace form's own dD/dq (second derivatives Delta_j Delta_k T_p) gives the same Ddot."""
    for arm in _random_arms():
        L = arm.lagrange
        q, qd, _ = _state(arm, 13)
        Ddot = L.mass_matrix_derivative(q) @ qd
        N = Ddot - 2 * L.coriolis_matrix(q, qd)
        assert _rel(N, -N.T, max(1.0, float(np.abs(Ddot).max()))) <= ROUNDING, arm.name
        zero = np.zeros(arm.n)
        G = L.gravity_derivative(q)
        col = np.stack([(L.inverse_dynamics_derivatives(q, zero, np.eye(arm.n)[j])[0] - G) @ qd
                        for j in range(arm.n)], axis=1)
        assert _rel(Ddot, col, max(1.0, float(np.abs(Ddot).max()))) <= ROUNDING, arm.name


# -- friction ----------------------------------------------------------------------------------

@pytest.mark.parametrize("engine", ENGINES)
def test_coulomb_at_rest_contributes_zero(engine):
    """The sharp sign(qd) has no derivative at qd == 0: the documented value is 0 (viscous only)."""
    arm = _friction_arm(2)
    E = arm.engine(engine)
    q, _, qdd = _state(arm, 2)
    qd = np.zeros(arm.n)
    np.testing.assert_array_equal(E.friction_derivative(qd), np.diag(arm.friction[0]))
    _, dqd = E.inverse_dynamics_derivatives(q, qd, qdd)
    assert _rel(dqd, np.diag(arm.friction[0])) <= ROUNDING   # C(q, 0) = 0


def test_friction_derivative_without_friction_is_zero():
    arm = arms.random_arm(1, n=3)
    for E in (arm.lagrange, arm.pinocchio):
        assert E.friction_derivative(np.ones((4, 3))).shape == (4, 3, 3)
        assert not np.any(E.friction_derivative(np.ones(3)))


# -- the boundary ------------------------------------------------------------------------------

@pytest.mark.parametrize("engine", ENGINES)
def test_bad_states_are_named(engine):
    arm = md.load("ur5")
    E = arm.engine(engine)
    q = np.zeros(6)
    with pytest.raises(md.StateError, match="qdd"):
        E.inverse_dynamics_derivatives(q, q, np.zeros(5))
    with pytest.raises(md.StateError, match="tau"):
        E.forward_dynamics_derivatives(q, q, [0, 0, 0, 0, 0, np.nan])
    with pytest.raises(md.StateError, match="q"):
        E.gravity_derivative(np.zeros((2, 7)))
    with pytest.raises(md.StateError, match="qd"):
        E.inverse_dynamics_derivatives(np.zeros((3, 6)), np.zeros((2, 6)), np.zeros((3, 6)))


def test_list_and_big_endian_inputs_give_the_same_answer():
    arm = md.load("panda")
    q, qd, qdd = _state(arm, 4)
    for E in (arm.lagrange, arm.pinocchio):
        ref = E.inverse_dynamics_derivatives(q, qd, qdd)
        for args in ((q.tolist(), qd.tolist(), qdd.tolist()), (q.astype(">f8"), qd.astype(">f8"), qdd.astype(">f8"))):
            for x, r in zip(E.inverse_dynamics_derivatives(*args), ref):
                np.testing.assert_array_equal(x, r)


def test_pinocchio_answers_are_not_views_of_its_data():
    arm = md.load("ur5")
    P = arm.pinocchio
    q, qd, qdd = _state(arm, 6)
    first = P.inverse_dynamics_derivatives(q, qd, qdd)
    kept = [x.copy() for x in first]
    P.inverse_dynamics_derivatives(q + 1, qd, qdd)
    P.forward_dynamics_derivatives(q + 1, qd, qdd)
    for x, k in zip(first, kept):
        np.testing.assert_array_equal(x, k)


def test_singular_mass_matrix_is_named(tmp_path):
    """A joint that moves no mass: forward-dynamics derivatives are undefined, and say so."""
    from test_cli import NOMASS

    path = tmp_path / "nomass.urdf"
    path.write_text(NOMASS)
    with pytest.warns(md.PhysicalConsistencyWarning, match="moves no mass"):
        arm = md.load(str(path))
    for eng in (arm.pinocchio, arm.lagrange):
        for args in ((np.zeros(2), np.zeros(2), np.ones(2)), (np.zeros((3, 2)), np.zeros((3, 2)), np.ones((3, 2)))):
            with pytest.raises(md.SingularMassMatrixError, match=r"joint\(s\) \[2\] move no mass"):
                eng.forward_dynamics_derivatives(*args)
        with pytest.raises(md.SingularMassMatrixError):
            arm.linearize(np.zeros(2), np.zeros(2), np.ones(2), engine=eng.name)


@pytest.mark.parametrize("bad", [np.nan, np.inf, 1e200])
def test_pinocchio_shortcut_refuses_non_finite_and_huge_states(bad):
    """NaN and inf are named (general path); a huge finite state is answered by the general path."""
    arm = md.load("ur5")
    q = np.zeros(6)
    x = q.copy()
    x[3] = bad
    if np.isfinite(bad):
        with pytest.raises(md.StateError, match="dtau|inverse_dynamics_derivatives|overflow|finite"):
            arm.pinocchio.inverse_dynamics_derivatives(q, x, q)
    else:
        with pytest.raises(md.StateError, match="qd"):
            arm.pinocchio.inverse_dynamics_derivatives(q, x, q)
        with pytest.raises(md.StateError, match="q"):
            arm.pinocchio.gravity_derivative(x)


def test_manipdyn_check_reports_the_derivatives(capsys):
    from manipdyn.cli import main

    assert main(["check", "ur5", "--samples", "5", "--timing-calls", "2"]) == 0
    out = capsys.readouterr().out
    for key in ("dtau_dq", "dtau_dqd", "dqdd_dq", "dqdd_dqd", "dg_dq"):
        assert f"\n{key} " in out, key
