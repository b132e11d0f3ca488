"""Issue 46 item 19: the consistent fit's conic programs are compiled once per structure (cvxpy's DPP),
and the prior weight's pull reaches the armature and friction entries (``extra_scale``).

Before, every fold and candidate of the smoothing choice, the prior-weight choice and the band's refits
re-canonicalized the same program (``Problem.get_problem_data``: 88 of 99 s inside cvxpy on the Panda
log).  Now a second fit of the same structure only puts its numbers into the compiled program."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support.errors import ModelError

cp = pytest.importorskip("cvxpy", reason="the consistent fit needs the identify extra (cvxpy)")
from manipdyn.identification import excitation  # noqa: E402
from manipdyn.identification.estimation import fitting, programs, solvers  # noqa: E402


@pytest.fixture(scope="module")
def ur5_noisy():
    """A UR5 excitation (6 s at 100 Hz) with viscous and Coulomb friction and 0.05 N m of torque noise."""
    arm = md.load("ur5")
    ex = excitation(arm, duration=6.0, harmonics=3, rate=100.0, iterations=0, seed=3)
    rng = np.random.default_rng(0)
    tau = (arm.inverse_dynamics(ex.q, ex.qd, ex.qdd) + 0.4 * np.tanh(ex.qd / 0.05) + 0.3 * ex.qd
           + 0.05 * rng.standard_normal(ex.q.shape))
    return arm, ex.q, ex.qd, ex.qdd, tau


def _fit(data, start=0, **kw):
    arm, q, qd, qdd, tau = data
    s = slice(start, None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fitting.fit(arm, q[s], qd[s], qdd[s], tau[s], method="consistent", friction=True,
                           complete=False, **kw)


def _compilations(monkeypatch):
    """A list that grows by one at every canonicalization of a problem (cvxpy's reduction chain applied)."""
    from cvxpy.reductions.chain import Chain

    calls, real = [], Chain.apply

    def counting(self, *a, **k):
        calls.append(type(self).__name__)
        return real(self, *a, **k)

    monkeypatch.setattr(Chain, "apply", counting)
    return calls


def test_a_second_fit_of_the_same_structure_is_not_canonicalized_again(ur5_noisy, monkeypatch):
    programs.clear_cache()
    calls = _compilations(monkeypatch)
    first = _fit(ur5_noisy)
    assert calls, "the first fit compiles its programs"
    assert programs.cache_info()["compiles"] >= 1
    del calls[:]
    hits = programs.cache_info()["hits"]
    second = _fit(ur5_noisy, start=60)            # other data (a fold's), the same structure
    assert calls == []                            # before: one canonicalization per solve, 3 to 5 per fit
    assert programs.cache_info()["hits"] > hits
    assert not np.allclose(first.beta, second.beta)    # the new numbers were used, not the old answer


def test_the_cached_programs_give_the_fit_of_the_programs_built_afresh(ur5_noisy):
    """The same fit through the compiled programs and through programs built from the numbers (the path
    before the cache).  A prior weight makes the answer unique and well determined in every direction
    (strictly convex), so the two agree to the solvers' accuracy: 1e-6 of the largest parameter leaves a
    margin over the ~1e-7 measured.  Without a weight, step 1 minimises the residual's norm, flat in the
    weakly excited directions, and the two programs (the same problem, scaled differently for DPP) stop at
    different points of that flat bottom: the torques differ by 3.4e-6 of their scale (measured; the plain
    program alone moves by 1e-12 when the data move by 1e-12, so this is the scaling, not noise), and the
    cached answer's residual is no larger (it was 9e-8 smaller): both are the optimum to the solver's
    accuracy.  So: the residual no more than 1e-8 above, the torques within 1e-5 of their scale."""
    arm, q, qd, qdd, tau = ur5_noisy
    for kw in ({"prior_weight": 0.01}, {}):
        programs.clear_cache()
        cached = _fit(ur5_noisy, **kw)
        info = programs.cache_info()
        assert info["uncached"] == 0 and info["hits"] + info["compiles"] >= 3
        with programs.uncached():
            plain = _fit(ur5_noisy, **kw)
        assert programs.cache_info()["uncached"] >= 3
        t1, t2 = cached.predict(q, qd, qdd), plain.predict(q, qd, qdd)
        if kw:
            # with a prior weight the radius-of-gyration floor gives way to the pull (sdp.consistent_fit), so the
            # bodies thin where the data and the pull allow and the exponential cones of the log-det are solved
            # to ~1e-8 in the objective: the parameters agree to 1.4e-5 of the largest (measured; 1e-7 with the
            # floor), the torques, which the data fix, to 1e-6 of their scale
            scale = np.abs(plain.parameters).max()
            assert np.max(np.abs(cached.parameters - plain.parameters)) < 1e-4 * scale
            assert np.max(np.abs(t1 - t2)) < 1e-6 * np.abs(tau).max()
        else:
            assert cached.report["relative_residual"] <= plain.report["relative_residual"] * (1 + 1e-8)
            assert np.max(np.abs(t1 - t2)) < 1e-5 * np.abs(tau).max()


def test_a_program_cvxpy_finds_not_dpp_is_built_afresh(ur5_noisy, monkeypatch):
    programs.clear_cache()
    monkeypatch.setattr(cp.Problem, "is_dpp", lambda self, *a, **k: False)
    r = _fit(ur5_noisy, prior_weight=0.01)
    info = programs.cache_info()
    assert info["not_dpp"] >= 1 and info["size"] == 0 and r.consistent


def test_scs_alone_still_fits_through_the_compiled_programs(ur5_noisy, monkeypatch):
    """Clarabel absent: step 1 on SCS (the fallback of solvers.solve), steps that need Clarabel skipped."""
    programs.clear_cache()
    monkeypatch.setitem(solvers._INSTALLED, id(cp), frozenset({"SCS"}))
    r = _fit(ur5_noisy, bounds=None)
    assert r.report["solver"].startswith("SCS")
    assert r.consistent and np.all(np.isfinite(r.parameters))


def test_extra_scale_pulls_the_friction_towards_the_prior(ur5_noisy):
    """The data's friction (0.4 N m Coulomb, 0.3 N m s viscous) against a prior with none: with the extras'
    pull, of a scale of 0.01 (N m s, N m), the friction coefficients come out closer to the prior's 0;
    with a huge scale the pull vanishes and the fit is the one without it."""
    from manipdyn.model.parameters import arm_parameters

    arm = ur5_noisy[0]
    n = arm.n
    prior = np.asarray(arm_parameters(arm, False, True))
    free = _fit(ur5_noisy, prior_weight=0.1)
    k = len(free.parameters) - 10 * n
    pulled = _fit(ur5_noisy, prior_weight=0.1, extra_scale=np.full(k, 0.01))
    loose = _fit(ur5_noisy, prior_weight=0.1, extra_scale=np.full(k, 1e6))
    dist = [np.linalg.norm(r.parameters[10 * n:] - prior[10 * n:]) for r in (free, pulled, loose)]
    assert dist[1] < 0.5 * dist[0]                       # pulled: less than half as far from the prior
    assert abs(dist[2] - dist[0]) < 1e-4 * dist[0]       # a 1e6 scale: a pull of 1e-14, none to speak of
    # the pull costs fit: the residual grows
    assert np.sum(pulled.residuals ** 2) > np.sum(free.residuals ** 2)


def test_extra_scale_is_checked(ur5_noisy):
    arm, q, qd, qdd, tau = ur5_noisy
    k = 2 * arm.n
    for bad, words in ((np.ones(k - 1), "shape"), (np.r_[np.ones(k - 1), 0.0], "> 0"),
                       (np.r_[np.ones(k - 1), np.nan], "> 0"), ("abc", "positive numbers")):
        with pytest.raises(ModelError, match="extra_scale") as e:
            _fit(ur5_noisy, prior_weight=0.1, extra_scale=bad)
        assert words in str(e.value)
    with pytest.raises(ModelError, match="extra_scale: only the 'consistent'"):
        fitting.fit(arm, q, qd, qdd, tau, method="wls", friction=True, extra_scale=np.ones(k))


def test_the_fit_modules_keep_their_public_names():
    """fitting.py split by meaning (issue 46 item 30): the least-squares factors in factors.py, the bounds in
    bounds.py; the names other modules import stay importable where they were."""
    from manipdyn.identification.estimation import bounds, factors, sdp
    from manipdyn.identification.estimation.fitting import (FitResult, fit, joint_factors, joint_noise,  # noqa: F401
                                                            known_torque, link_min_eigenvalues, nonnegative_extras)

    assert joint_factors is factors.joint_factors and known_torque is factors.known_torque
    assert sdp.Bounds is bounds.Bounds and sdp.PLAUSIBLE_MASS == bounds.PLAUSIBLE_MASS


def test_blas_threads_limits_scipys_own_blas_loaded_later():
    """SciPy ships its own OpenBLAS, loaded when scipy.linalg is first imported, which the commands do lazily
    inside ``blas_threads(1)``; threadpoolctl limits only the libraries loaded when the limit is set, so SciPy's
    ran two spinning threads (``observe --fit-data`` on the Panda log: 9.3 s of CPU, 2.9 s with it limited).
    Checked in a fresh interpreter, where nothing has imported SciPy yet."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    pytest.importorskip("threadpoolctl", reason="threadpoolctl (identify extra) not installed: no limit to test")
    pytest.importorskip("scipy", reason="SciPy not installed: no second BLAS")
    if (os.cpu_count() or 1) < 2:
        pytest.skip("one core: every BLAS pool has one thread anyway")
    script = ("import sys, threadpoolctl\n"
              "from manipdyn._support.threads import blas_threads\n"
              "assert 'scipy.linalg' not in sys.modules\n"
              "with blas_threads(1):\n"
              "    import scipy.linalg\n"
              "    print(sorted({p['num_threads'] for p in threadpoolctl.threadpool_info() if p['user_api'] == 'blas'}))\n")
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    env.pop("OPENBLAS_NUM_THREADS", None)
    env.pop("OMP_NUM_THREADS", None)
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "[1]"
