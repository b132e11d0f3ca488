"""Monte-Carlo studies: seeding, plants, replay, reports, and a real Dask cluster.

The cluster tests start ``dask scheduler`` and two ``dask worker`` processes
on 127.0.0.1 (tests/dask_cluster.py) and compare what they return with runs
in this process: bit for bit (JSON text), except the ``"timing"`` entry.
Runs are short (0.5 to 1 s simulated at 1 kHz) to keep the suite quick.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import sys
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn import montecarlo as mc
from manipdyn.cli import main
from manipdyn.control import SimulationDiverged, with_payload, with_scaled_inertia

import arms
from dask_cluster import dask_cluster

distributed = pytest.importorskip("distributed", reason="the scale extra (dask[distributed]) is not installed")

DURATION = 1.0   # s simulated per run: short (the demo path squeezed into less diverges)


@pytest.fixture(scope="module")
def puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load("puma560")


def _without_timing(text: str) -> str:
    doc = json.loads(text)
    assert "timing" in doc
    doc.pop("timing")
    return json.dumps(doc)


# -- seeding and plants -------------------------------------------------------------
def test_a_runs_plant_depends_on_seed_and_index_only(puma):
    a = mc.study(puma, runs=10, seed=4, duration=DURATION)
    b = mc.study(puma, runs=50, seed=4, duration=DURATION, controllers=("ct",))
    for run in (0, 3, 9):
        da, db = a.draw(run), b.draw(run)
        for field in ("payload_com", "scale", "friction", "q0_offset", "torque_noise"):
            np.testing.assert_array_equal(getattr(da, field), getattr(db, field))
        assert da.payload_mass == db.payload_mass
    assert a.draw(1).payload_mass != a.draw(2).payload_mass
    assert mc.study(puma, runs=10, seed=5).draw(3).payload_mass != a.draw(3).payload_mass


def test_draws_follow_the_documented_ranges(puma):
    d = mc.ABSOLUTE_DEFAULTS                 # the absolute figures (kg, N m) of the defaults before issue 46
    s = mc.study(puma, runs=200, seed=0, duration=DURATION, distributions=d)
    draws = [s.draw(k) for k in range(200)]
    mass = np.array([x.payload_mass for x in draws])
    com = np.array([x.payload_com for x in draws])
    scale = np.array([x.scale for x in draws])
    fr = np.array([x.friction for x in draws])
    assert 0 <= mass.min() and mass.max() <= d.payload_mass and mass.mean() == pytest.approx(1.0, abs=0.15)
    assert np.all(np.abs(com[:, :2]) <= 0.05) and np.all((0 <= com[:, 2]) & (com[:, 2] <= 0.15))
    assert np.all(np.abs(scale - 1) <= 0.2) and scale.std() > 0.08      # uniform +-0.2: std 0.115
    assert np.all((0 <= fr) & (fr <= 0.5))
    noise = np.concatenate([x.torque_noise for x in draws[:20]])
    assert noise.shape[1] == 6 and noise.std() == pytest.approx(d.torque_noise, rel=0.02)


def test_plant_is_the_dh_arm_with_payload_and_scaled_links(puma):
    """The plant built on the Pinocchio model equals the one the control package builds from DH links."""
    s = mc.study(puma, runs=5, seed=2, duration=DURATION)
    rng = np.random.default_rng(0)
    for run in range(3):
        draw = s.draw(run)
        plant = s.plant(run)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
            ref = with_payload(with_scaled_inertia(s.arm, draw.scale), draw.payload_mass, draw.payload_com)
        q, qd, tau = s.arm.random_state(rng), rng.uniform(-1, 1, 6), rng.uniform(-20, 20, 6)
        fr = draw.friction[0] * qd + draw.friction[1] * np.sign(qd)
        expect = ref.forward_dynamics(q, qd, tau - fr)
        # two routes to the same arm (Pinocchio inertia algebra vs pseudo-inertias
        # through a new URDF): rounding only, ~1e-14 relative
        np.testing.assert_allclose(plant.forward_dynamics(q, qd, tau), expect, rtol=1e-10, atol=1e-10)


def test_urdf_arm_plant_matches_the_dh_arm():
    """A URDF arm travels as URDF text; its payload sits in the tip frame, the DH frame n."""
    dh = md.load("ur5")                       # no rotor inertia: its URDF is the same arm
    urdf_arm = md.load(md.to_urdf(dh))
    su = mc.study(urdf_arm, runs=3, seed=9, duration=DURATION)
    sd = mc.study(dh, runs=3, seed=9, duration=DURATION)
    assert su.model[0] == "urdf" and sd.model[0] == "toml"
    rng = np.random.default_rng(1)
    q, qd, tau = dh.random_state(rng), rng.uniform(-1, 1, 6), rng.uniform(-20, 20, 6)
    for run in range(3):
        np.testing.assert_allclose(su.plant(run).forward_dynamics(q, qd, tau),
                                   sd.plant(run).forward_dynamics(q, qd, tau), rtol=1e-10, atol=1e-10)


# -- runs, replay, aggregation ----------------------------------------------------------
@pytest.fixture(scope="module")
def small_report(puma):
    s = mc.study(puma, runs=6, seed=3, duration=DURATION)
    return mc.run(s, scheduler="sync", chunk_size=4)


def _replay_log(s, rec):
    """The log of ``rec``'s run replayed alone; a diverged run must diverge again (its log up to then)."""
    if rec["diverged"]:   # the replay diverges the same way; the figures cover its log
        with pytest.raises(SimulationDiverged) as info:
            s.replay(rec["run"], rec["controller"])
        return info.value.log
    return s.replay(rec["run"], rec["controller"])


def _replays_match(report):
    """Every record of ``report`` is what ``study.replay`` (one md.simulate) gives, bit for bit."""
    s = report.study
    for rec in report.per_run:
        log = _replay_log(s, rec)
        e = log.e
        assert rec["rms_error"] == float(np.sqrt(np.mean(np.einsum("ij,ij->i", e, e)))), rec
        assert rec["max_error"] == float(np.abs(e).max()), rec
        assert rec["peak_torque"] == float(np.abs(log.tau).max()), rec


def test_runs_stepped_together_diverge_and_saturate_as_alone(puma):
    """Chunks step their runs together (lockstep.py): diverged and saturated runs replay alike."""
    # the demo path squeezed into 0.5 s is too fast for the adaptive controller on some plants
    s = mc.study(puma, runs=6, seed=3, duration=0.5)
    report = mc.run(s, scheduler="sync", chunk_size=6)
    assert 0 < report.controllers["adaptive"]["diverged"] < 6
    _replays_match(report)
    s = mc.study(puma, runs=3, seed=3, duration=0.5, tau_max=150.0)
    report = mc.run(s, scheduler="sync", chunk_size=3)
    assert all(e["saturated"] == 3 for e in report.controllers.values())
    _replays_match(report)


def test_replay_gives_the_studys_numbers_bit_for_bit(small_report):
    _replays_match(small_report)
    s = small_report.study
    for rec in small_report.per_run[::5]:
        log = _replay_log(s, rec)
        e = log.e
        # the study's own formula (einsum), so that equality is bit for bit ...
        assert rec["rms_error"] == float(np.sqrt(np.mean(np.einsum("ij,ij->i", e, e))))
        # ... and the documented meaning: RMS over time of the norm of the error
        assert rec["rms_error"] == pytest.approx(np.sqrt(np.mean(np.linalg.norm(e, axis=1) ** 2)), rel=1e-14)
        assert rec["max_error"] == float(np.abs(e).max())
        assert rec["peak_torque"] == float(np.abs(log.tau).max())


def test_report_matches_the_per_run_records(small_report):
    doc = json.loads(small_report.to_json())
    assert doc["runs"] == 6 and doc["seed"] == 3
    assert [(r["run"], r["controller"]) for r in doc["per_run"]] == \
        [(k, c) for k in range(6) for c in mc.CONTROLLER_KEYS]
    for key, entry in doc["controllers"].items():
        vals = [r["rms_error"] for r in doc["per_run"] if r["controller"] == key and not r["diverged"]]
        assert entry["rms_error"]["max"] == max(vals)
        assert entry["rms_error"]["p50"] == float(np.percentile(vals, 50))
        assert entry["diverged"] == sum(r["diverged"] for r in doc["per_run"] if r["controller"] == key)
        assert entry["saturated"] == 0                        # the bundled Puma has no torque limits
        if not entry["diverged"]:
            assert entry["worst"][0]["rms_error"] == max(vals)
    # the adaptive controller learns the payload: better than computed torque on the wrong model
    c = doc["controllers"]
    assert c["adaptive"]["rms_error"]["p50"] < c["ct"]["rms_error"]["p50"] < c["pd"]["rms_error"]["p50"]


def test_chunking_does_not_change_the_report(puma, small_report):
    s = small_report.study
    other = mc.run(s, scheduler="sync", chunk_size=1)
    assert _without_timing(other.to_json()) == _without_timing(small_report.to_json())


def test_divergence_and_saturation_are_counted_not_failures(puma, capsys):
    rc = main(["montecarlo", "puma560", "--runs", "3", "--duration", "0.2", "--controllers", "pd,ct",
               "--scheduler", "sync", "--torque-noise", "1e7", "--json", "--no-progress"])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert all(e["diverged"] == 3 for e in doc["controllers"].values())
    assert doc["controllers"]["ct"]["rms_error"]["p50"] is None        # no finished run to describe
    rc = main(["montecarlo", "puma560", "--runs", "2", "--duration", "0.2", "--controllers", "ct",
               "--scheduler", "sync", "--tau-max", "1", "--json", "--no-progress"])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["controllers"]["ct"]["saturated"] == 2
    sigma = max(doc["study"]["bounds"]["noise"])          # the noise is sized to the joints' torques
    assert all(r["peak_torque"] <= 1 + 6 * sigma * 6 for r in doc["per_run"])   # limit + 6 sigma noise


@pytest.mark.parametrize("argv, match", [
    (["--controllers", "pd,xx"], "--controllers"),
    (["--runs", "0"], "--runs"),
    (["--dt", "1"], "--dt"),
    (["--link-scale", "1.5"], "link_scale"),
])
def test_cli_usage_errors_exit_2_with_one_line(argv, match, capsys):
    rc = main(["montecarlo", "puma560", "--scheduler", "sync", "--duration", "0.2", *argv])
    err = capsys.readouterr().err
    assert rc == 2 and match in err and err.count("\n") == 1


def test_missing_dask_says_what_to_install(puma, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)     # import distributed -> ImportError
    s = mc.study(puma, runs=1, duration=0.1)
    with pytest.raises(mc.MissingExtraError, match=r"pip install 'manipdyn\[scale\]'"):
        mc.run(s)
    assert len(mc.run(s, scheduler="sync").per_run) == len(mc.CONTROLLER_KEYS)   # in-process needs no Dask


def test_help_documents_the_default_distributions(capsys):
    with pytest.raises(SystemExit):
        main(["montecarlo", "--help"])
    out = capsys.readouterr().out
    for text in ("at most 0.2 tau_j on every joint", "1 + U(-0.2, 0.2)", "Coulomb U(0, 0.1 tau_j)", "N(0, 0.01 rad)",
                 "N(0, 0.01 tau_j)", "--payload-mass 2 --friction-viscous 0.5", "--scheduler", "--plot"):
        assert text in " ".join(out.split()), text


def test_plot_is_written(small_report, tmp_path):
    pytest.importorskip("matplotlib", reason="the plot extra is not installed")
    path = tmp_path / "cdf.png"
    mc.plot_report(small_report, str(path))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# -- cross-check in parts ------------------------------------------------------------------
def test_state_slices_are_rows_of_the_full_draw():
    arm = arms.random_arm(5)
    full = md.check.crosscheck.draw_states(arm, 1000, 7)
    part = md.check.crosscheck.draw_states(arm, 1000, 7, 250, 600)
    for a, b in zip(full, part):
        np.testing.assert_array_equal(a[250:600], b)


def test_crosscheck_in_parts_reports_what_a_local_run_reports(puma):
    arm = arms.random_arm(11, n=4)
    local = md.crosscheck(arm, samples=2300, seed=1, chunk=200)
    parts = md.crosscheck(arm, samples=2300, seed=1, chunk=200, scheduler="sync", workers=3)
    assert parts.to_json() == local.to_json()
    assert local["D"].worst_index != 0 or local["tau"].worst_index != 0   # indices were really merged
    # an arm with notes (the Puma's impossible link inertias): said once, as locally
    local = md.crosscheck(puma, samples=1200, seed=2, chunk=300)
    assert local.notes
    assert md.crosscheck(puma, samples=1200, seed=2, chunk=300, scheduler="sync", workers=2).to_json() \
        == local.to_json()


# -- a real Dask cluster ---------------------------------------------------------------------
def test_study_on_a_dask_cluster_is_bit_identical_to_a_local_run(tmp_path, capsys):
    argv = ["montecarlo", "puma560", "--runs", "40", "--seed", "11", "--duration", "0.5",
            "--controllers", "pd,ct", "--json", "--no-progress"]
    assert main(argv + ["--scheduler", "sync"]) == 0
    local = capsys.readouterr().out
    with dask_cluster(2) as (address, _):
        assert main(argv + ["--scheduler", address, "--chunk-size", "3"]) == 0
        remote = capsys.readouterr().out
        rc = main(["check", "ur5", "--samples", "1500", "--scheduler", address, "--json",
                   "--timing-calls", "0", "--no-progress"])
        check_remote = capsys.readouterr().out
    assert _without_timing(remote) == _without_timing(local)
    timing = json.loads(remote)["timing"]
    assert timing["workers"] == 2 and timing["chunks"] == 14 and len(timing["chunks_by_process"]) == 2
    assert rc == 0 and main(["check", "ur5", "--samples", "1500", "--json", "--timing-calls", "0",
                             "--no-progress"]) == 0
    assert check_remote == capsys.readouterr().out


def test_a_worker_killed_mid_study_loses_no_run_and_counts_none_twice(puma):
    s = mc.study(puma, runs=40, seed=5, duration=0.5, controllers=("pd", "ct"))
    local = mc.run(s, scheduler="sync")
    seen = []
    with dask_cluster(2) as (address, workers):
        victim = workers[0]

        def progress(done, total):
            seen.append(done)
            if done >= 4 and victim.poll() is None:     # a few chunks done, most still to come
                os.kill(victim.pid, signal.SIGKILL)
                victim.wait(timeout=10)

        report = mc.run(s, scheduler=address, chunk_size=2, progress=progress)
        assert victim.poll() is not None                      # it really died mid-study
    assert seen[-1] == 40 and seen == sorted(seen) and len(seen) == 20   # each chunk reported once
    assert [(r["run"], r["controller"]) for r in report.per_run] == \
        [(k, c) for k in range(40) for c in ("pd", "ct")]
    assert _without_timing(report.to_json()) == _without_timing(local.to_json())
    # every chunk came back once, from the survivor or from the victim before it died
    assert sum(report.timing["chunks_by_process"].values()) == 20


def test_study_takes_a_model_name_and_names_a_wrong_arm():
    """``study("puma560", ...)`` loads the bundled arm as the command line does; something that is
    not an arm is a ModelError naming the argument, not an AttributeError."""
    from manipdyn.control.montecarlo import study

    st = study("puma560", runs=2, seed=0, controllers=("pd",))
    assert st.arm.name == "puma560" and st.arm == md.load("puma560")
    with pytest.raises(md.ModelError, match=r"arm: cannot send int"):
        study(42, runs=2)


def test_a_stiff_plant_is_integrated_not_declared_diverged():
    """The UR5's last link (J = 1.3e-4 kg m^2) with a drawn viscous friction of 0.45 N m s has a mode
    at -b/J ~ -3400 1/s: one RK4 step of 1 ms (h |lambda| = 3.4 > 2.785) blows up within a few
    steps, for any controller.  The run's own plant asks for more steps per period
    (control/stiffness.py); the study then runs them, its numbers replay bit for bit, and the
    answer converges (four times as many steps move q by under 2 % of the tracking error)."""
    from manipdyn.control import simulate

    arm = md.load("ur5")
    s = mc.study(arm, runs=8, seed=1, controllers=("pd", "ct"), duration=0.3,
                 distributions=dataclasses.replace(mc.ABSOLUTE_DEFAULTS, payload_mass=0.0))
    setups = {run: s.setup(run, "pd") for run in range(8)}
    stiff = [run for run, st in setups.items() if st.substeps > 1]
    assert stiff and len(stiff) < 8, {run: st.substeps for run, st in setups.items()}
    blew_up = 0
    for run in stiff:
        kw = setups[run].simulate_kwargs()
        try:
            simulate(**{**kw, "substeps": 1})
        except SimulationDiverged:                         # the integrator, not the arm
            blew_up += 1
        log = simulate(**s.setup(run, "pd").simulate_kwargs())
        assert log.substeps == setups[run].substeps and np.abs(log.e).max() < 1.0
        # the sharp Coulomb sign makes the right-hand side jump at v = 0, so RK4 converges at first
        # order there: four times the steps move q by 0.1 to 1 % of the tracking error (measured),
        # where one step per period ran away
        fine = simulate(**{**s.setup(run, "pd").simulate_kwargs(), "substeps": 4 * log.substeps})
        assert np.abs(fine.q - log.q).max() < 0.02 * np.abs(log.e).max()
    # h rho past RK4's 2.785 (runs 3, 5, 6 of this seed) blows up in one step per period;
    # between 2.0 (SAFE_STEP) and 2.785 it does not yet: the margin
    assert blew_up >= 2
    report = mc.run(s, scheduler="sync", chunk_size=8)     # stiff and non-stiff runs in one chunk
    assert all(e["diverged"] == 0 for e in report.controllers.values())
    _replays_match(report)


def test_substeps_argument_and_the_cap_name_what_is_wrong():
    from manipdyn.control import simulate
    from manipdyn.control.stiffness import MAX_SUBSTEPS, rk4_substeps

    arm = md.load("ur5")
    s = mc.study(arm, runs=8, seed=1, controllers=("pd",), duration=0.3,
                 distributions=dataclasses.replace(mc.ABSOLUTE_DEFAULTS, payload_mass=0.0))
    kw = s.setup(6, "pd").simulate_kwargs()
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="substeps: expected an integer >= 1"):
            simulate(**{**kw, "substeps": bad})
    with pytest.raises(ValueError, match="substeps: at most 1000"):
        simulate(**{**kw, "substeps": 10**9})
    q = np.zeros((1, 6))
    m, rho = rk4_substeps(kw["plant"], q, q, q, 1e-3)
    assert m >= 2 and rho * 1e-3 / m <= 2.0
    with pytest.raises(ValueError, match=r"plant: its fastest mode .* over 1000"):
        rk4_substeps(kw["plant"], q, q, q, 2.0 * MAX_SUBSTEPS / rho * 1.5)
