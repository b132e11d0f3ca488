"""The fast path's contracts: its shortcuts never change an answer or hide bad input."""

from __future__ import annotations

import os
import signal
import warnings

import numpy as np
import pytest

import manipdyn as md


@pytest.fixture(scope="module")
def arm():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load("puma560")


CALLS = {
    "mass_matrix": (("q",), "q"),
    "coriolis_torque": (("q", "qd"), "qd"),
    "gravity_torque": (("q",), "q"),
    "inverse_dynamics": (("q", "qd", "qdd"), "qdd"),
    "forward_dynamics": (("q", "qd", "tau"), "tau"),
}


@pytest.mark.parametrize("method", sorted(CALLS))
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("where", ["first", "last"])
def test_non_finite_state_names_the_argument(arm, method, bad, where):
    """NaN or inf in any argument, including q_1 (which D and g do not depend on)."""
    names, _ = CALLS[method]
    rng = np.random.default_rng(0)
    for target in names:
        args = {nm: rng.uniform(-1, 1, 6) for nm in names}
        args[target][0 if where == "first" else -1] = bad
        with pytest.raises(ValueError, match=rf"^{target}: entry \d is {bad!r}; states must be finite"):
            getattr(arm, method)(*args.values())


@pytest.mark.parametrize("method", sorted(CALLS))
def test_wrong_shape_names_argument_and_shapes(arm, method):
    names, _ = CALLS[method]
    args = [np.zeros(6) for _ in names]
    args[-1] = np.zeros((6, 1))
    with pytest.raises(ValueError, match=rf"^{names[-1]}: got shape \(6, 1\), expected \(6,\) or \(N, 6\)"):
        getattr(arm, method)(*args)
    args[-1] = np.zeros(5)
    with pytest.raises(ValueError, match=rf"^{names[-1]}: got shape \(5,\), expected"):
        getattr(arm, method)(*args)


@pytest.mark.parametrize("method", sorted(CALLS))
def test_lists_ints_and_batches_give_the_same_numbers(arm, method):
    names, _ = CALLS[method]
    rng = np.random.default_rng(1)
    X = [rng.uniform(-1, 1, (4, 6)) for _ in names]
    f = getattr(arm, method)
    batch = f(*X)
    for i in range(4):
        one = f(*[x[i] for x in X])
        # Pinocchio's parallel ABA and its serial aba round differently (a few
        # ulps, seen 2e-15 relative); every other call is the same code.
        np.testing.assert_allclose(one, batch[i], rtol=1e-13, atol=1e-13)
        np.testing.assert_array_equal(f(*[x[i].tolist() for x in X]), one)
    ints = [np.arange(6) % 2 for _ in names]
    np.testing.assert_array_equal(f(*ints), f(*[i.astype(float) for i in ints]))


def test_results_are_caller_owned(arm):
    q = np.full(6, 0.3)
    tau1 = arm.inverse_dynamics(q, q, q)
    keep = tau1.copy()
    arm.inverse_dynamics(-q, q, q)
    np.testing.assert_array_equal(tau1, keep)
    D1 = arm.mass_matrix(q)
    keep = D1.copy()
    arm.mass_matrix(-q)
    np.testing.assert_array_equal(D1, keep)


def test_arm_methods_are_the_engines(arm):
    """The arm's fast-path methods answer exactly what the Pinocchio engine answers."""
    rng = np.random.default_rng(7)
    args = {1: (arm.random_state(rng),), 2: (arm.random_state(rng), rng.uniform(-1, 1, 6)),
            3: (arm.random_state(rng), rng.uniform(-1, 1, 6), rng.uniform(-1, 1, 6))}
    nargs = {"mass_matrix": 1, "gravity_torque": 1, "coriolis_torque": 2,
             "inverse_dynamics": 3, "forward_dynamics": 3}
    for name in CALLS:
        a = args[nargs[name]]
        assert np.array_equal(getattr(arm, name)(*a), getattr(arm.pinocchio, name)(*a)), name


def test_changing_threads_rebuilds_the_pool(arm):
    eng = arm.pinocchio
    X = np.random.default_rng(2).uniform(-1, 1, (3000, 6))
    old = eng.num_threads
    try:
        eng.num_threads = 1
        a = eng.inverse_dynamics(X, X, X)
        eng.num_threads = 2
        b = eng.inverse_dynamics(X, X, X)
        np.testing.assert_array_equal(a, b)
        with pytest.raises(ValueError, match="num_threads"):
            eng.num_threads = 0
    finally:
        eng.num_threads = old


def test_friction_goes_down_the_general_path():
    links = [md.DHLink(a=0.3, mass=1.0, com=(-0.15, 0, 0), inertia=[0.001, 0.01, 0.01],
                       friction_viscous=0.5, friction_coulomb=0.2) for _ in range(2)]
    arm = md.Manipulator(links, convention="standard")
    q, qd, qdd = np.array([0.1, 0.2]), np.array([1.0, -2.0]), np.array([0.3, 0.4])
    tau = arm.inverse_dynamics(q, qd, qdd)
    expect = arm.lagrange.inverse_dynamics(q, qd, qdd)
    np.testing.assert_allclose(tau, expect, rtol=0, atol=1e-12)
    np.testing.assert_allclose(arm.forward_dynamics(q, qd, tau), qdd, rtol=0, atol=1e-12)


@pytest.mark.parametrize("method", ["kinetic_energy", "coriolis_torque", "inverse_dynamics"])
def test_mixed_single_and_batch_states_name_the_argument(arm, method):
    """One state for q and a batch for the others is a shape error in both engines."""
    args = [np.zeros(6)] + [np.zeros((3, 6))] * (2 if method == "inverse_dynamics" else 1)
    for eng in (arm.pinocchio, arm.lagrange):
        with pytest.raises(ValueError, match=r"^qd: got shape \(3, 6\), expected \(6,\) to match q"):
            getattr(eng, method)(*args)


@pytest.mark.skipif("fork" not in __import__("multiprocessing").get_all_start_methods(),
                    reason="needs the fork start method (POSIX)")
def test_a_forked_child_runs_a_large_batch_after_its_parent_did():
    """GNU OpenMP's pool does not survive fork: before the fix, a child forked after its parent ran
    a parallel batch (>= PARALLEL_MIN_STATES states, several threads) hung in its own batch.  The
    child must answer, with the parent's numbers; it is killed (by its pid) after 60 s."""
    import multiprocessing as mp

    from manipdyn.engines.pinocchio.engine import PARALLEL_MIN_STATES

    arm = md.load("ur5")
    arm.pinocchio.num_threads = 2
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-1, 1, (2 * PARALLEL_MIN_STATES, 6)) for _ in range(3))
    parent = arm.inverse_dynamics(q, qd, qdd)            # starts the pool here

    def child(conn):
        conn.send(arm.inverse_dynamics(q, qd, qdd))
        conn.close()

    ctx = mp.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    p = ctx.Process(target=child, args=(send,), daemon=True)
    p.start()
    try:
        assert recv.poll(60), "the forked child's batch did not return within 60 s"
        np.testing.assert_array_equal(recv.recv(), parent)
    finally:
        if p.is_alive():
            os.kill(p.pid, signal.SIGKILL)
        p.join(10)
