"""``manipdyn identify MODEL DATA --payload``: the payload of a known arm from the command line."""

from __future__ import annotations

import json

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.control import with_payload

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import excitation, identify_payload, write_measurements_csv  # noqa: E402

MASS, COM, INERTIA = 2.5, np.array([0.02, -0.03, 0.08]), np.diag([0.010, 0.012, 0.006])


@pytest.fixture(scope="module")
def payload_log(tmp_path_factory):
    """UR5 carrying a known payload, 1 % noise (of each joint's peak torque), qd and qdd logged."""
    arm = md.load("ur5")
    ex = excitation(arm, duration=10.0, harmonics=4, rate=100.0, iterations=0, seed=1)
    true = with_payload(arm, MASS, COM, INERTIA)
    tau = true.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.01 * np.abs(tau).max(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)
    path = tmp_path_factory.mktemp("payload") / "log.csv"
    write_measurements_csv(path, ex.t, ex.q, tau, qd=ex.qd, qdd=ex.qdd)
    return arm, true, ex, tau, path


def test_text_json_and_model(payload_log, tmp_path, capsys):
    arm, true, ex, tau, path = payload_log
    ref = identify_payload(arm, ex.q, ex.qd, ex.qdd, tau)
    assert main(["identify", "ur5", str(path), "--payload", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    # what the API gives on the same numbers (the CSV's 17 significant digits are exact)
    assert d["mass"] == pytest.approx(ref.mass, rel=1e-6)
    assert np.allclose(d["com"], ref.com, atol=1e-6)
    assert abs(d["mass"] - MASS) <= 0.02 * MASS and np.linalg.norm(np.subtract(d["com"], COM)) <= 5e-3
    assert d["link"] == 6 and d["data"] == str(path) and d["output"] is None
    assert set(ref.as_dict()) <= set(d)

    out = tmp_path / "ur5_payload.toml"
    assert main(["identify", "ur5", str(path), "--payload", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"mass   {ref.mass:.4g} +- {ref.mass_std:.2g} kg" in text
    assert f"x = {1e3 * ref.com[0]:.2f} +- {1e3 * ref.com_std[0]:.2g}" in text and "mm (payload frame)" in text
    assert "inertia about the COM" in text and f"wrote {out}" in text
    # the written model is the arm carrying the payload: it predicts the true torques to well
    # under the noise (0.2 of each joint's noise level, as tests/test_payload.py asks of the API)
    carried = md.load(str(out))
    err = carried.inverse_dynamics(ex.q, ex.qd, ex.qdd) - true.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    assert np.all(np.sqrt(np.mean(err**2, axis=0)) <= 0.2 * ref.sigma)


def test_static_data_print_notes_and_null_std(tmp_path, capsys):
    """Held still, only the weight shows: the inertia is not determined, the note says so and the
    JSON has null (not Infinity) for the standard deviations of what was not excited."""
    arm = md.load("ur5")
    rng = np.random.default_rng(3)
    q = np.repeat(arm.random_state(rng, 8), 30, axis=0)
    z = np.zeros_like(q)
    tau = with_payload(arm, MASS, COM, INERTIA).inverse_dynamics(q, z, z)
    path = tmp_path / "static.csv"
    write_measurements_csv(path, np.arange(len(q)) * 0.01, q, tau, qd=z, qdd=z)
    assert main(["identify", "ur5", str(path), "--payload"]) == 0
    text = capsys.readouterr().out
    assert "poorly determined: Ixx" in text and "note: the data do not determine" in text
    assert main(["identify", "ur5", str(path), "--payload", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["parameter_std"]["Ixx"] is None and d["mass"] == pytest.approx(MASS, rel=1e-6)


def test_payload_link_and_usage_errors(payload_log, capsys):
    arm, true, ex, tau, path = payload_log
    assert main(["identify", "ur5", str(path), "--payload", "--payload-link", "nope"]) == 2
    assert "no link named 'nope'" in capsys.readouterr().err
    name = arm.chain()[0][-1].link_name or "link6"
    assert main(["identify", "ur5", str(path), "--payload", "--payload-link", name, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["link"] == 6
    for extra, msg in ((["--method", "ols"], "--method: not with --payload"),
                       (["--armature"], "--armature: not with --payload"),
                       (["-o", "x.json"], "with --payload, expected a file name ending in .toml or .urdf")):
        assert main(["identify", "ur5", str(path), "--payload", *extra]) == 2
        assert msg in capsys.readouterr().err
    assert main(["identify", "ur5", str(path), "--payload-link", name, "-o", "x.toml"]) == 2
    assert "--payload-link: only with --payload" in capsys.readouterr().err
    assert main(["identify", "ur5", str(path)]) == 2
    assert "-o/--output: required" in capsys.readouterr().err
