"""``validate`` scores the forward dynamics (issue 44, item 4): beside each joint's torque RMS, the RMS
of the acceleration error ``D^-1 (tau - tau_hat)`` on the model's own ``D``, in text, JSON and HTML, and
with several models the best per joint marked.
"""

from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.control.demo import DEFAULT_BANDWIDTH, DEFAULT_GAMMA, demo_path, make_controller
from manipdyn.identification.results.forward_error import ACCEL_NOTE, acceleration_error
from manipdyn.model.inertia import LinkInertia


def _ur5(name, wrist_inertia_scale=1.0):
    base = md.load("ur5")
    links = list(base.links)
    if wrist_inertia_scale != 1.0:          # the wrist's inertia tensor only: its mass (gravity) unchanged
        b = links[-1].body
        links[-1] = dataclasses.replace(links[-1], motor_inertia=links[-1].motor_inertia * wrist_inertia_scale,
                                        body=LinkInertia(b.mass, b.com, np.asarray(b.inertia) * wrist_inertia_scale,
                                                         b.name))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.Manipulator(links, convention=base.convention, gravity=base.gravity, name=name,
                              friction=md.Friction(viscous=[0.5] * 6, coulomb=[0.3] * 6, smoothing=0.2))


@pytest.fixture(scope="module")
def log_csv(tmp_path_factory):
    truth = _ur5("ur5_truth")
    path = demo_path(truth, 2.0)
    ctrl = make_controller("pd", truth, DEFAULT_BANDWIDTH, DEFAULT_GAMMA, path=path, dt=1e-3)
    log = md.simulate(truth, ctrl, path, 2.0, dt=1e-3)
    out = tmp_path_factory.mktemp("accel") / "ur5_log.csv"
    head = ",".join(["t", *(f"q{i}" for i in range(1, 7)), *(f"qd{i}" for i in range(1, 7)),
                     *(f"tau{i}" for i in range(1, 7))])
    np.savetxt(out, np.column_stack([log.t, log.q, log.qd, log.tau]), delimiter=",", header=head, comments="")
    return truth, out


def test_the_acceleration_error_is_the_forward_dynamics_miss(log_csv):
    truth, log = log_csv
    light = _ur5("ur5_light_wrist", 0.2)
    v = md.validate([truth, light], log, cutoff=50.0)
    d = v.data
    for arm, r in zip((truth, light), v.results):
        # D^-1 (tau - ID(q, qd, qdd)) is FD(q, qd, tau) - qdd, exactly: the identity the score rests on
        miss = arm.forward_dynamics(d.q, d.qd, d.tau) - d.qdd
        assert r.accel_rms == pytest.approx(np.sqrt(np.mean(miss**2, axis=0)), rel=1e-9, abs=1e-12)
    t, w = v.results
    # a wrist with a fifth of its inertia: its torque error on joint 6 looks negligible (7e-4 N m, 1 % of
    # joint 1's, measured), its acceleration error is 26.6 rad/s^2 against the truth's 0.074 (measured):
    # the forward dynamics see what the torque RMS hides
    assert w.rms[5] < 0.02 * w.rms[0]
    assert w.accel_rms[5] > 100 * t.accel_rms[5] and w.accel_rms[5] > 10 * w.accel_rms[:5].max()
    side = v.to_dict()
    assert [b["model"] for b in side["best_accel"]][5] == "ur5_truth"
    assert side["models"][1]["accel_rms"][5] == pytest.approx(float(w.accel_rms[5]))
    text = v.format()
    assert "forward dynamics: RMS acceleration error" in text and "rad/s^2" in text
    row6 = [line for line in text.splitlines()[text.splitlines().index(next(
        x for x in text.splitlines() if x.startswith("forward dynamics"))):] if line.startswith("    6 ")][0]
    assert row6.split()[1].endswith("*")                  # the truth is best on joint 6


def test_one_model_gets_a_column_and_the_page_a_table(log_csv, tmp_path, capsys):
    truth, log = log_csv
    model = tmp_path / "light.toml"
    md.save(_ur5("light", 0.2), model)
    assert main(["validate", str(model), str(log), "--cutoff", "50", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert len(d["accel_rms"]) == 6 and all(x > 0 for x in d["accel_rms"])
    assert main(["validate", str(model), "ur5", str(log), "--cutoff", "50", "--report", str(tmp_path / "v.html")]) == 0
    page = (tmp_path / "v.html").read_text()
    assert "Forward dynamics side by side" in page and "acceleration error RMS" in page
    r = md.validate(str(model), log, cutoff=50.0).results[0]
    assert "accel rms (rad/s^2)" in r.format()


def test_a_model_without_a_mass_matrix_says_why():
    class Regressor:                            # a base model: base parameters, no D
        n = 2

    a, why = acceleration_error(Regressor(), np.zeros((3, 2)), np.ones((3, 2)))
    assert a is None and why == ACCEL_NOTE
