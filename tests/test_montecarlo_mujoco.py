"""Monte-Carlo studies in MuJoCo (issue 40, item 3): ``study(..., simulator="mujoco")`` and
``manipdyn montecarlo ... --simulator mujoco``.

The bound, as tests/test_mujoco_track.py has it for ``track``: the drawn plant becomes an arm with an
MJCF (the same draws from the same seed), and MuJoCo's run and manipdyn's use the same scheme (the
torque held over each period, the same RK4 steps per period, the same start).  They differ only in how
each evaluates the dynamics (about 1e-13), so each run's tracking error must agree with manipdyn's
far better than that run's own RK4 error, estimated by step halving.  Measured on
``montecarlo ur5 --simulator mujoco --runs 20`` (100 runs, 2 s): the two simulators' RMS errors
differ by at most 6e-8 rad, at most 1e-6 of the step-halving difference (median 7e-14); three LQR runs
diverge in both.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.control import montecarlo as mc
from manipdyn.control.montecarlo.plant import plant_arm
from manipdyn.control.simulate import SimulationDiverged, simulate

from common import err_line

mujoco = pytest.importorskip("mujoco", reason="MuJoCo is not installed: montecarlo --simulator mujoco is not tested")

KW = dict(runs=3, seed=4, duration=0.5, controllers=("pd", "ct", "adaptive"))


@pytest.fixture(scope="module")
def studies():
    arm = md.load("ur5")
    own, mj = mc.study(arm, **KW), mc.study(arm, simulator="mujoco", **KW)
    return own, mj, mc.run(own, scheduler="sync"), mc.run(mj, scheduler="sync", chunk_size=1)


def test_the_same_seed_draws_the_same_plants_and_the_plant_arm_is_that_plant(studies):
    own, mj, _, _ = studies
    rng = np.random.default_rng(0)
    q, qd, tau = rng.normal(size=(3, 8, 6))
    for run in range(own.runs):
        a, b = own.draw(run), mj.draw(run)
        assert all(np.array_equal(getattr(a, f), getattr(b, f))
                   for f in ("scale", "friction", "q0_offset", "payload_com"))
        plant = mj.plant(run)
        arm = plant_arm(mj.arm, plant)
        ref = plant.forward_dynamics(q, qd, tau)
        # the same plant: Pinocchio on the changed model against the arm rebuilt from its parameters,
        # measured 4.5e-13 of the largest acceleration (rounding through the parameter round trip)
        assert np.abs(arm.forward_dynamics(q, qd, tau) - ref).max() <= 1e-10 * np.abs(ref).max()
        # ... and MuJoCo on its MJCF (its engine: the friction law added as manipdyn's, constraints off)
        assert np.abs(arm.engine("mujoco").forward_dynamics(q, qd, tau) - ref).max() <= 1e-9 * np.abs(ref).max()


def test_each_run_in_mujoco_tracks_as_manipdyns_run_within_the_integrators_difference(studies):
    own, mj, r_own, r_mj = studies
    assert [(r["run"], r["controller"]) for r in r_own.per_run] == [(r["run"], r["controller"]) for r in r_mj.per_run]
    for a, b in zip(r_own.per_run, r_mj.per_run):
        assert a["diverged"] == b["diverged"] and a["substeps"] == b["substeps"]
        setup = own.setup(a["run"], a["controller"])
        kw = setup.simulate_kwargs()
        kw["substeps"] = 2 * setup.substeps
        half = simulate(**kw)
        e = half.e
        integrator = abs(a["rms_error"] - float(np.sqrt(np.mean(np.einsum("ij,ij->i", e, e)))))
        # a real RK4 error (measured 3.4e-5 to 3.0e-3 rad here: one step per period, sharp Coulomb sign),
        # against the simulators' difference, measured at most 9e-16 rad here
        assert 0 < integrator
        assert abs(a["rms_error"] - b["rms_error"]) <= integrator, (a, b, integrator)
        assert abs(a["max_error"] - b["max_error"]) <= 1e-6 * a["max_error"]


def test_the_report_keeps_its_form_and_a_run_replays_bit_for_bit(studies):
    own, mj, r_own, r_mj = studies
    d_own, d_mj = r_own.to_dict(), r_mj.to_dict()
    assert d_mj["study"].pop("simulator") == "mujoco" and d_mj["study"].pop("mujoco_plant") == "model"
    assert d_own["study"].pop("simulator") == "manipdyn"
    assert set(d_own) == set(d_mj) and d_own["study"] == d_mj["study"]
    assert d_own["controllers"].keys() == d_mj["controllers"].keys()
    assert "MuJoCo stepping each plant's MJCF (model plant)" in str(r_mj).splitlines()[0]
    rec = next(r for r in r_mj.per_run if r["run"] == 1 and r["controller"] == "ct")
    log = mj.replay(1, "ct")                                   # MuJoCo again, alone
    e = log.e
    assert float(np.sqrt(np.mean(np.einsum("ij,ij->i", e, e)))) == rec["rms_error"]
    assert log.plant.endswith("(MuJoCo)")


def test_chunking_does_not_change_a_mujoco_study(studies):
    # the Dask path runs the same pure function on chunks (tests/test_montecarlo.py runs it on a cluster);
    # in MuJoCo too, a run's numbers do not depend on the chunk it ran in
    _, mj, _, r_mj = studies
    other = mc.run(mj, scheduler="sync", chunk_size=3)
    assert json.dumps(other.per_run) == json.dumps(r_mj.per_run)


def test_a_run_that_mujoco_resets_is_diverged_not_continued():
    arm = md.load("ur5")
    s = mc.study(arm, runs=1, seed=0, duration=0.3, controllers=("pd",), simulator="mujoco")
    setup = s.setup(0, "pd")
    kw = setup.simulate_kwargs()

    def wild(t, q, qd):                     # a torque MuJoCo's accelerations overflow on
        return np.full(6, 1e300)
    kw["controller"] = wild
    kw.pop("trajectory")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(SimulationDiverged, match="MuJoCo met a non-finite or huge control"):
            simulate(trajectory=setup.trajectory, **kw)


def test_cli_montecarlo_in_mujoco(capsys):
    argv = ["montecarlo", "ur5", "--runs", "2", "--duration", "0.3", "--controllers", "pd,ct", "--scheduler", "sync",
            "--no-progress"]
    assert main(argv + ["--simulator", "mujoco", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["study"]["simulator"] == "mujoco" and len(doc["per_run"]) == 4
    assert main(argv + ["--mujoco-plant", "file"]) == 2
    assert err_line(capsys).endswith("--mujoco-plant: only with --simulator mujoco")


def test_a_mujoco_study_on_a_dask_cluster_is_bit_identical_to_a_local_run(capsys):
    pytest.importorskip("distributed", reason="Dask is not installed: the cluster path is not tested")
    from dask_cluster import dask_cluster

    argv = ["montecarlo", "ur5", "--runs", "4", "--seed", "2", "--duration", "0.3", "--controllers", "pd,ct",
            "--simulator", "mujoco", "--json", "--no-progress"]
    assert main(argv + ["--scheduler", "sync"]) == 0
    local = json.loads(capsys.readouterr().out)
    with dask_cluster(2) as (address, _):
        assert main(argv + ["--scheduler", address, "--chunk-size", "1"]) == 0
        remote = json.loads(capsys.readouterr().out)
    local.pop("timing"), remote.pop("timing")
    assert json.dumps(remote) == json.dumps(local) and remote["study"]["simulator"] == "mujoco"


def test_plants_drawn_from_an_identification_become_arms_with_their_drawn_rotors_and_friction(tmp_path):
    pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
    from manipdyn.identification import excitation, fit
    from manipdyn.identification.experiments.demo import true_arm
    from manipdyn.identification.results.basemodel import prior_text, write_base_model

    prior = md.load("ur5")
    truth = true_arm(prior, seed=1)
    ex = excitation(prior, duration=6.0, harmonics=3, rate=100.0, iterations=0)
    tau = truth.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.01 * np.abs(tau).max(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)
    r = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="wls", friction=True, armature=True)
    path = tmp_path / "wls.base.json"
    write_base_model(path, r, prior_text(prior), {"method": "wls"})
    s = mc.study(prior, runs=2, seed=3, duration=0.3, controllers=("ct",), plants=str(path), simulator="mujoco")
    rng = np.random.default_rng(1)
    q, qd, tau = rng.normal(size=(3, 6, 6))
    for run in range(2):
        plant = s.plant(run)
        arm = plant_arm(s.arm, plant)
        assert not np.array_equal(plant.pinocchio.model.armature, prior.pinocchio.model.armature)   # drawn rotors
        ref = plant.forward_dynamics(q, qd, tau)
        assert np.abs(arm.forward_dynamics(q, qd, tau) - ref).max() <= 1e-10 * np.abs(ref).max()
    report = mc.run(s, scheduler="sync")
    own = mc.run(mc.study(prior, runs=2, seed=3, duration=0.3, controllers=("ct",), plants=str(path)),
                 scheduler="sync")
    for a, b in zip(own.per_run, report.per_run):
        # measured 0 and 4e-15 relative; 1e-9 is the bound on the forward dynamics' own agreement above
        assert abs(a["rms_error"] - b["rms_error"]) <= 1e-9 * a["rms_error"]
