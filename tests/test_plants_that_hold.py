"""Plants drawn from an identification that stay draws, and runs that say why they diverge
(issue 27, items 4 and 5; issue 25, item 3: ``study(..., plants="id.json")``)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn import montecarlo as mc
from manipdyn.cli import main

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import excitation, fit, write_measurements_csv  # noqa: E402
from manipdyn.identification.results.basemodel import prior_text, write_base_model  # noqa: E402
from manipdyn.identification.experiments.demo import true_arm  # noqa: E402
from manipdyn.identification.estimation.fitting import link_min_eigenvalues  # noqa: E402
from manipdyn.identification.estimation.sdp import EPS, project_physical  # noqa: E402

from common import PANDA_LOG as _PANDA_LOG, PANDA_SKIP  # noqa: E402  (../shared/realdata or $MANIPDYN_REALDATA)

PANDA_LOG = str(_PANDA_LOG)
STILL = mc.Distributions(payload_mass=0, link_scale=0, friction_viscous=0, friction_coulomb=0)


@pytest.fixture(scope="module")
def ur5_wls(tmp_path_factory):
    """A wls base model of a perturbed UR5 (1 % torque noise, friction): not physical itself, so
    every draw near it must be projected."""
    prior = md.load("ur5")
    truth = true_arm(prior, seed=1)
    ex = excitation(prior, duration=6.0, harmonics=3, rate=100.0, iterations=0)
    tau = truth.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.01 * np.abs(tau).max(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)
    r = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="wls", friction=True)
    path = tmp_path_factory.mktemp("plants") / "w.base.json"
    write_base_model(path, r, prior_text(prior), {"method": "wls"})
    return prior, path


def test_projection_is_the_nearest_physical_arm_in_the_covariance_metric(ur5_wls):
    """Each projected draw is physical, and its base parameters are no farther (Mahalanobis, in the
    identification's sigmas) from the Gaussian draw than those of the old Frobenius projection of
    each J_i, which is one physical candidate among those the cone program searches: the optimum
    cannot be worse (1e-6 relative: the solver's accuracy).  Over 20 draws the median largest
    change of one base parameter is less than half the old one's (measured 1.1 against 4.6 sigma)."""
    prior, path = ur5_wls
    plants = mc.load_identified(path)
    K, W, L = (np.array(a) for a in (plants.K, plants.whiten, plants.factor))
    std = np.sqrt(np.einsum("ij,ij->i", L, L))
    old_shift = []
    for k in range(20):
        _, pi0 = plants.draw_base(0, k)
        beta = K @ pi0
        d = plants.draw_details(0, k)
        assert d["moved"] and d["inertia"]
        assert np.all(link_min_eigenvalues(d["pi"], prior.n) >= 0.5 * EPS) and np.all(d["pi"][10 * prior.n:] >= 0)
        np.testing.assert_allclose(d["distance"], np.linalg.norm(W @ (K @ d["pi"] - beta)), rtol=1e-12)
        frob = project_physical(pi0, prior.n, eps=EPS)
        assert d["distance"] <= np.linalg.norm(W @ (K @ frob - beta)) * (1 + 1e-6)
        old_shift.append(np.max(np.abs(K @ frob - beta) / std))
    counts = plants.projected(0, 20)
    assert counts["any"] == 20 and counts["shift_sigma_p50"] < 0.5 * np.median(old_shift)


def test_offsets_are_not_clipped_and_draws_do_not_depend_on_the_order(ur5_wls, tmp_path):
    """A friction offset may be negative (it is not a coefficient >= 0); the projection of a draw is
    the same whichever draws its process solved before (no warm start: a chunked study on Dask
    must get the plants a local one gets)."""
    prior, path = ur5_wls
    plants = mc.load_identified(path)
    assert len(plants.nonnegative) == 2 * prior.n and all(plants.nonnegative)
    first = plants.draw_details(7, 5)["pi"]
    from manipdyn.control.montecarlo import identified

    identified._draw.cache_clear()
    for k in (0, 1, 2):
        plants.draw_details(7, k)
    identified._draw.cache_clear()
    plants.draw_details(7, 4)
    np.testing.assert_array_equal(plants.draw_details(7, 5)["pi"], first)


def test_study_takes_the_base_model_file_as_the_cli_does(ur5_wls):
    """Issue 25, item 3: ``montecarlo.study(..., plants="id.json")`` works where ``--plants-from
    id.json`` does, with the same plants as ``load_identified``."""
    prior, path = ur5_wls
    by_name = mc.study(prior, runs=2, seed=3, duration=0.1, plants=str(path))
    by_path = mc.study(prior, runs=2, seed=3, duration=0.1, plants=path)
    loaded = mc.study(prior, runs=2, seed=3, duration=0.1, plants=mc.load_identified(path))
    assert by_name.plants == loaded.plants == by_path.plants
    np.testing.assert_array_equal(by_name.plant(1).parameters, loaded.plant(1).parameters)
    with pytest.raises(md.ModelError, match="nothere.json"):
        mc.study(prior, runs=2, plants=str(path.parent / "nothere.json"))


def test_a_loop_too_fast_for_its_period_is_caught_and_named():
    """PD tuned to 300 rad/s on the UR5 at 1 kHz: the plant alone needs one RK4 step (the stiffness
    check sees nothing), yet every run diverges.  The sampled-loop check says so before the run:
    dt |eig(D^-1 K_d)| > 2, the cause is the sampled loop, and the figure scales with dt, so the
    report's shorter period (here dt / 4) holds the runs."""
    kw = dict(runs=2, seed=0, controllers=("pd",), bandwidth=300.0, duration=0.3, distributions=STILL)
    rep = mc.run(mc.study("ur5", dt=1e-3, **kw), scheduler="sync")
    fine = mc.run(mc.study("ur5", dt=2.5e-4, **kw), scheduler="sync")
    for r, f in zip(rep.per_run, fine.per_run):
        assert r["substeps"] == 1 and r["diverged"] and r["cause"] == "sampled loop" and r["sampled_loop"] > 2
        np.testing.assert_allclose(f["sampled_loop"], r["sampled_loop"] / 4, rtol=1e-3)
        assert not f["diverged"] and f["cause"] is None and f["sampled_loop"] < 2
    assert rep.controllers["pd"]["diverged_because"] == {"sampled loop": 2}
    text = str(rep)
    assert "sampled loop: 2 of 2 runs" in text and "more RK4 steps would not" in text
    assert "sampled loop" not in str(fine)


def test_identify_bootstrap_prints_its_spread_and_the_base_model_carries_it(tmp_path, capsys):
    """Item 5: ``identify --bootstrap N`` prints each base parameter's bootstrap standard deviation
    in text mode; ``--base-json`` carries them with their covariance, and ``--plants-from`` draws
    from it when the refits outnumber the base parameters (the fit's covariance otherwise, saying
    why: fewer refits leave a singular covariance)."""
    arm = md.load("ur5")
    ex = excitation(arm, duration=4.0, harmonics=3, rate=100.0, iterations=0)
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd) + 0.05 * np.random.default_rng(4).standard_normal(ex.q.shape)
    data = tmp_path / "d.csv"
    write_measurements_csv(data, ex.t, ex.q, tau, qd=ex.qd, qdd=ex.qdd)
    base = tmp_path / "b.json"
    assert main(["identify", "ur5", str(data), "-o", str(tmp_path / "w.json"), "--method", "wls",
                 "--bootstrap", "20", "--base-json", str(base)]) == 0
    out = capsys.readouterr().out
    doc = json.loads((tmp_path / "w.json").read_text())
    boot = doc["bootstrap"]
    r = len(doc["base_parameters"])
    assert boot["replicates"] == 20 and len(boot["std"]) == r and np.shape(boot["covariance"]) == (r, r)
    np.testing.assert_allclose(np.sqrt(np.diag(boot["covariance"])), boot["std"], rtol=1e-12)
    assert "in --json" not in out
    lines = [ln for ln in out.splitlines() if ln.startswith("  ") and " +- " in ln]
    assert len(lines) == r
    for ln, s, row in zip(lines, boot["std"], doc["base_parameters"]):
        assert f"+- {s:.3g}" in ln and ln.endswith(row["expression"])
    few = mc.load_identified(tmp_path / "w.json")
    assert few.covariance.startswith("fit (the bootstrap's 20 refits are too few")
    doc["bootstrap"]["replicates"] = r + 2      # as if enough: the file's bootstrap covariance is used
    doc["bootstrap"]["covariance"] = (np.diag(boot["std"]) ** 2).tolist()
    (tmp_path / "many.json").write_text(json.dumps(doc))
    many = mc.load_identified(tmp_path / "many.json")
    assert many.covariance == f"bootstrap ({r + 2} refits)"
    np.testing.assert_allclose(np.sqrt(np.sum(np.array(many.factor) ** 2, axis=1)), boot["std"], rtol=1e-12)
    doc["bootstrap"]["replicates"] = "lots"
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    with pytest.raises(md.ModelError, match="bad.json.*bootstrap.replicates"):
        mc.load_identified(tmp_path / "bad.json")


@pytest.mark.skipif(not os.path.exists(PANDA_LOG), reason=PANDA_SKIP)
def test_readme_panda_identification_draws_and_divergences(tmp_path, capsys):
    """Item 4 on the README's Panda identification: the draws move a base parameter by a median
    of under 3 sigma (the Frobenius projection: 14), and every diverged run is explained or, where
    not, is not one the sampled loop predicts to hold (measured: 32 of 34 explained at 1 kHz)."""
    base = tmp_path / "b.json"
    assert main(["identify", "panda", PANDA_LOG, "-o", str(tmp_path / "p.toml"), "--t-range", "0:10",
                 "--friction-terms", "viscous,coulomb,offset", "--base-json", str(base)]) == 0
    capsys.readouterr()
    study = mc.study("panda", runs=10, seed=1, plants=str(base), controllers=("pd", "ct"))
    counts = study.plants.projected(1, 10)
    assert counts["shift_sigma_p50"] < 3 and counts["shift_sigma_max"] < 5
    rep = mc.run(study, scheduler="sync")
    pd = [r for r in rep.per_run if r["controller"] == "pd"]
    assert all(r["cause"] == "sampled loop" for r in pd if r["diverged"])
    # The figure is a linearisation at the reference samples: it knows neither the states the run
    # really visits nor the plant's nonlinear friction (the bundled panda carries Gaz et al.'s sigmoid
    # law).  A run flagged near the limit may hold: measured on the former default fit (the data alone),
    # run 8 at 2.02 held; on today's (prior weight 1, chosen on the hold-outs: its covariance draws other
    # plants) runs 6 and 7 at 2.10 and 2.09 held and run 3 at 2.45 diverged.  Every run flagged a tenth
    # above the limit diverges, and the figure is not idle: some run does.
    assert all(r["diverged"] for r in pd if r["sampled_loop"] > 2.2)
    assert sum(r["diverged"] for r in pd) >= sum(r["sampled_loop"] > 2.2 for r in pd) >= 1
    assert rep.controllers["ct"]["diverged"] == 0
