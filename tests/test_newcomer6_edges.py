"""Issue 46 (a newcomer, round six): numbers at the edges, and what a command says it did.

Items 5 (a contact that never happens), 23 (exit 3 on edge numbers), 26 (a velocity cut-off that
is no frequency), 29 (the API's edges).  Each case: exit 2 with one line, or a ModelError, never
exit 3 or a traceback.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main


@pytest.fixture(scope="module")
def traj(tmp_path_factory):
    """A 4 s UR5 excitation trajectory at 250 Hz (what synthesize reads)."""
    d = tmp_path_factory.mktemp("traj")
    path = d / "traj.csv"
    assert main(["excite", "ur5", "-o", str(path), "--period", "4", "--rate", "250", "--iterations", "1",
                 "--ramp", "0"]) == 0
    return d, path


def _one_line_error(capsys, code, *words):
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err and "internal error" not in err, err
    for w in words:
        assert w in err, err
    return err


# -- 5. a contact that never happens ----------------------------------------------------------------
def test_item5_a_contact_after_the_trajectory_is_refused(traj, capsys):
    """Issue 46 item 5: ``synthesize --contact 5:6:...`` on a 4 s trajectory reported "1 contact(s)"
    that never happens; now refused, naming the trajectory's span, nothing written."""
    d, path = traj
    out = d / "push.csv"
    code = main(["synthesize", "ur5", str(path), "-o", str(out), "--contact", "5:6:0,0,-30"])
    _one_line_error(capsys, code, "--contact 5:6", "acts at no sample")
    assert not out.exists() and not (d / "push.contacts.json").exists()
    assert main(["synthesize", "ur5", str(path), "-o", str(out), "--contact", "1:2:0,0,-30"]) == 0
    assert "1 contact(s)" in capsys.readouterr().out


# -- 23. a superscript digit as the contact's link ----------------------------------------------------
def test_item23_a_superscript_digit_link_is_a_usage_error(traj, capsys):
    d, path = traj
    code = main(["synthesize", "ur5", str(path), "-o", str(d / "x.csv"), "--contact", "1:2:0,0,-30@\u00b2"])
    _one_line_error(capsys, code, "LINK")


# -- 29. synthesize writes torques its own readers refuse ------------------------------------------
def test_item29_synthesize_refuses_torques_its_readers_refuse():
    """1e307 N m torques were written; the log readers refuse anything over limits.MAX_SIGNAL."""
    from manipdyn._support import limits
    from manipdyn.identification.experiments.synthesize import synthesize

    arm = md.load("ur5")
    q = np.zeros((3, 6))
    qdd = np.full((3, 6), 1e150)                # torques ~1e150 N m: finite, beyond any reader
    with pytest.raises(md.ModelError, match="MAX_SIGNAL"):
        synthesize(arm, q, q, qdd)
    ok = synthesize(arm, q, q, np.ones((3, 6)))
    assert np.all(np.abs(ok) <= limits.MAX_SIGNAL)


# -- 23. replay --every beyond any log; integers of over 4300 digits --------------------------------
def _log_of(tmp_path):
    from test_bands import _log

    path = tmp_path / "log.csv"
    _log(path, md.load("ur5"), 13)
    return path


def test_item23_replay_every_beyond_any_log_is_a_usage_error(tmp_path, capsys):
    log = _log_of(tmp_path)
    _one_line_error(capsys, main(["replay", "ur5", str(log), "--every", "999999999999999999999"]), "every")


def test_item23_an_integer_of_over_4300_digits_is_a_usage_error(tmp_path, capsys):
    """Python refuses to convert an integer of more than 4300 digits with a bare ValueError, which
    tomllib passes on: every command reading a model file or a RUNS.toml ended in exit 3."""
    log = _log_of(tmp_path)
    big = "1" * 4400
    model = tmp_path / "big.toml"
    model.write_text(md.to_toml(md.load("ur5")).replace("[[links]]", f"[[links]]\nmass = {big}", 1))
    for argv in (["check", str(model)], ["validate", str(model), str(log)], ["urdf", str(model), str(tmp_path / "o")]):
        _one_line_error(capsys, main(argv), "4400 digits")
    runs = tmp_path / "RUNS.toml"
    runs.write_text(f'[[log]]\npath = "{log.name}"\nrepeat = {big}\n')
    _one_line_error(capsys, main(["validate", "ur5", "--logs", str(runs)]), "4400 digits", "RUNS.toml")
    with pytest.raises(md.ModelError, match="4400 digits"):
        md.load(str(model))


# -- 29. the API's edges -----------------------------------------------------------------------------
def test_item29_a_model_file_with_a_byte_order_mark_loads(tmp_path):
    """A model file some editor saved with a BOM got "not valid TOML: Invalid statement (at line 1,
    column 1)"; the BOM is skipped, as TOML readers commonly do."""
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + md.to_toml(md.load("ur5")).encode("utf-8"))
    arm = md.load(str(path))
    q = np.linspace(0.1, 0.6, 6)
    assert np.allclose(arm.inverse_dynamics(q, q, q), md.load("ur5").inverse_dynamics(q, q, q))


def test_item29_replay_substeps_is_bounded(tmp_path):
    """``md.replay(..., substeps=10**6)`` ran for about an hour; the whole replay's integration steps are
    bounded by limits.MAX_REPLAY_STEPS, refused before any step."""
    log = _log_of(tmp_path)
    with pytest.raises(md.ModelError, match="MAX_REPLAY_STEPS"):
        md.replay("ur5", str(log), substeps=10**6)


# -- 26. identify --velocity-cutoff that is no frequency ------------------------------------------
@pytest.mark.parametrize("value", ["-1", "nan", "inf", "1e300", "1e-300"])
def test_item26_a_bad_velocity_cutoff_is_refused_before_the_fit(tmp_path, capsys, value):
    """Issue 46 item 26: ``identify --velocity-cutoff -1`` (nan, inf, 1e300) ran the whole fit, exited 0
    and wrote a model without thresholds, the reason on stdout only; 1e-300 Hz wrote 6e-12 N m
    thresholds.  Refused in one line before the log is read: no model written."""
    log = _log_of(tmp_path)
    out = tmp_path / "m.toml"
    code = main(["identify", "ur5", str(log), "-o", str(out), f"--velocity-cutoff={value}"])
    _one_line_error(capsys, code, "--velocity-cutoff")
    assert not out.exists()


# -- 27. MuJoCo's own voice -----------------------------------------------------------------------
def test_item27_mujocos_warnings_are_python_warnings_and_no_log_file(tmp_path, monkeypatch):
    """Issue 46 item 27: ``replay --simulator mujoco`` printed hundreds of raw ``WARNING: ...`` lines and
    left ``./MUJOCO_LOG.TXT``.  Once manipdyn has imported MuJoCo (mujoco_module), MuJoCo's warnings
    are MuJoCoWarning (a ModelNoteWarning), "Time = ..." dropped so that repeats are one, and no log
    file is written."""
    pytest.importorskip("mujoco", reason="the mujoco extra is not installed")
    from manipdyn.engines.mujoco.deps import MuJoCoWarning, mujoco_module

    monkeypatch.chdir(tmp_path)
    mujoco = mujoco_module()
    xml = ('<mujoco><worldbody><body><joint type="hinge" axis="0 0 1"/>'
           '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body></worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = np.nan                  # MuJoCo warns "Nan, Inf or huge value in QPOS"
    with pytest.warns(MuJoCoWarning, match=r"^MuJoCo: Nan, Inf or huge value in QPOS") as caught:
        mujoco.mj_step(m, d)
    assert not any("Time =" in str(w.message) for w in caught)
    assert issubclass(MuJoCoWarning, md.ModelNoteWarning)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


# -- 28. raw control characters ---------------------------------------------------------------------
def test_item28_control_characters_of_a_file_name_never_reach_stdout_or_a_page(tmp_path, capsys):
    """Issue 46 item 28: ESC, C1 controls and U+202E from log file names, model names and a record's
    source reached stdout and the HTML pages.  Both go through one escaper (_support/text.visible)."""
    pytest.importorskip("matplotlib", reason="the report's figures need the plot extra")
    from test_bands import _log

    from manipdyn._support.text import visible

    log = _log_of(tmp_path)
    evil = tmp_path / "ev\x1b[31mil\x9b\u202eX.csv"
    _log(evil, md.load("ur5"), 14)
    page = tmp_path / "ev.html"
    assert main(["validate", "ur5", str(evil), str(log), "--report", str(page)]) == 0
    out = capsys.readouterr().out
    assert "ev\\x1b[31mil\\x9b\\u202eX.csv" in out
    for raw in ("\x1b", "\x9b", "\u202e"):
        assert raw not in out and raw not in page.read_text(encoding="utf-8")
    assert visible("a\tb\nc\x1b", keep="\n\t") == "a\tb\nc\\x1b"


def test_item29_a_complex_q_is_refused_not_cut_to_its_real_part():
    """Issue 46 item 29: a complex ``q`` was cut to its real part in silence (numpy only warns when it
    casts); the trajectories refuse it by name, as the arm's own calls do."""
    from manipdyn.control.trajectory import Quintic, Sampled, ViaPoints

    z = np.zeros(6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # a ComplexWarning would be the old silent cast
        for make, name in ((lambda: Quintic(z + 0.1j, z, 1.0), "q0"),
                           (lambda: Sampled(np.arange(3.0), np.zeros((3, 6)) + 1j), "q"),
                           (lambda: Quintic([0.0, 1j], [0.0, 0.0], 1.0), "q0")):
            with pytest.raises(ValueError, match=rf"{name}: expected real numbers, got a complex"):
                make()
        with pytest.raises(md.StateError, match="complex"):
            md.load("ur5").inverse_dynamics(z + 1j, z, z)
    assert np.allclose(Quintic(z, z + 1, 1.0)(0.5)[0], 0.5)


@pytest.mark.parametrize("dt", [0, 0.0, -1e-3, float("nan"), float("inf"), "x", True])
def test_item29_fit_thresholds_refuses_a_period_that_is_none(dt):
    """``fit_thresholds(dt=0)`` raised ZeroDivisionError."""
    from manipdyn.identification.uncertainty.thresholds import fit_thresholds

    r = np.random.default_rng(0).standard_normal((500, 2)) * 0.01
    with pytest.raises(md.ModelError, match="dt: expected the sample period"):
        fit_thresholds(r, dt)


def _massless_last(tmp_path, rotor: bool):
    """The UR5 whose last link has no mass and no inertia, with (or without) a rotor on its joint."""
    import re

    text = md.to_toml(md.load("ur5"))
    i = text.rindex("[[links]]")
    last = re.sub(r"\nmass = [^\n]*", "\nmass = 0.0" + ("\nmotor_inertia = 0.001\ngear_ratio = 1.0" if rotor else ""),
                  text[i:])
    last = re.sub(r"\ninertia = [^\n]*", "\ninertia = [0.0, 0.0, 0.0]", last)
    last = re.sub(r"\ncom = [^\n]*", "\ncom = [0.0, 0.0, 0.0]", last)
    path = tmp_path / ("rotor.toml" if rotor else "bare.toml")
    path.write_text(text[:i] + last)
    return path


def test_item29_montecarlo_in_mujoco_takes_a_massless_last_link_with_a_rotor(tmp_path, capsys):
    """``montecarlo --simulator mujoco`` refused a valid arm whose last link is massless (its zero
    tensor, rebuilt through sums, came back as diag(0, 1e-19, -1e-19): "a negative principal moment");
    without a rotor the arm is not simulable, and that is said (it was exit 3, "kd: must be > 0")."""
    pytest.importorskip("mujoco", reason="the mujoco extra is not installed")
    pytest.importorskip("dask", reason="montecarlo runs on dask (the scale extra)")
    from manipdyn.model.links import DHLink  # noqa: F401  (the module whose check was at rounding level)

    code = main(["montecarlo", str(_massless_last(tmp_path, True)), "--runs", "1", "--simulator", "mujoco",
                 "--workers", "1"])
    err = capsys.readouterr().err
    assert code in (0, 1), err
    assert "negative principal moment" not in err
    code = main(["montecarlo", str(_massless_last(tmp_path, False)), "--runs", "1", "--workers", "1"])
    _one_line_error(capsys, code, "singular", "joint(s) [6]")


def test_the_escaping_writer_left_over_a_closed_stream_writes_to_the_process_stdout():
    """The CLI's stdout wrapper (issue 46 item 28) left in place over a capture since closed (seen in one pytest
    call: test_newcomer4_reach then test_newcomer's demo) raised 'I/O operation on closed file' in a later
    print; it writes to the process's own stdout instead."""
    import io

    from manipdyn._support.text import EscapingWriter

    buf = io.StringIO()
    w = EscapingWriter(buf)
    assert w.write("a\x1bb\n") == 4 and buf.getvalue() == "a\\x1bb\n"
    buf.close()
    assert w.write("after\n") == 6          # no ValueError
