"""``md.replay`` and ``manipdyn replay`` (issue 40, item 4): models simulated forward from states of a
log with the logged torque, q and qd at the horizon against the log.

Lean: a synthetic log of 2 s, and a 2 s window of the real Panda log (skipped without it).
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.control.demo import DEFAULT_BANDWIDTH, DEFAULT_GAMMA, demo_path, make_controller
from manipdyn.control.replay import BASELINE
from manipdyn.model.variants import with_scaled_inertia

from common import PANDA_LOG, err_line, needs_panda_log


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """A 2 s log of the UR5 (viscous and smooth Coulomb friction) under the demo PD, 1 kHz: t, q, qd,
    tau; the torque is constant over each sample, which the replay holds (mean of the ends) only
    approximately: the truth's replay error is that difference and the filter's, no model error."""
    base = md.load("ur5")
    truth = md.Manipulator(base.links, convention=base.convention, gravity=base.gravity, name="ur5_truth",
                           friction=md.Friction(viscous=[0.5] * 6, coulomb=[0.3] * 6, smoothing=0.2))
    path = demo_path(truth, 2.0)
    ctrl = make_controller("pd", truth, DEFAULT_BANDWIDTH, DEFAULT_GAMMA, path=path, dt=1e-3)
    log = md.simulate(truth, ctrl, path, 2.0, dt=1e-3)
    path_csv = tmp_path_factory.mktemp("replay") / "ur5_log.csv"
    head = "t," + ",".join(f"q{i}" for i in range(1, 7)) + "," + ",".join(f"qd{i}" for i in range(1, 7)) + "," + \
        ",".join(f"tau{i}" for i in range(1, 7))
    np.savetxt(path_csv, np.column_stack([log.t, log.q, log.qd, log.tau]), delimiter=",", header=head, comments="")
    return truth, path_csv


def test_replay_ranks_the_true_model_first_and_reports_every_joint(synthetic):
    truth, log = synthetic
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        wrong = with_scaled_inertia(truth, 1.3, name="ur5_heavier")
    r = md.replay([truth, wrong], log, horizons=(0.02, 0.1), every=20, cutoff=50.0)
    assert r.labels == ["ur5_truth", "ur5_heavier"] and r.q_rms["ur5_truth"].shape == (2, 6)
    # the wrong model (every link 30 % heavier, the controller's torque the same) drifts more, at every horizon
    assert np.all(r.pooled("ur5_truth") < 0.5 * r.pooled("ur5_heavier"))
    assert np.all(r.pooled("ur5_truth", "qd") < 0.5 * r.pooled("ur5_heavier", "qd"))
    # the true model predicts: far better than the constant-velocity guess q_k + H qd_k (measured 0.005 to
    # 0.009 of it; what is left is the torque held as the mean of each sample's ends, and the filter)
    assert np.all(r.pooled("ur5_truth") < 0.05 * r.pooled(BASELINE))
    assert r.starts > 50 and r.steps == (20, 100)
    text = r.format()
    assert "q error at 20 ms (20 samples)" in text and BASELINE in text and "ur5_heavier" in text
    d = r.to_dict()
    assert d["models"]["ur5_truth"]["0.1"]["q_pooled"] == pytest.approx(float(r.pooled("ur5_truth")[1]))


def test_replay_in_mujoco_agrees_with_manipdyn_within_the_integrators_difference(synthetic):
    pytest.importorskip("mujoco", reason="MuJoCo is not installed: replay --simulator mujoco is not tested")
    truth, log = synthetic
    kw = dict(horizons=(0.02, 0.05), every=40, cutoff=50.0)
    own = md.replay(truth, log, **kw)
    m = own.substeps["ur5_truth"]
    mj = md.replay(truth, log, simulator="mujoco", **kw)
    halved = md.replay(truth, log, substeps=2 * m, **kw)
    for what in ("q_rms", "qd_rms"):
        a, b, c = (getattr(x, what)["ur5_truth"] for x in (own, mj, halved))
        integrator = np.abs(a - c).max()                 # RK4's own error at this step (step halving)
        assert 0 < integrator < 1e-3 * np.abs(a).max()   # a bound that means something, far below the scores
        assert np.abs(a - b).max() <= integrator, f"{what}: MuJoCo and manipdyn differ by {np.abs(a - b).max():.3g}"
    assert mj.to_dict()["simulator"] == "mujoco" and mj.to_dict()["mujoco_plant"] == "model"


@needs_panda_log
def test_replay_on_the_real_panda_log_in_both_simulators():
    pytest.importorskip("mujoco", reason="MuJoCo is not installed")
    kw = dict(horizons=(0.01, 0.05), every=20, t_range=(10, 12))
    own = md.replay(["panda"], str(PANDA_LOG), **kw)
    mj = md.replay(["panda"], str(PANDA_LOG), simulator="mujoco", **kw)
    halved = md.replay(["panda"], str(PANDA_LOG), substeps=2 * own.substeps["panda"], **kw)
    a, b, c = own.q_rms["panda"], mj.q_rms["panda"], halved.q_rms["panda"]
    assert np.abs(a - b).max() <= np.abs(a - c).max()
    # the log's own samples: the guess q_k + H qd_k misses by what the arm accelerated, never 0
    assert np.all(own.q_rms[BASELINE] > 0) and own.starts >= 15


def test_cli_replay_prints_json_and_refuses_what_it_cannot_do(synthetic, tmp_path, capsys):
    truth, log = synthetic
    toml = tmp_path / "ur5_truth.toml"
    md.save(truth, str(toml))
    page = tmp_path / "replay.html"
    assert main(["replay", str(toml), "ur5", str(log), "--horizon", "0.05", "--every", "20", "--cutoff", "50",
                 "--json", "--report", str(page)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc["models"]) == {"ur5_truth", "ur5"} and doc["horizon_samples"] == [50]
    from manipdyn._support.html import read_tables

    table = read_tables(page.read_text())["q_0.05"]          # the page carries the JSON's numbers exactly
    assert table[1][-1] == doc["models"]["ur5_truth"]["0.05"]["q_pooled"]
    for far in ("100", "1e300"):                 # 1e300 s: refused before any array of that size
        assert main(["replay", "ur5", str(log), "--horizon", far]) == 2
        assert "longest horizon" in err_line(capsys)
    assert main(["replay", "ur5"]) == 2
    assert "give at least one model, then at least one log" in err_line(capsys)
    assert main(["replay", "ur5", str(log), "--mujoco-plant", "file"]) == 2
    assert err_line(capsys).endswith("--mujoco-plant: only with --simulator mujoco")
    assert main(["replay", "ur5", str(log), "--every", "0"]) == 2
    assert "every" in err_line(capsys)
