"""The Coriolis matrix C(q, qd) of both engines (issue 6).

``C`` is the Christoffel-form Coriolis matrix: ``C qd = h`` (eq. 2.39) and
``dD/dt - 2C`` is skew-symmetric.  The trace-form engine builds it from the
chapter's ``D_ijk`` (``C_ij = sum_k D_ijk qd_k``, derivation in
:meth:`manipdyn.engines.lagrange.engine.TraceFormEngine.coriolis_matrix`); Pinocchio's comes
from ``pin.computeCoriolisMatrix``.

Claim tested here rather than asserted: the chapter's ``D_ijk`` are the
Christoffel symbols of the first kind of D,
``c_ijk = (dD_ij/dq_k + dD_ik/dq_j - dD_jk/dq_i) / 2``, with the derivatives of
D taken by finite differences of the engine's D (no use of D_ijk), and
``dD_ij/dq_k = D_ijk + D_jik``.

Tolerances:

* ROUNDING = 1e-12 relative to ``max(1, |x|)``, for two floating-point paths to
  the same exact quantity (as in tests/test_identities.py): O(n^3) products of
  O(1..100) numbers, accumulated rounding ~1e-14 of the scale.
* ENGINES = 1e-9 relative, the cross-check's tolerance (manipdyn/check/crosscheck.py), for
  the trace form against Pinocchio.
* Finite differences, central, step e = 1e-5 (rad or m).  S_D = sum over links
  of (m rho^2 + tr I) + armature bounds every |D_ij| (rho >= 1 m, the longest
  lever arm); each q-derivative of D brings a factor <= ~1 (angles) or 1/rho <= 1
  (prismatic), times at most n terms.  Truncation: e^2/6 * n S_D per derivative
  (~1.3e-10 S_D for n = 8); rounding: ~100 eps S_D / e ~ 2.2e-9 S_D (pessimistic:
  measured errors stay below 1e-11 S_D).  The tests allow FD_TOL = 1e-7 S_D per
  derivative, > 40x the estimate; a wrong Christoffel symbol is O(S_D) (the
  plausible wrong candidate dD_ij/dq_k / 2 misses by > 5e-4 S_D on 60 random
  arms).  Derivatives along qd (dD/dt) scale with v = sum |qd_i| (truncation
  with v^3, rounding with v), hence the factor (1 + v)^3.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

import manipdyn as md

import arms
import reference as ref

ROUNDING = 1e-12
ENGINES = 1e-9
FD_STEP = 1e-5
FD_TOL = 1e-7

seeds = st.integers(0, 2**32 - 1)
joint_counts = st.integers(1, 8)
conventions = st.sampled_from(["standard", "modified"])
prismatic_fractions = st.sampled_from([0.0, 0.3, 1.0])


def corners(f):
    """Examples Hypothesis always runs: 1 and 8 joints, both conventions, all prismatic."""
    for n in (1, 8):
        for conv in ("standard", "modified"):
            f = example(seed=n + 100, n=n, convention=conv, pfrac=0.3)(f)
    return example(seed=7, n=4, convention="standard", pfrac=1.0)(f)


def random_case(seed, n, convention, pfrac):
    arm = arms.random_arm(seed, n=n, convention=convention, prismatic_fraction=pfrac)
    q, qd, _ = arms.random_state(np.random.default_rng([seed, 6]), arm)
    return arm, q, qd


def inertia_scale(arm, q) -> float:
    """S_D (module docstring): bounds |D_ij| and, per joint, its q-derivatives."""
    T = ref.link_poses(arm.links, arm.convention, q)
    origins = [Ti[:3, 3] for Ti in T]
    coms = [(T[i] @ np.append(arm.links[i - 1].com, 1.0))[:3] for i in range(1, arm.n + 1)]
    rho = max(1.0, max(np.linalg.norm(o - c) for o in origins for c in coms))
    return sum(l.mass * rho**2 + float(np.trace(l.inertia)) + l.armature for l in arm.links)


def rounding_close(actual, expected, what):
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    assert actual.shape == expected.shape, (what, actual.shape, expected.shape)
    err = np.max(np.abs(actual - expected) / np.maximum(1.0, np.abs(expected)))
    assert err <= ROUNDING, f"{what}: relative error {err:.3g} > {ROUNDING}"


def dD_dq(engine, q) -> np.ndarray:
    """``dD[i, j, k] = dD_ij/dq_k`` by central differences of ``engine.mass_matrix``."""
    n = len(q)
    steps = FD_STEP * np.eye(n)
    Dp = engine.mass_matrix(q + steps)          # batch: row k is q + e e_k
    Dm = engine.mass_matrix(q - steps)
    return np.moveaxis((Dp - Dm) / (2 * FD_STEP), 0, 2)


@pytest.fixture(scope="module")
def bundled():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return {name: md.load(name) for name in ("puma560", "stanford")}


# ---------------------------------------------------------------------------
# The chapter's D_ijk are Christoffel symbols of the first kind
# ---------------------------------------------------------------------------


@corners
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_chapter_Dijk_are_christoffel_symbols(seed, n, convention, pfrac):
    """c_ijk from finite differences of D equals the chapter's D_ijk (plain loops,
    tests/reference.py), which is therefore symmetric in (j, k); and
    dD_ij/dq_k = D_ijk + D_jik.  Tolerance FD_TOL * S_D (module docstring)."""
    arm, q, _ = random_case(seed, n, convention, pfrac)
    Dijk = ref.coriolis_tensor(arm.links, arm.convention, q)
    dD = dD_dq(arm.lagrange, q)
    # c_ijk = (dD_ij/dq_k + dD_ik/dq_j - dD_jk/dq_i) / 2
    christoffel = 0.5 * (dD + np.einsum("ikj->ijk", dD) - np.einsum("jki->ijk", dD))
    tol = FD_TOL * inertia_scale(arm, q)
    np.testing.assert_allclose(Dijk, christoffel, rtol=0, atol=tol)
    np.testing.assert_allclose(dD, Dijk + np.einsum("jik->ijk", Dijk), rtol=0, atol=tol)
    # symmetry in (j, k) of the chapter's sum itself (rounding only)
    rounding_close(Dijk, Dijk.transpose(0, 2, 1), "D_ijk - D_ikj")
    # the engine's batched D_ijk is the same sum
    rounding_close(arm.lagrange.christoffel_symbols(q), Dijk, "christoffel_symbols")


def test_christoffel_symbols_of_bundled_arms(bundled):
    """Puma 560 (rotors, a massless link with inertia) and Stanford (a prismatic
    joint): the batched D_ijk against the plain loops; ROUNDING."""
    rng = np.random.default_rng(3)
    for arm in bundled.values():
        q = arm.random_state(rng)
        rounding_close(arm.lagrange.christoffel_symbols(q),
                       ref.coriolis_tensor(arm.links, arm.convention, q), arm.name)


# ---------------------------------------------------------------------------
# C qd = h and the skew-symmetry of dD/dt - 2C
# ---------------------------------------------------------------------------


@corners
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_C_qd_is_h_and_C_is_christoffel_contraction(seed, n, convention, pfrac):
    """C qd = h for both engines (ROUNDING, relative to sum_j |C_ij qd_j|, the
    size of the terms summed); the trace-form C equals sum_k D_ijk qd_k (ROUNDING)."""
    arm, q, qd = random_case(seed, n, convention, pfrac)
    for eng in (arm.lagrange, arm.pinocchio):
        C = eng.coriolis_matrix(q, qd)
        assert C.shape == (n, n)
        scale = np.maximum(1.0, np.abs(C) @ np.abs(qd))
        h = eng.coriolis_torque(q, qd)
        assert np.all(np.abs(C @ qd - h) <= ROUNDING * scale), eng.name
    C = arm.lagrange.coriolis_matrix(q, qd)
    rounding_close(C, ref.coriolis_tensor(arm.links, arm.convention, q) @ qd, "sum_k D_ijk qd_k")


@corners
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_dD_dt_minus_2C_is_skew_symmetric(seed, n, convention, pfrac):
    """N = dD/dt - 2C with dD/dt = (D(q + e qd) - D(q - e qd)) / 2e (the derivative
    of D along the motion): N + N^T = 0 and x^T N x = 0, both engines.
    Tolerance FD_TOL * S_D * (1 + v)^3, v = sum |qd_i| (module docstring)."""
    arm, q, qd = random_case(seed, n, convention, pfrac)
    x = np.random.default_rng([seed, 7]).standard_normal(n)
    v = float(np.sum(np.abs(qd)))
    tol = FD_TOL * inertia_scale(arm, q) * (1 + v) ** 3
    for eng in (arm.lagrange, arm.pinocchio):
        Dpm = eng.mass_matrix(np.array([q + FD_STEP * qd, q - FD_STEP * qd]))
        Ddot = (Dpm[0] - Dpm[1]) / (2 * FD_STEP)
        N = Ddot - 2 * eng.coriolis_matrix(q, qd)
        np.testing.assert_allclose(N + N.T, 0.0, rtol=0, atol=tol, err_msg=eng.name)
        assert abs(x @ N @ x) <= tol * (x @ x) * n, eng.name


def test_skew_symmetry_bundled(bundled):
    """The same identity on the Puma 560 and the Stanford arm at 20 states each."""
    rng = np.random.default_rng(5)
    for arm in bundled.values():
        for _ in range(20):
            q = arm.random_state(rng)
            qd = rng.uniform(-2, 2, arm.n)
            v = float(np.sum(np.abs(qd)))
            tol = FD_TOL * inertia_scale(arm, q) * (1 + v) ** 3
            for eng in (arm.lagrange, arm.pinocchio):
                Ddot = (eng.mass_matrix(q + FD_STEP * qd) - eng.mass_matrix(q - FD_STEP * qd)) / (2 * FD_STEP)
                N = Ddot - 2 * eng.coriolis_matrix(q, qd)
                np.testing.assert_allclose(N + N.T, 0.0, rtol=0, atol=tol, err_msg=f"{arm.name} {eng.name}")


# ---------------------------------------------------------------------------
# The two engines agree
# ---------------------------------------------------------------------------


@corners
@given(seed=seeds, n=joint_counts, convention=conventions, pfrac=prismatic_fractions)
def test_engines_agree_on_C(seed, n, convention, pfrac):
    """Trace form against Pinocchio, the cross-check's ENGINES tolerance.

    Not a foregone conclusion: C with C qd = h and dD/dt - 2C skew is not unique
    for n >= 3 (add any skew N(q, qd) with N qd = 0).  Pinocchio's
    computeCoriolisMatrix turns out to be the Christoffel one too."""
    arm, _, _ = random_case(seed, n, convention, pfrac)
    q, qd, _ = arms.random_state(np.random.default_rng([seed, 8]), arm, size=5)
    Cl = arm.lagrange.coriolis_matrix(q, qd)
    Cp = arm.pinocchio.coriolis_matrix(q, qd)
    scale = np.maximum(1.0, np.abs(Cl).reshape(5, -1).max(axis=1))[:, None, None]
    assert np.all(np.abs(Cp - Cl) <= ENGINES * scale)


def test_crosscheck_compares_C(bundled):
    for arm in bundled.values():
        report = md.crosscheck(arm, samples=50, seed=2)
        assert "C" in report.quantities
        assert report["C"].ok, report


# ---------------------------------------------------------------------------
# Shapes
# ---------------------------------------------------------------------------


def test_batch_shapes(bundled):
    arm = bundled["puma560"]
    n = arm.n
    rng = np.random.default_rng(9)
    q = arm.random_state(rng, 4)
    qd = rng.uniform(-1, 1, (4, n))
    for eng in (arm.lagrange, arm.pinocchio):
        C = eng.coriolis_matrix(q, qd)
        assert C.shape == (4, n, n)
        assert eng.coriolis_matrix(q[0], qd[0]).shape == (n, n)
        assert eng.coriolis_matrix(q[:1], qd[:1]).shape == (1, n, n)
        for b in range(4):  # the batch is the per-state result
            rounding_close(C[b], eng.coriolis_matrix(q[b], qd[b]), f"{eng.name} batch {b}")
        with pytest.raises(md.StateError, match="qd"):
            eng.coriolis_matrix(q, qd[:3])
        with pytest.raises(md.StateError, match="qd"):
            eng.coriolis_matrix(q[0], np.ones(n + 1))
    assert arm.lagrange.christoffel_symbols(q).shape == (4, n, n, n)
    assert arm.lagrange.christoffel_symbols(q[0]).shape == (n, n, n)
    # the Pinocchio result is a copy: a later call does not change it
    C0 = arm.pinocchio.coriolis_matrix(q[0], qd[0])
    keep = C0.copy()
    arm.pinocchio.coriolis_matrix(q[1], qd[1])
    np.testing.assert_array_equal(C0, keep)
