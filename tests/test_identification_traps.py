"""Issue 24, item 5: the traps between a real log and a model, each fixed and held here.

Friction side on a coupled motor-side log, the filter's edges, ``--prior-weight auto``'s cost,
and a Coulomb smoothing chosen from the log.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import manipdyn as md

pytest.importorskip("scipy")
pytest.importorskip("cvxpy")

from common import PANDA_LOG as PANDA, PANDA_SKIP


def _write_csv(path, header, columns):
    data = np.column_stack(columns)
    np.savetxt(path, data, delimiter=",", header=",".join(header), comments="", fmt="%.10g")


def _sines(t, n, seed, fmax):
    """Band-limited motion per joint: q (N, n), qd, qdd; six sines each, up to fmax Hz."""
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.05, fmax, (6, n))
    a = rng.uniform(0.05, 0.2, (6, n))
    ph = rng.uniform(0, 2 * np.pi, (6, n))
    w = 2 * np.pi * f
    arg = w[None] * t[:, None, None] + ph[None]
    q = (a * np.sin(arg)).sum(axis=1)
    qd = (a * w * np.cos(arg)).sum(axis=1)
    qdd = -(a * w**2 * np.sin(arg)).sum(axis=1)
    return q, qd, qdd


# -- friction side ----------------------------------------------------------------------------

def test_coupled_motor_side_log_fits_its_friction_at_the_motors_and_says_so(tmp_path, capsys):
    """The hard log: currents and motor positions through a [transmission] whose motor 6 drives joints 5
    and 6.  ``--friction`` used to fit a joint-side law there, silently; the coupled joints then
    predict the held-out motion worse than with the motor-side law the log's physics has."""
    from manipdyn.cli import main
    from manipdyn.identification import hard_log

    hl = hard_log(0, tmp_path / "hl")
    log, prior = str(hl.log), str(hl.prior_file)
    rms = {}
    for side in (None, "joint"):
        out = tmp_path / f"id_{side}.toml"
        extra = [] if side is None else ["--friction-side", side]
        assert main(["identify", prior, log, "-o", str(out), "--t-range", ":30", "--armature", "--friction",
                     "--json", *extra]) == 0
        notes = json.loads(capsys.readouterr().out)["fit_notes"]
        assert md.load(str(out)).friction_model.side == (side or "motor")
        said = [x for x in notes if "motor 6 drives joints 5 and 6" in x]
        assert len(said) == 1 and ("MOTOR side (chosen)" if side is None else "JOINT side, as given") in said[0]
        assert main(["validate", str(out), log, "--t-range", "30:", "--json"]) == 0
        rms[side or "motor"] = np.array(json.loads(capsys.readouterr().out)["rms"])
    # measured on seed 0: joint 5 1.89 against 2.27 N m, joint 6 1.10 against 2.25
    assert np.all(rms["motor"][4:] < 0.9 * rms["joint"][4:]), rms


def test_friction_side_choice_on_diagonal_and_link_side_drives():
    from manipdyn.identification.inputs.choices import friction_side
    from manipdyn.formats.logs.measurements import Measurements

    z = np.zeros((3, 2))
    link_side = Measurements(np.arange(3.0), z, z, z, z)
    at_motor = Measurements(np.arange(3.0), z, z, z, z, motor_signals=("qm", "i"))
    diagonal = md.Transmission(np.diag([50.0, 20.0]))
    coupled = md.Transmission([[50.0, 0.0], [20.0, 30.0]])
    assert friction_side(diagonal, at_motor) == ("joint", None)            # the side does not matter there
    side, note = friction_side(coupled, link_side)
    assert side == "joint" and "motor 2 drives joints 1 and 2" in note and "--friction-side motor" in note
    assert friction_side(coupled, at_motor)[0] == "motor"
    assert friction_side(coupled, at_motor, "joint")[0] == "joint"         # a side given is kept
    with pytest.raises(md.ModelError, match="friction side: expected 'joint', 'motor' or None"):
        friction_side(coupled, at_motor, "wheel")


# -- edges ------------------------------------------------------------------------------------

def test_a_log_cut_at_10_s_fits_at_least_9_s_with_its_edges_right(tmp_path):
    """A slow motion (cut-off at its 2 Hz floor) logged for 10 s at 1 kHz: the filter used to drop
    3 / cutoff = 1.5 s at each end (7 s left).  Now 0.375 s, and the accelerations at the new ends
    are as right as in the middle, within 1 % of qdd's RMS (filtering.py measures 0.3 % worst-case
    over band-limited motions at 0.75 / cutoff; the old odd extension was 20 to 30 % off there)."""
    from manipdyn.identification import read_log

    t = np.arange(0.0, 10.0, 1e-3)
    q, qd, qdd = _sines(t, 2, 0, 0.35)
    p = tmp_path / "cut.csv"
    _write_csv(p, ["t", "q1", "q2", "tau1", "tau2"], [t, q, qdd])
    m = read_log(p, 2)
    assert m.cutoff == pytest.approx(2.0)
    assert m.t[-1] - m.t[0] >= 9.0
    ref = np.interp(m.t, t, qdd[:, 0]), np.interp(m.t, t, qdd[:, 1])
    err = np.abs(m.qdd - np.column_stack(ref))
    assert np.all(err.max(axis=0) < 0.01 * np.sqrt(np.mean(qdd**2, axis=0)))


@pytest.mark.skipif(not PANDA.is_file(), reason=PANDA_SKIP)
def test_panda_log_cut_at_10_s(tmp_path, capsys):
    """The README's Panda protocol on a file that ends at 10 s: the fit keeps over 9 s of it, and joint 2
    predicts 10 to 13.8 s at 0.48 N m (0.69 when 1.5 s were dropped at each end; the published
    model: 0.426)."""
    from manipdyn.cli import main
    from manipdyn.identification import read_log

    rows = PANDA.read_text().splitlines()
    cut = tmp_path / "panda_cut10.csv"
    cut.write_text("\n".join([rows[0]] + [r for r in rows[1:] if float(r.split(",", 1)[0]) < 10.0]) + "\n")
    m = read_log(cut, 7)
    assert m.t[-1] - m.t[0] >= 9.0
    out = tmp_path / "id.toml"
    assert main(["identify", "panda", str(cut), "-o", str(out), "--friction-terms", "viscous,coulomb,offset"]) == 0
    capsys.readouterr()
    assert main(["validate", str(out), str(PANDA), "--t-range", "10:13.8", "--json"]) == 0
    rms = json.loads(capsys.readouterr().out)["rms"]
    assert rms[1] < 0.55, rms


# -- --prior-weight auto ----------------------------------------------------------------------

def _panda_log(N=5000, rate=200.0, seed=0):
    arm = md.load("panda")
    t = np.arange(N) / rate
    q, qd, qdd = _sines(t, arm.n, seed, 0.4)
    lim = np.asarray(arm.qlim)
    q = q + lim.mean(axis=1)
    tau = arm.inverse_dynamics(q, qd, qdd) + 0.3 * np.sign(qd) + 0.1 * qd
    tau = tau + np.random.default_rng(seed).normal(scale=0.05, size=tau.shape)
    return arm, q, qd, qdd, tau


def test_prior_weight_auto_computes_what_the_folds_share_once(monkeypatch):
    """Cross-validating 5 weights x 5 folds used to rebuild the base parameters (a pivoted QR at random
    states), the regressor of every fold's data and its QRs over the samples in each of the 25 fits.
    Now once each; and the folds' fits give what fits on the same samples give."""
    import manipdyn.identification.estimation.base as base_mod
    import manipdyn.identification.estimation.fitting as est_mod
    from manipdyn.identification.estimation.selection import choose_prior_weight

    arm, q, qd, qdd, tau = _panda_log(N=600)
    calls = {"base": 0, "regressor": 0}
    real_base = base_mod.base_parameters

    def counting_base(*a, **k):
        calls["base"] += 1
        return real_base(*a, **k)

    engine = arm.lagrange
    real_reg = type(engine).regressor

    def counting_reg(self, q_, *a, **k):
        if np.ndim(q_) == 2 and len(q_) >= 300:     # the data (600 samples, 300 a fold), not the base's 200 states
            calls["regressor"] += 1
        return real_reg(self, q_, *a, **k)

    monkeypatch.setattr(base_mod, "base_parameters", counting_base)
    monkeypatch.setattr(est_mod, "base_parameters", counting_base)
    monkeypatch.setattr(type(engine), "regressor", counting_reg)
    w, table = choose_prior_weight(arm, q, qd, qdd, tau, weights=(0.0, 1.0), folds=2, friction=True, bounds=None)
    assert calls == {"base": 1, "regressor": 1}
    assert len(table) == 2 and w in (0.0, 1.0)


def test_block_factors_stack_into_the_fit_of_all_the_samples():
    """What the folds rely on: a fit from the stacked factors of two blocks is the fit of all samples."""
    from manipdyn.identification import base_parameters, fit
    from manipdyn.identification.estimation.fitting import joint_factors, known_torque

    arm, q, qd, qdd, tau = _panda_log(N=1000, rate=50.0)          # 20 s of motion
    base = base_parameters(arm, friction=True)
    Y = base.regressor(arm.lagrange.regressor(q, qd, qdd, friction=True))
    y = tau - known_torque(arm, qd, qdd, False, True)
    halves = np.concatenate([joint_factors(Y[:400], y[:400]), joint_factors(Y[400:], y[400:])], axis=1)
    stacked = np.stack([np.linalg.qr(h, mode="r") for h in halves])
    for method in ("wls", "consistent"):
        a = fit(arm, q, qd, qdd, tau, method=method, friction=True, bounds=None, base=base)
        b = fit(arm, q, qd, qdd, tau, method=method, friction=True, bounds=None, base=base, factors=stacked)
        np.testing.assert_allclose(b.sigma, a.sigma, rtol=1e-9)
        if method == "wls":   # the same problem to rounding
            np.testing.assert_allclose(b.beta, a.beta, rtol=1e-6, atol=1e-9 * np.abs(a.beta).max())
        else:
            # consistent: two SDPs that are the same problem, each solved to the solver's tolerance
            # (~1e-8 in the objective).  Directions the data hardly excite move by more than that
            # (measured: 6e-6 absolute on small parameters) without changing the fit, so compare what
            # the data determine: the fitted torques, to the solver's tolerance relative to their size.
            fa, fb = np.einsum("...p,p->...", Y, a.beta), np.einsum("...p,p->...", Y, b.beta)
            np.testing.assert_allclose(fb, fa, rtol=0, atol=1e-6 * np.abs(fa).max())



# -- Coulomb smoothing from the log ------------------------------------------------------------

@pytest.mark.parametrize("noise", [1e-4, 3e-3])
def test_coulomb_smoothing_is_the_logged_velocitys_noise(tmp_path, capsys, noise):
    """qd logged with white noise ``noise`` rad/s: the search for the law's smoothing starts at that level (within 20 %: the
    filter removes all but ~2 fc / (rate / 2) = 2 % of the noise's power, and the RMS of 5000 samples
    is known to 1 %), the note says so, and ``--smoothing`` still decides when given."""
    from manipdyn.cli import main

    arm = md.load("ur5")
    rate = 200.0
    t = np.arange(6000) / rate
    q, qd, qdd = _sines(t, arm.n, 1, 0.4)
    law = md.Friction(viscous=np.full(arm.n, 0.2), coulomb=np.full(arm.n, 1.0), smoothing=1e-4)
    tau = arm.inverse_dynamics(q, qd, qdd) + law.torque(qd)
    qd_logged = qd + np.random.default_rng(2).normal(scale=noise, size=qd.shape)
    p = tmp_path / "log.csv"
    n = arm.n
    _write_csv(p, ["t"] + [f"q{j + 1}" for j in range(n)] + [f"qd{j + 1}" for j in range(n)]
               + [f"tau{j + 1}" for j in range(n)], [t, q, qd_logged, tau])
    out = tmp_path / "id.toml"
    assert main(["identify", "ur5", str(p), "-o", str(out), "--friction-terms",
                 "viscous,coulomb", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    # issue 37: one note, naming the noise level it started from (no second, contradicting note)
    said = [x for x in rep["fit_notes"] if x.startswith("Coulomb smoothing")]
    assert len(said) == 1, said
    v0 = float(said[0].split("the velocity's noise level on the log, ")[1].split(" rad/s")[0])
    assert v0 == pytest.approx(noise, rel=0.2)
    # issue 30: the noise level is where the search starts; the blocked hold-outs choose (the law's own
    # smoothing is 1e-4, so at 3e-3 of noise the held-out error picks a sharper sign than the noise level),
    # and (issue 37) a candidate replaces the noise level only when it wins by more than the folds' spread
    from manipdyn.identification.estimation.selection import one_se_choice

    v = md.load(str(out)).friction_model.smoothing
    table = rep["smoothing_selection"]
    assert v == one_se_choice(table, "smoothing", v0)[0]["smoothing"]
    assert any(row["smoothing"] == pytest.approx(v0, rel=1e-2) for row in table)
    assert said[0].startswith(f"Coulomb smoothing tanh(v / V): V = {v:.3g} rad/s chosen by 5-fold blocked hold-outs")
    if noise > 1e-3:
        assert v < v0
    assert main(["identify", "ur5", str(p), "-o", str(out), "--friction-terms",
                 "viscous,coulomb", "--smoothing", "0.05", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert md.load(str(out)).friction_model.smoothing == 0.05
    assert not any("Coulomb smoothing" in x for x in rep["fit_notes"])
