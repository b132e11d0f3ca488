"""Issue 30 item 5: what the fit should have doubted, said.

A declared payload the data contradict (the README's sample RUNS.toml declares 2.8 kg on a run that
carries none): the run is named, as far off its noise and the other runs, and the payload check names
the contradiction.  Degenerate inertias: named by :func:`degenerate_links`, kept off by the default
fit's radius-of-gyration floor on the real Panda log, whose held-out error stays what it was.
"""

import json
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.identification.results.doubts import GYRATION_FRACTION, arm_size, degenerate_links

from test_bands import _log

from common import PANDA_LOG as _PANDA_LOG, PANDA_SKIP  # noqa: E402

PANDA_LOG = str(_PANDA_LOG)


def test_a_declared_payload_the_data_contradict_is_named(tmp_path, capsys):
    arm = md.load("ur5")
    _log(tmp_path / "run1.csv", arm, 21)
    _log(tmp_path / "run2.csv", arm, 22)           # carries nothing
    (tmp_path / "RUNS.toml").write_text(
        '[[log]]\npath = "run1.csv"\n\n[[log]]\npath = "run2.csv"\n'
        'payload = { mass = 2.8, com = [0.0, 0.0, 0.05], inertia = [0.006, 0.006, 0.004, 0.0, 0.0, 0.0] }\n')
    out = tmp_path / "id.toml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["identify", "ur5", "--logs", str(tmp_path / "RUNS.toml"), "-o", str(out), "--json",
                     "--band-folds", "0"]) == 0
    rep = json.loads(capsys.readouterr().out)
    doubts = rep["doubts"]
    assert any(d.startswith("run run2.csv: its residual is far above") for d in doubts), doubts
    assert any(d.startswith("run run2.csv: declared payload 2.8 kg, but its torques say") for d in doubts), doubts
    assert not any("run1.csv" in d for d in doubts)
    assert all(d in rep["fit_notes"] for d in doubts)
    # the model file carries them and validate repeats them
    assert md.load_with_notes(str(out))[0].trust["doubts"] == doubts
    assert main(["validate", str(out), str(tmp_path / "run1.csv")]) == 0
    assert "note: the fit doubted: run run2.csv: declared payload 2.8 kg" in capsys.readouterr().out


def test_the_right_payload_is_not_doubted(tmp_path, capsys):
    arm = md.load("ur5")
    _log(tmp_path / "run1.csv", arm, 23)
    from manipdyn.model.variants import with_payload

    heavy = with_payload(arm, 2.0, np.array([0.0, 0.0, 0.05]), np.zeros((3, 3)))
    _log(tmp_path / "run2.csv", heavy, 24)
    (tmp_path / "RUNS.toml").write_text('[[log]]\npath = "run1.csv"\n\n[[log]]\npath = "run2.csv"\n'
                                        'payload = { mass = 2.0, com = [0.0, 0.0, 0.05] }\n')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["identify", "ur5", "--logs", str(tmp_path / "RUNS.toml"), "-o", str(tmp_path / "id.toml"),
                     "--json", "--band-folds", "0"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert not any(d.startswith("run ") for d in rep["doubts"]), rep["doubts"]


def test_degenerate_links_are_named():
    arm = md.load("ur5")
    links = list(arm.links)
    import dataclasses

    from manipdyn.model.inertia import LinkInertia

    rod = np.diag([1e-9, 0.05, 0.05])         # a 1e-5 m thin rod of 3.7 kg
    links[2] = dataclasses.replace(links[2], body=LinkInertia(links[2].mass, links[2].com, rod))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bad = md.Manipulator(links, convention=arm.convention, name="bad")
    named = degenerate_links(bad)
    assert len(named) == 1 and named[0].startswith("link 3") and "degenerate inertia" in named[0]
    assert degenerate_links(arm) == []
    assert arm_size(arm) > 0.5


@pytest.mark.skipif(not os.path.exists(PANDA_LOG), reason=PANDA_SKIP)
def test_the_default_fit_keeps_the_pandas_bodies_off_the_boundary(tmp_path):
    """The Panda fitted with the README's options: without the floor every link ends on J >= 0 (a 5 kg rod
    with a smallest moment of 2e-8 kg m^2); the default's floor (1 % of the arm's size, or half the prior
    body's own) holds, the links on it are named, and the held-out RMS on 10-13.8 s stays within 1 % per joint
    of the fit without the floor (the floor costs nothing the held-out data can see)."""
    from manipdyn.identification.estimation.sdp import Bounds

    kw = dict(t_range=(0, 10), friction_terms="viscous,coulomb,offset", smoothing=0.0235, band_folds=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = md.identify("panda", PANDA_LOG, **kw)
    b = Bounds.plausible(r.prior)
    S_min = []
    for j, r_floor in zip(r.arm.chain()[0], b.gyration):
        S = 0.5 * np.trace(j.body.inertia) - np.linalg.eigvalsh(j.body.inertia)
        S_min.append(S.min())
        assert np.sqrt(max(S.min(), 0) / j.body.mass) >= 0.99 * r_floor
    assert np.all(b.gyration > 0) and np.max(b.gyration) == pytest.approx(0.01 * arm_size(r.prior))
    assert any("radius of gyration at the plausibility floor" in d for d in r.report()["doubts"])
    v = md.validate(r, PANDA_LOG, t_range=(10, 13.8)).results[0]
    assert GYRATION_FRACTION < 0.01
    assert S_min
    # the floor does not worsen the held-out error (against the fit without it: bounds with gyration=None)
    from manipdyn.identification.estimation import fitting

    d = r.data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nofloor = fitting.fit(r.prior, d.q, d.qd, d.qdd, d.tau, method="consistent", friction=r.friction,
                              bounds=Bounds(mass=b.mass, com=b.com, total_mass=b.total_mass))
    assert len(degenerate_links(nofloor.arm)) > len(degenerate_links(r.arm))   # without the floor, more degenerate
    J_free = [np.linalg.eigvalsh(j.body.inertia)[0] for j in nofloor.arm.chain()[0]]
    # 2e-8 kg m^2 left free; with the floor the thinnest (link 2, whose published body is nearly flat) 3e-7
    assert min(J_free) < 1e-7 and min(S_min) > 10 * min(J_free)
    # the held-out comparison at the default's own prior weight (chosen on the hold-outs, issue 44): the floor
    # is held in step 2, on the base parameters step 1 found, so it changes no torque at all
    w = r.provenance["options"].get("prior_weight", 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        same = fitting.fit(r.prior, d.q, d.qd, d.qdd, d.tau, method="consistent", friction=r.friction,
                           bounds=Bounds(mass=b.mass, com=b.com, total_mass=b.total_mass), prior_weight=w,
                           rest=r.fit.rest)
    v0 = md.validate(same.arm, PANDA_LOG, t_range=(10, 13.8)).results[0]
    assert np.all(v.rms <= 1.01 * v0.rms), (v.rms, v0.rms)


def test_a_fit_that_drops_the_gyration_floor_says_so(monkeypatch):
    """The floor is best effort: when the solve with it fails, the fit retries without it, and
    the notes say that it did (before, nothing did).  The failure is planted in front of the real
    solver, for the floored try only; the retry runs the real solver (the ordinary fits of the
    tests above run it with the floor)."""
    from manipdyn.identification import excitation
    from manipdyn.identification.estimation import fitting
    from manipdyn.identification.estimation.sdp import Bounds

    arm = md.load("ur5")
    ex = excitation(arm, duration=4.0, harmonics=3, rate=100.0, iterations=0, seed=2)
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    real = fitting.consistent_fit
    calls = []

    def failing_with_floor(*a, bounds=None, **kw):
        calls.append(bounds is not None and bounds.gyration is not None)
        if calls[-1]:
            raise md.ModelError("consistent fit: the solver failed (planted)")
        return real(*a, bounds=bounds, **kw)

    monkeypatch.setattr(fitting, "consistent_fit", failing_with_floor)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = fitting.fit(arm, ex.q, ex.qd, ex.qdd, tau, method="consistent", bounds=Bounds.plausible(arm))
    assert calls == [True, False]
    assert r.report["gyration_floor_dropped"] is True
    assert r.report["fit_notes"][0].startswith("the radius-of-gyration floor (a plausibility bound, best effort) "
                                               "was dropped: the fit with it failed (consistent fit: the solver "
                                               "failed (planted))")
    assert r.consistent
    monkeypatch.setattr(fitting, "consistent_fit", real)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r2 = fitting.fit(arm, ex.q, ex.qd, ex.qdd, tau, method="consistent", bounds=Bounds.plausible(arm))
    assert "gyration_floor_dropped" not in r2.report
    assert not any("floor" in n and "dropped" in n for n in r2.report["fit_notes"])


def test_a_fit_the_solver_stopped_short_of_is_saved_with_the_doubt(tmp_path, monkeypatch):
    """Issue 38 item 7: an answer labelled inaccurate was printed as "stopped short ... this answer is
    not it" and then saved as if nothing happened.  It is now saved with that doubt in its trust
    record, so the model file says it and ``validate`` repeats it.  The label is planted on the real
    solver's real answer (the answer is Clarabel's; only its name says "inaccurate": a fit that
    stops short on its own cannot be made to order).  The real solvers' choice is held by
    ``tests/test_pipeline.py::test_the_consistent_fit_does_not_move_with_the_blas_kernel``."""
    from manipdyn.identification.estimation import fitting

    arm = md.load("ur5")
    log = tmp_path / "fit.csv"
    _log(log, arm, 1)
    real = fitting.consistent_fit

    def labelled_inaccurate(*a, **kw):
        pi, solver = real(*a, **kw)
        return pi, "CLARABEL (inaccurate)"

    monkeypatch.setattr(fitting, "consistent_fit", labelled_inaccurate)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = md.identify(arm, [log], band_folds=0)
    assert r.report()["stopped_short"] is True
    out = tmp_path / "ur5_id.toml"
    r.save(out)
    back = md.load(str(out))
    doubts = back.trust["doubts"]
    assert any("stopped short of the best physical fit" in d for d in doubts), doubts
    monkeypatch.setattr(fitting, "consistent_fit", real)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = md.identify(arm, [log], band_folds=0)
    assert not any("stopped short" in d for d in clean.report()["doubts"])
