"""Issue 45, item 2: torque constants from currents with no payload run and no k_t, the scale from the
prior's gravity (identification/payload/gravity_scale.py), said in one line in the notes, the trust
record and the report; a log's own torque columns scored as one more model (``--compare-column``)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import manipdyn as md

pytest.importorskip("scipy", reason="torque constants need the identify extra")

K_TRUE = np.array([9.0, 12.5, 7.5, 3.0, 2.5, 2.0])       # N m/A, joint side (R = I)


def _prior():
    try:
        return md.load("erd:ur5_robot")
    except md.ModelError as exc:                       # example-robot-data not installed
        pytest.skip(f"erd:ur5_robot: {exc}")


def _log(path, seconds=24.0, rate=100.0, seed=0):
    """A synthetic log of the prior itself moving (sums of sines, every joint), its currents
    ``tau / K_TRUE`` with viscous and Coulomb friction and 0.5 % noise, and a column m1..m6 holding the
    rigid torque (a stand-in for a controller's own target torque)."""
    arm = _prior()
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / rate)
    w = 2 * np.pi * np.array([0.11, 0.17, 0.23])
    a = rng.uniform(0.2, 0.5, (3, 6))
    ph = rng.uniform(0, 2 * np.pi, (3, 6))
    q0 = np.array([0.0, -1.2, 1.0, -1.4, -1.5, 0.0])
    q = q0 + sum(a[k] * np.sin(w[k] * t[:, None] + ph[k]) for k in range(3))
    qd = sum(a[k] * w[k] * np.cos(w[k] * t[:, None] + ph[k]) for k in range(3))
    qdd = sum(-a[k] * w[k] ** 2 * np.sin(w[k] * t[:, None] + ph[k]) for k in range(3))
    rigid = arm.inverse_dynamics(q, qd, qdd)
    tau = rigid + 0.8 * qd + 1.5 * np.tanh(qd / 0.01)
    cur = tau / K_TRUE
    cur = cur + 0.005 * np.std(cur, axis=0) * rng.standard_normal(cur.shape)
    cols = [t[:, None], q, qd, cur, rigid]
    head = ["t"] + [f"{s}{j}" for s in ("q", "qd", "i", "m") for j in range(1, 7)]
    np.savetxt(path, np.hstack(cols), delimiter=",", header=",".join(head), comments="", fmt="%.10g")
    return path


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    d = tmp_path_factory.mktemp("gravity_scale")
    log = _log(d / "run.csv")
    out = d / "M.toml"
    r = md.identify("erd:ur5_robot", str(log), friction_terms="viscous,coulomb", identify_torque_constants=True,
                    method="ols", band_folds=0, output=str(out))
    return r, out, log


def test_the_scale_comes_from_the_priors_gravity_where_it_varies(fitted):
    """The prior is the truth here, so the gravity fixes the scale exactly: joints 2 and 3 (the motors whose
    gravity varies) within 2 % of the truth (the 0.5 % current noise and the fit's own bias stay far under it),
    and each error within three of its own standard deviations where that is finite."""
    r, _, _ = fitted
    tc = r.torque_constants
    assert tc.scale == "gravity" and list(tc.reference) == [2, 3]
    err = tc.values / K_TRUE - 1
    assert np.all(np.abs(err[1:3]) < 0.02), err
    ok = np.isfinite(tc.std)
    assert np.all(np.abs(tc.values - K_TRUE)[ok] <= 3 * tc.std[ok] + 0.02 * K_TRUE[ok]), (tc.values, tc.std)


def test_one_line_in_the_notes_the_trust_record_and_the_report(fitted, tmp_path):
    r, out, _ = fitted
    line = r.torque_constants.as_dict()["summary"]
    assert line.startswith("torque constants from the currents, N m/A, scale from the prior's gravity torque on "
                           "joint(s) 2, 3") and "k2 " in line and "+-" in line
    assert line in r.report()["fit_notes"]
    assert sum(line in x for x in r.format().splitlines()) == 1
    arm = md.load(str(out))
    assert arm.trust["torque_constants"] == line
    assert np.allclose(arm.transmission.torque_constant, r.torque_constants.values)
    page = tmp_path / "r.html"
    r.report_html(str(page))
    import html as _h

    assert page.read_text().count(_h.escape(line)) == 1        # in the notes on the fit, once


def test_scale_from_gravity_is_checked_by_name(fitted):
    _, _, log = fitted
    with pytest.raises(md.ModelError, match="scale_from_gravity: only with identify_torque_constants"):
        md.identify("erd:ur5_robot", str(log), scale_from_gravity=[2])
    with pytest.raises(md.ModelError, match="scale_from_gravity: expected motor numbers 1 to 6"):
        md.identify("erd:ur5_robot", str(log), identify_torque_constants=True, scale_from_gravity=[7],
                    method="ols", band_folds=0)


def test_a_logs_own_torque_is_scored_as_one_more_model(fitted, capsys):
    """--compare-column m: the m1..m6 columns (here the rigid torque without friction) scored beside the model on
    the same samples, named as given; the identified model, which has the friction, beats it on every joint."""
    from manipdyn.cli import main

    _, out, log = fitted
    assert main(["validate", str(out), str(log), "--compare-column", "m=controller target torque", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    names = [m["model"] for m in rep["models"]]
    assert names[1] == "controller target torque"
    assert all(b["index"] == 0 for b in rep["best"]), rep["best"]
    assert main(["validate", str(out), str(log), "--compare-column", "nothere"]) == 2
    assert "compare_column" in capsys.readouterr().err


def test_the_command_line_checks_scale_from_gravity(fitted, capsys):
    from manipdyn.cli import main

    _, out, log = fitted
    for args, why in ((["--identify-torque-constants", "--scale-from-gravity", "2,x"], "expected motor numbers"),
                      (["--scale-from-gravity", "2"], "only with")):
        assert main(["identify", "erd:ur5_robot", str(log), "-o", str(out.with_name("x.toml")), *args]) == 2
        err = capsys.readouterr().err
        assert "scale" in err and why in err and len(err.strip().splitlines()) == 1, err
