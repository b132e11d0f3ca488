"""Monte-Carlo plants drawn from an identification (issue 19, item 2): the draws, the projection,
the plant itself, the command line, and bit-identical studies on a real Dask scheduler."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn import montecarlo as mc
from manipdyn.cli import main

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import excitation, fit  # noqa: E402
from manipdyn.identification.results.basemodel import prior_text, write_base_model  # noqa: E402
from manipdyn.identification.experiments.demo import true_arm  # noqa: E402
from manipdyn.identification.estimation.fitting import link_min_eigenvalues  # noqa: E402
from manipdyn.identification.estimation.model import arm_with_parameters  # noqa: E402

DURATION = 0.5   # s simulated per run: short, the runs are not what is tested here


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """wls and ols base models of a perturbed UR5 (1 % torque noise, friction identified)."""
    prior = md.load("ur5")
    truth = true_arm(prior, seed=1)
    ex = excitation(prior, duration=6.0, harmonics=3, rate=100.0, iterations=0)
    tau = truth.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.01 * np.abs(tau).max(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)
    folder = tmp_path_factory.mktemp("identified")
    paths = {}
    for method in ("wls", "ols"):
        r = fit(prior, ex.q, ex.qd, ex.qdd, tau, method=method, friction=True)
        paths[method] = folder / f"{method}.base.json"
        write_base_model(paths[method], r, prior_text(prior), {"method": method})
        paths[method + "_result"] = r
    return prior, paths


def test_draws_have_the_identified_distribution(identified):
    """Before the projection the draws' base parameters are beta_hat + L z: mean beta_hat and
    covariance C (checked over 2000 draws: the sample covariance's entries have relative
    standard errors ~sqrt(2 / 2000) = 3 % on the diagonal; 15 % is 5 of them)."""
    prior, paths = identified
    plants = mc.load_identified(paths["wls"])
    r = paths["wls_result"]
    K = r.base.K
    draws = np.array([K @ plants.draw_base(3, k)[1] for k in range(2000)])
    std = np.sqrt(np.diag(r.covariance))
    np.testing.assert_allclose(np.mean(draws, axis=0), r.beta, atol=0.1 * std.max(), rtol=0)
    assert np.all(np.abs(np.mean(draws, axis=0) - r.beta) < 5 * std / np.sqrt(2000))
    np.testing.assert_allclose(np.std(draws, axis=0, ddof=1) / std, 1.0, atol=0.15)
    corr = np.corrcoef(draws, rowvar=False)
    expect = r.covariance / np.outer(std, std)
    assert np.max(np.abs(corr - expect)) < 0.15      # correlations kept (+-0.15: ~7 standard errors)
    # seeded per (seed, run) only
    np.testing.assert_array_equal(plants.draw_base(3, 17)[1], plants.draw_base(3, 17)[1])
    assert not np.array_equal(plants.draw_base(3, 17)[1], plants.draw_base(4, 17)[1])


def test_projected_draws_are_physical_and_counted(identified):
    prior, paths = identified
    plants = mc.load_identified(paths["wls"])
    n = prior.n
    moved = 0
    for k in range(30):
        raw = plants.draw_base(0, k)[1]
        pi, m = plants.draw_parameters(0, k)
        assert np.all(link_min_eigenvalues(pi, n) >= 0.5e-8) and np.all(pi[10 * n:] >= 0)
        assert m == (not np.array_equal(pi, raw))
        moved += m
    counts = plants.projected(0, 30)
    assert counts["any"] == moved and counts["inertia"] <= moved and counts["drive"] <= moved
    # this wls identification is not physical itself (J_i of links 2 to 4 have negative
    # eigenvalues), so every draw near it is projected: the report must say so
    assert plants.physical() is False and moved == 30


def test_plant_is_the_arm_with_the_drawn_parameters(identified):
    """The plant (Pinocchio inertias set from pi, friction from pi) has the forward dynamics of the
    DH arm written with those parameters (arm_with_parameters, then a new URDF): two routes,
    rounding only."""
    prior, paths = identified
    plants = mc.load_identified(paths["wls"])
    s = mc.study(prior, runs=3, seed=5, duration=DURATION, plants=plants)
    d = s.distributions
    assert d.payload_mass == d.link_scale == d.friction_viscous == d.friction_coulomb == 0.0
    rng = np.random.default_rng(2)
    for run in range(3):
        plant = s.plant(run)
        pi, _ = plants.draw_parameters(5, run)
        np.testing.assert_array_equal(plant.parameters, pi)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
            ref = arm_with_parameters(prior, pi, friction=True)
        q, qd, tau = prior.random_state(rng), rng.uniform(-1, 1, 6), rng.uniform(-20, 20, 6)
        np.testing.assert_allclose(plant.forward_dynamics(q, qd, tau), ref.forward_dynamics(q, qd, tau),
                                   rtol=1e-9, atol=1e-9)
    assert not np.array_equal(s.plant(0).parameters, s.plant(1).parameters)


def test_errors_name_the_file_and_what_is_missing(identified, tmp_path, capsys):
    prior, paths = identified
    with pytest.raises(md.ModelError, match="no standard deviation.*wls or consistent"):
        mc.load_identified(paths["ols"])
    doc = json.loads(paths["wls"].read_text())
    doc["base_parameters"][0]["expression"] = "link1.m"
    bad = tmp_path / "edited.json"
    bad.write_text(json.dumps(doc))
    with pytest.raises(md.ModelError, match="edited.json.*not the 48 base parameters"):
        mc.load_identified(bad)
    plants = mc.load_identified(paths["wls"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        puma = md.load("puma560")          # 6 revolute joints too, other kinematics
    with pytest.raises(md.ModelError, match="plants: the identification.s prior .* other kinematics"):
        mc.study(puma, runs=2, plants=plants)
    assert main(["montecarlo", "ur5", "--plants-from", str(tmp_path / "missing.json"), "--runs", "2",
                 "--scheduler", "sync"]) == 2
    err = capsys.readouterr().err
    assert "missing.json" in err and len(err.strip().splitlines()) == 1


def test_identified_study_is_bit_identical_here_and_on_a_dask_scheduler(identified, capsys):
    """``manipdyn montecarlo ur5 --plants-from F.json --json`` in this process and on a real
    scheduler with two workers on 127.0.0.1: the same JSON, timing aside; the report names the
    plant source and the projections."""
    pytest.importorskip("distributed", reason="the scale extra (dask[distributed]) is not installed")
    from dask_cluster import dask_cluster

    prior, paths = identified
    args = ["montecarlo", "ur5", "--plants-from", str(paths["wls"]), "--runs", "6", "--duration",
            str(DURATION), "--seed", "4", "--chunk-size", "2", "--json", "--no-progress"]
    assert main(args + ["--scheduler", "sync"]) == 0
    here = json.loads(capsys.readouterr().out)
    with dask_cluster(2) as (address, _):
        assert main(args + ["--scheduler", address]) == 0
        there = json.loads(capsys.readouterr().out)
    assert there["timing"]["workers"] == 2
    here.pop("timing"), there.pop("timing")
    assert json.dumps(here, sort_keys=True) == json.dumps(there, sort_keys=True)
    plants = here["study"]["plants"]
    assert plants["source"] == "identified" and plants["file"] == "wls.base.json"
    assert plants["projected"]["any"] == 6 and plants["identified_parameters_physical"] is False
    assert main(args[:-2] + ["--scheduler", "sync", "--no-progress"]) == 0
    assert "plants: drawn from the identification wls.base.json" in capsys.readouterr().out
