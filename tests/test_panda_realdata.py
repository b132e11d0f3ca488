"""The real Franka Panda log (../shared/realdata/panda_gaz2019, measured outside the project):
identify on t < 10 s as logged, score on 10 s <= t < 13.8 s against the published model."""

from __future__ import annotations

import json

import numpy as np
import pytest

import manipdyn as md

from common import PANDA_LOG as DATA, needs_panda_log

pytestmark = needs_panda_log
pytest.importorskip("cvxpy", reason="identification needs the identify extra")

SIGMOID = dict(sigmoid_A=[0.54615, 0.87224, 0.64068, 1.2794, 0.83904, 0.30301, 0.56489],
               sigmoid_alpha=[5.1181, 9.0657, 10.136, 5.5903, 8.3469, 17.133, 10.336],
               sigmoid_p3=[0.039533, 0.025882, -0.04607, 0.036194, 0.026226, -0.021047, 0.0035526])


def test_panda_as_logged_end_to_end(tmp_path, capsys):
    from manipdyn.cli import main

    out = tmp_path / "panda_id.toml"
    assert main(["identify", "panda", str(DATA), "-o", str(out), "--t-range", "0:10",
                 "--friction-terms", "viscous,coulomb,offset", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["consistent"] and any("1131 duplicate rows" in n for n in rep["data_notes"])
    ident, prior = md.load(str(out)), md.load("panda")
    m, m0 = sum(l.mass for l in ident.links), sum(l.mass for l in prior.links)
    assert abs(m - m0) <= 0.25 * m0                       # the plausibility target
    pub = md.Manipulator(prior.links, convention=prior.convention, gravity=prior.gravity, name="published",
                         friction=md.Friction(**SIGMOID))
    pub_file = tmp_path / "published.toml"
    md.save(pub, pub_file)
    scores = {}
    for name, path in (("published", pub_file), ("identified", out)):
        assert main(["validate", str(path), str(DATA), "--t-range", "10:13.8", "--json"]) == 0
        scores[name] = np.array(json.loads(capsys.readouterr().out)["rms"])
    # measured (README table): better on every joint but joint 2 (the held-out window visits
    # q2 > 0.3 rad, which the fit window never does: README); joint 2 is asserted as it is, so
    # a change that fixes it (or makes it worse than the measured 24 %) shows up here
    better = scores["identified"] < scores["published"]
    assert better[[0, 2, 3, 4, 5, 6]].all(), scores
    assert scores["identified"][1] <= 1.3 * scores["published"][1], scores


def test_published_joint2_error_belongs_to_the_fit_windows_states():
    """The README's reason joint 2 is not won (benchmarks/bench_panda.py): the published model's
    joint-2 error has a mean of about -0.56 N m on the fit window's states and about 0 on the
    held-out window's, and it repeats with the excitation's period (13.33 s), so it is a
    function of the state, not drift."""
    from benchmarks.bench_panda import SIGMOID as S
    from manipdyn.identification import read_log

    prior = md.load("panda")
    pub = md.Manipulator(prior.links, convention=prior.convention, gravity=prior.gravity, friction=md.Friction(**S))
    d = read_log(str(DATA), 7)
    e = d.tau[:, 1] - pub.inverse_dynamics(d.q, d.qd, d.qdd)[:, 1]
    fit, held = d.t < 10, (d.t >= 10) & (d.t < 13.8)
    assert e[fit].mean() < -0.4 and abs(e[held].mean()) < 0.1, (e[fit].mean(), e[held].mean())
    # one period later, the same states give the same error: 1.5-5 s against 14.83-18.33 s
    a = (d.t >= 1.5) & (d.t < 5.0)
    b = np.flatnonzero((d.t >= 1.5 + 40 / 3) & (d.t < 5.0 + 40 / 3))[: a.sum()]
    assert np.abs(d.q[a][: len(b)] - d.q[b]).max() < 0.05             # the same states...
    assert np.corrcoef(e[a][: len(b)], e[b])[0, 1] > 0.8                # ...the same error
