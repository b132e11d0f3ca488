"""The time-varying LQR tracking controller (manipdyn.control.LQR, issue 18 part 6).

* its Riccati pieces: the DARE solver against the plain recursion and the
  default weights against the double integrator they are designed on;
* it tracks the demo path on the nominal arm, far better than PD;
* it runs in a Monte-Carlo study, replays bit for bit, does not depend on the
  chunking, nor on where the runs ran (a real Dask cluster);
* bad options are refused by name, in the API and on the command line.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn import montecarlo as mc
from manipdyn.cli import main
from manipdyn.control import LQR, Quintic, lqr_weights, simulate, solve_dare
from manipdyn.control.demo import demo_path, make_controller


@pytest.fixture(scope="module")
def puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load("puma560")


# -- the Riccati pieces ------------------------------------------------------------------
def test_dare_is_the_fixed_point_of_the_riccati_recursion():
    rng = np.random.default_rng(0)
    A = np.eye(4) + 0.05 * rng.standard_normal((4, 4))      # a little unstable: not a trivial pair
    B = rng.standard_normal((4, 2))
    Q, R = np.diag([1.0, 2.0, 0.5, 0.1]), np.diag([0.3, 1.0])
    P = solve_dare(A, B, Q, R)
    resid = A.T @ P @ A - A.T @ P @ B @ np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A) + Q - P
    # the residual of a converged float64 solution: rounding of a few products of P (~10 to 100)
    assert np.abs(resid).max() <= 1e-9 * np.abs(P).max()
    X = Q.copy()
    for _ in range(5000):                                    # the plain recursion, to its fixed point
        X = A.T @ X @ A - A.T @ X @ B @ np.linalg.solve(R + B.T @ X @ B, B.T @ X @ A) + Q
    np.testing.assert_allclose(P, X, rtol=1e-9)
    K = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
    assert np.abs(np.linalg.eigvals(A - B @ K)).max() < 1.0   # stabilising
    with pytest.raises(ValueError, match="A, B: the discrete Riccati"):
        solve_dare(np.diag([2.0, 0.5]), np.array([[0.0], [1.0]]), np.eye(2), np.eye(1))   # mode 2 unreachable


def test_default_weights_give_a_joint_alone_the_demo_gains():
    """lqr_weights' claim: on a double integrator D_ii qdd = u, Kp = wn^2 D_ii and Kd = 2 wn D_ii."""
    m, wn, dt = 2.5, 10.0, 1e-4
    A = np.array([[1.0, dt], [0.0, 1.0]])
    B = np.array([[dt * dt / 2 / m], [dt / m]])                # exact zero-order hold
    P = solve_dare(A, B, np.diag([wn**4, 2 * wn**2]), np.array([[1 / m**2]]))
    R = np.array([[1 / m**2]])
    K = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)[0]
    # the discrete optimum tends to the continuous one as wn dt -> 0; at wn dt = 1e-3
    # the difference is of that order
    np.testing.assert_allclose(K, [wn**2 * m, 2 * wn * m], rtol=5e-3)


# -- tracking -----------------------------------------------------------------------------
def test_lqr_tracks_the_demo_path_on_the_nominal_arm(puma):
    path = demo_path(puma, 3.0)
    lqr = make_controller("lqr", puma, path=path, dt=1e-3)
    assert lqr.K.shape == (3001, 6, 12) and lqr.tau_ref.shape == (3001, 6)
    logs = {k: simulate(puma, c, path, 3.0) for k, c in
            (("lqr", lqr), ("pd", make_controller("pd", puma)), ("ct", make_controller("ct", puma)))}
    rms = {k: float(np.linalg.norm(log.rms_error())) for k, log in logs.items()}
    # PD at 10 rad/s lags the path by ~0.1 rad; the LQR, with the exact model as feed-forward
    # and its gains along the path, only by what the torque held over each 1 ms step costs
    # (computed torque's ~1e-4 rad): three orders of magnitude, asserted as two
    assert rms["lqr"] < rms["pd"] / 100
    assert rms["lqr"] < 3 * rms["ct"]
    assert logs["lqr"].max_error().max() < 1e-3
    # the feed-forward is the model's inverse dynamics of the reference
    t = lqr.t_grid[::500]
    q, qd, qdd = path(t)
    np.testing.assert_allclose(lqr.tau_ref[::500], puma.inverse_dynamics(q, qd, qdd), rtol=1e-12, atol=1e-9)


def test_lqr_rejects_an_initial_offset_and_holds_the_end(puma):
    path = Quintic(np.zeros(6), np.full(6, 0.3), duration=1.0)
    log = simulate(puma, LQR(puma, dt=1e-3), path, 2.0, q0=np.full(6, 0.05))
    assert np.abs(log.e[0]).max() == pytest.approx(0.05)
    # an error of 0.05 rad at a 10 rad/s bandwidth decays within ~0.6 s; after the path
    # ends (t = 1 s) the terminal DARE gain holds the arm at the end point
    assert np.abs(log.e[log.t >= 1.0]).max() < 1e-3
    assert np.abs(log.e[-1]).max() < 1e-4


def test_gains_are_computed_once_per_reference(puma):
    path = demo_path(puma, 1.0)
    c = LQR(puma, trajectory=path)
    K = c.K
    c.reset(path)                              # the same reference: nothing recomputed
    assert c.K is K
    c.reset(demo_path(puma, 1.0))              # a new one: recomputed, to the same numbers
    assert c.K is not K
    np.testing.assert_array_equal(c.K, K)
    assert c.gain(-1.0) is c._Klist[0] and c.gain(0.0005) is c._Klist[0]
    assert c.gain(0.001) is c._Klist[1] and c.gain(99.0) is c._Klist[-1]


# -- Monte-Carlo -------------------------------------------------------------------------
def _replays_match(report):
    s = report.study
    for rec in report.per_run:
        assert not rec["diverged"], rec
        log = s.replay(rec["run"], rec["controller"])
        e = log.e
        assert rec["rms_error"] == float(np.sqrt(np.mean(np.einsum("ij,ij->i", e, e)))), rec
        assert rec["max_error"] == float(np.abs(e).max()), rec
        assert rec["peak_torque"] == float(np.abs(log.tau).max()), rec


def _without_timing(text):
    doc = json.loads(text)
    doc.pop("timing")
    return doc


def test_lqr_in_a_monte_carlo_study_replays_bit_for_bit(puma):
    s = mc.study(puma, runs=4, seed=2, duration=1.0, controllers=("ct", "lqr"))
    report = mc.run(s, scheduler="sync", chunk_size=4)
    _replays_match(report)
    other = mc.run(s, scheduler="sync", chunk_size=1)
    assert _without_timing(other.to_json()) == _without_timing(report.to_json())
    assert "lqr" in mc.CONTROLLER_KEYS and mc.study(puma, runs=1).controllers == mc.CONTROLLER_KEYS
    # the gains come from the nominal arm, the path and dt: not from a run's plant
    np.testing.assert_array_equal(s.controller("lqr").K, LQR(puma, dt=s.dt, trajectory=s.path()).K)
    assert report.controllers["lqr"]["diverged"] == 0


def test_lqr_study_on_a_dask_cluster_is_bit_identical(capsys):
    pytest.importorskip("distributed", reason="the scale extra (dask[distributed]) is not installed")
    from dask_cluster import dask_cluster

    argv = ["montecarlo", "puma560", "--runs", "6", "--seed", "7", "--duration", "0.5",
            "--controllers", "LQR", "--json", "--no-progress"]
    assert main(argv + ["--scheduler", "sync"]) == 0
    local = capsys.readouterr().out
    with dask_cluster(2) as (address, _):
        assert main(argv + ["--scheduler", address, "--chunk-size", "2"]) == 0
        remote = capsys.readouterr().out
    assert _without_timing(remote) == _without_timing(local)
    assert json.loads(local)["controllers"]["lqr"]["diverged"] == 0


# -- bad options ---------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, match", [
    ({"Q": -1.0}, "Q: must be positive semi-definite"),
    ({"Q": np.ones(5)}, r"Q: expected a scalar, shape \(12,\)"),
    ({"Q": [[1.0, 2.0], [3.0, 4.0]]}, r"Q: expected a scalar, shape \(12,\)"),
    ({"R": 0.0}, "R: must be positive definite"),
    ({"R": np.full(6, np.nan)}, "R: must be finite"),
    ({"R": "x"}, "R: expected a number"),
    ({"dt": 0.0}, "dt: expected a positive finite controller period"),
    ({"dt": float("inf")}, "dt: expected a positive finite"),
    ({"wn": -1.0}, "wn: expected a positive finite bandwidth"),
])
def test_bad_options_are_named(puma, kwargs, match):
    with pytest.raises(ValueError, match=match):
        LQR(puma, **kwargs)


def test_a_reference_without_a_span_is_refused(puma):
    def ref(t):
        return np.zeros(6), np.zeros(6), np.zeros(6)
    c = LQR(puma)
    with pytest.raises(ValueError, match="trajectory: LQR needs a reference with a finite span"):
        c.reset(ref)
    with pytest.raises(ValueError, match="LQR: no trajectory"):
        c.gain(0.0)


def test_cli_track_and_montecarlo_accept_lqr_in_any_case(capsys):
    assert main(["track", "puma560", "--controller", "LQR", "--duration", "1", "--json", "--no-progress"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["controllers"]["LQR"]["diverged"] is False
    assert max(doc["controllers"]["LQR"]["max_error"]) < 1e-3
    with pytest.raises(SystemExit) as info:                 # argparse's own usage error
        main(["track", "puma560", "--controller", "lqq"])
    assert info.value.code == 2
    assert "--controller" in capsys.readouterr().err
    assert main(["montecarlo", "puma560", "--runs", "1", "--scheduler", "sync", "--controllers", "ct,lqq",
                 "--duration", "0.1"]) == 2
    err = capsys.readouterr().err
    assert "--controllers" in err and "pd,pdg,ct,adaptive,lqr" in err
