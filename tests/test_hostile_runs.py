"""Issue 31, items 25 to 28 and 30 on RUNS.toml, payloads and plants drawn from a base model.

Each test builds the issue's reproducer (a RUNS.toml with a NUL in a path, 400-digit integers,
a payload of 1e20 kg or a com of 1e300 m, 35 000 entries against a lowered limit, one log
listed twice, an output that is a log the RUNS file lists, a base model whose covariance is
zero) and checks: exit 2 with one line naming the key and ``[[log]]``, the input intact, or a
ModelError naming the argument in the API.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

import manipdyn as md
from manipdyn import limits
from manipdyn.cli import main

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import excitation, write_measurements_csv  # noqa: E402
from manipdyn.identification.inputs.runs import LogSpec, Payload, as_log_specs, read_runs_file  # noqa: E402


from common import err_line


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    """A short UR5 log (t, q, tau) with 1 % torque noise."""
    arm = md.load("ur5")
    folder = tmp_path_factory.mktemp("runs")
    ex = excitation(arm, duration=4.0, harmonics=3, rate=100.0, iterations=0, seed=1)
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.01 * np.abs(tau).max(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)
    path = folder / "run1.csv"
    write_measurements_csv(path, ex.t, ex.q, tau)
    return path


def _runs(tmp_path, body: str):
    p = tmp_path / "RUNS.toml"
    p.write_text(body)
    return p


@pytest.mark.parametrize("entry, key", [
    ('path = "run\\u0000.csv"', "path"),
    ('path = "{log}"\nrate = 1' + "0" * 400, "rate"),
    ('path = "{log}"\nt_range = [0, 1' + "0" * 400 + "]", "t_range"),
    ('path = "{log}"\npayload = {{ mass = 1' + "0" * 400 + ", com = [0, 0, 0] }}", "payload"),
    ('path = "{log}"\npayload = {{ mass = 1e20, com = [0, 0, 0] }}', "payload"),
    ('path = "{log}"\npayload = {{ mass = 2, com = [1e300, 0, 0] }}', "payload"),
    ('path = "{log}"\npayload = {{ mass = 2, com = [0, 0, 0], inertia = [1e250, 1e250, 1e250, 0, 0, 0] }}',
     "payload"),
])
def test_hostile_runs_entries_are_one_line_naming_the_key(tmp_path, log, capsys, entry, key):
    """Issue 26: "in RUNS.toml: a NUL in a path; a 400-digit integer in rate, t_range or payload;
    a payload com or inertia of 1e200 to 1e308 (LinAlgError)"; issue 28: "RUNS payloads of 1e20
    kg are scored, with exit 0"."""
    runs = _runs(tmp_path, "[[log]]\n" + entry.format(log=log) + "\n")
    code = main(["identify", "ur5", "--logs", str(runs), "--method", "ols", "-o", str(tmp_path / "o.toml")])
    line = err_line(capsys)
    assert code == 2 and "[[log]] 1" in line and key in line and "internal error" not in line, line


def test_runs_entry_count_is_capped_before_any_log_is_read(tmp_path, log, capsys, monkeypatch):
    """Issue 27: "RUNS.toml with 35,000 [[log]] entries passes 120 s at 4.4 GB" (against a
    lowered limit: the cap, not the size, is what is tested)."""
    monkeypatch.setattr(limits, "MAX_RUNS", 20)
    runs = _runs(tmp_path, "".join(f'[[log]]\npath = "{log}"\nt_range = [0, {1 + k * 1e-3}]\n' for k in range(21)))
    assert main(["identify", "ur5", "--logs", str(runs), "--method", "ols", "-o", str(tmp_path / "o.toml")]) == 2
    line = err_line(capsys)
    assert "MAX_RUNS" in line and "21" in line, line
    assert not (tmp_path / "o.toml").exists()


def test_the_same_log_twice_is_refused_not_counted_twice(tmp_path, log, capsys):
    """Issue 28: "the same log given k times (same sha256) shrinks the standard deviations by √k,
    with no note" (here under two names: a copy)."""
    copy = tmp_path / "copy.csv"
    copy.write_bytes(log.read_bytes())
    runs = _runs(tmp_path, f'[[log]]\npath = "{log}"\n[[log]]\npath = "copy.csv"\n')
    assert main(["identify", "ur5", "--logs", str(runs), "--method", "ols", "-o", str(tmp_path / "o.toml")]) == 2
    line = err_line(capsys)
    assert "same data" in line and "sqrt(2)" in line, line
    # two windows of one file are two runs
    runs = _runs(tmp_path, f'[[log]]\npath = "{log}"\nt_range = [0, 2]\n[[log]]\npath = "{log}"\nt_range = [2, 4]\n')
    assert main(["identify", "ur5", "--logs", str(runs), "--method", "ols", "-o", str(tmp_path / "o.toml")]) in (0, 1)


@pytest.mark.parametrize("option", ["--base-json", "--predictions", "link"])
def test_logs_listed_in_runs_are_inputs_of_the_output_checks(tmp_path, log, capsys, option):
    """Issue 25: "logs listed inside RUNS.toml are not treated as inputs, so --base-json and
    --predictions (or a symlink to them) overwrite them, with exit 0"."""
    mine = tmp_path / "mine.csv"
    mine.write_bytes(log.read_bytes())
    before = mine.read_bytes()
    runs = _runs(tmp_path, '[[log]]\npath = "mine.csv"\n')
    if option == "--predictions":
        argv = ["validate", "ur5", "--logs", str(runs), "--predictions", str(mine)]
    else:
        target = mine
        if option == "link":
            target = tmp_path / "link.json"
            target.symlink_to(mine)
        argv = ["identify", "ur5", "--logs", str(runs), "--method", "ols", "-o", str(tmp_path / "o.toml"),
                "--base-json", str(target)]
    assert main(argv) == 2
    line = err_line(capsys)
    assert "would overwrite [[log]] 1 of" in line, line
    assert mine.read_bytes() == before


def test_payload_and_logspec_refuse_nonsense_by_name(tmp_path):
    """Issue 30: "Payload(mass=-3) and torque_constant_reference=[1.9] are accepted"; "LogSpec,
    Payload and logs=5 raise type errors that are not manipdyn's"."""
    for kw, name in [({"mass": -3, "com": (0, 0, 0)}, "mass"), ({"mass": "2", "com": (0, 0, 0)}, "mass"),
                     ({"mass": 2, "com": 5}, "com"), ({"mass": 2, "com": (0, 0)}, "com"),
                     ({"mass": 1e20, "com": (0, 0, 0)}, "MAX_PAYLOAD_MASS"),
                     ({"mass": 2, "com": (0, 0, 0), "inertia": None}, "inertia")]:
        with pytest.raises(md.ModelError, match=name):
            Payload(**kw)
    for kw, name in [({"path": 5}, "path"), ({"path": "a.csv", "t_range": (10,)}, "t_range"),
                     ({"path": "a.csv", "t_range": (0, "a")}, "t_range"), ({"path": "a.csv", "rate": "200"}, "rate"),
                     ({"path": "a.csv", "payload": 3}, "payload"), ({"path": "a\x00.csv"}, "path")]:
        with pytest.raises(md.ModelError, match=name):
            LogSpec(**kw)
    with pytest.raises(md.ModelError, match=r"^logs: expected"):
        as_log_specs(5)
    with pytest.raises(md.ModelError, match=r"^logs: expected"):
        md.identify("ur5", 5, method="ols")


def test_a_non_integer_reference_motor_is_refused(tmp_path, log):
    """``torque_constant_reference=[1.9]`` was motor 1 (int(1.9))."""
    for ref in ([1.9], [0], [7], "1", [True]):
        with pytest.raises(md.ModelError, match="torque_constant_reference: expected motor numbers"):
            md.identify("ur5", str(log), method="ols", identify_torque_constants=True,
                        torque_constant_reference=ref)


def test_plants_from_a_zero_covariance_is_refused_by_name(tmp_path, log, capsys):
    """Issue 26: "--plants-from with an all-zero covariance (SCS allocation error)"."""
    base = tmp_path / "b.base.json"
    assert main(["identify", "ur5", str(log), "--method", "wls", "-o", str(tmp_path / "o.toml"),
                 "--base-json", str(base)]) in (0, 1)
    capsys.readouterr()
    data = json.loads(base.read_text())
    assert data.get("covariance") is not None
    k = len(data["covariance"])
    data["covariance"] = [[0.0] * k for _ in range(k)]
    base.write_text(json.dumps(data))
    code = main(["montecarlo", "ur5", "--plants-from", str(base), "--runs", "2", "--duration", "0.2",
                 "--scheduler", "sync"])
    line = err_line(capsys)
    assert code == 2 and "covariance" in line and "no spread" in line, line


def test_joint_names_option_is_a_list_not_letters(tmp_path, log, capsys):
    """Issue 28: "--joint-names in identify and validate is read as a raw string: abcdef becomes
    joints a to f"."""
    from manipdyn.cli.logopts import library_options
    from manipdyn.cli import build_parser as parser

    args = parser().parse_args(["validate", "ur5", str(log), "--joint-names", "a,b,c,d,e,f"])
    from manipdyn.identification import validate

    assert library_options(args, validate)["joint_names"] == ["a", "b", "c", "d", "e", "f"]
    with pytest.raises(md.ModelError, match=r"joint_names: expected a list of 6 names"):
        md.identify("ur5", str(log), method="ols", joint_names="abcdef")


def test_a_signal_given_twice_in_columns_is_refused(tmp_path, log, capsys):
    """Issue 28: "a duplicate key in --columns is accepted" (the later one silently won)."""
    assert main(["validate", "ur5", str(log), "--columns", "q=q{i},q=x{i}"]) == 2
    line = err_line(capsys)
    assert "columns" in line and "'q' given twice" in line, line


def test_validate_refuses_degrees_as_identify_does(tmp_path, log, capsys):
    """Issue 28: "validate ur5 deg.csv scores degrees as radians (RMS 4603 N m) where identify
    catches them"."""
    text = log.read_text().splitlines()
    head = text[0].split(",")
    qcols = [k for k, h in enumerate(head) if h.startswith("q")]
    rows = []
    for row in text[1:]:
        cells = row.split(",")
        for k in qcols:
            cells[k] = repr(float(cells[k]) * 180 / np.pi)
        rows.append(",".join(cells))
    deg = tmp_path / "deg.csv"
    deg.write_text("\n".join([text[0]] + rows) + "\n")
    assert main(["validate", "ur5", str(deg)]) == 2
    line = err_line(capsys)
    assert "outside the model's joint limits" in line and "--deg" in line, line
    assert main(["validate", "ur5", str(deg), "--deg"]) == 0


def test_two_models_of_one_name_keep_a_row_each(tmp_path, log):
    """Issue 28: "two models with the same name keep one row in validate's per-log table"."""
    arm = md.load("ur5")
    heavier = md.load("ur5")
    a, b = tmp_path / "a" / "ur5.toml", tmp_path / "b" / "ur5.toml"
    a.parent.mkdir()
    b.parent.mkdir()
    md.save(arm, str(a))
    md.save(heavier, str(b))
    res = md.validate([str(a), str(b)], str(log))
    names = [r.model for r in res.results]
    assert len(set(names)) == 2, names


@pytest.mark.parametrize("kt", ["0", "-0.5", "1e59"])
def test_a_torque_constant_out_of_range_is_refused_by_name(tmp_path, kt):
    """Issue 26: "a k_t of 0 or 1e59 in the prior ... a negative k_t" (crashed the fit)."""
    text = md.to_toml(md.load("ur5"))
    assert "[transmission]" not in text
    model = tmp_path / "m.toml"
    model.write_text(text + f"\n[transmission]\ntorque_constant = [{', '.join([kt] * 6)}]\n")
    with pytest.raises(md.ModelError, match=r"torque_constant.*MAX_TORQUE_CONSTANT"):
        md.load(str(model))


def test_undetermined_torque_constants_are_not_written(tmp_path, capsys):
    """Issue 28: "the README's own kt/RUNS.toml with default options writes torque_constant =
    [994632, ..., 1.25e16], with only a note" (a shorter set: 8 s runs)."""
    from manipdyn.identification.experiments.hardlog import hard_log_set

    paths = hard_log_set(0, tmp_path, duration=8.0)
    out = tmp_path / "id.toml"
    code = main(["identify", paths["prior"], "--logs", paths["runs"], "-o", str(out),
                 "--identify-torque-constants", "--method", "ols"])
    cap = capsys.readouterr()
    if code == 2:
        assert "not determined" in cap.err and "motor(s)" in cap.err, cap.err
        assert not out.exists()
    else:     # every motor determined: what is written must be finite and within the limit
        kt = md.load(str(out)).transmission.torque_constant
        assert np.all(np.isfinite(kt)) and np.all(kt <= limits.MAX_TORQUE_CONSTANT)


def test_a_carried_fitted_range_of_1e308_is_refused_by_name():
    """Issue 26: "a carried fitted_range of ±1e308" (its bounds, rounded outwards for the model
    file's [sources], overflowed: OverflowError, exit 3)."""
    from manipdyn.identification import StateRange

    good = {"q": [[-1.0, 1.0]] * 6, "qd": [[-2.0, 2.0]] * 6, "tau": [[-50.0, 50.0]] * 6}
    assert "q (rad)" in StateRange.from_dict(good, 6, "fitted_range").to_text()
    for bound in (1e308, -1e308, 1e10):
        bad = dict(good, q=[[min(0.0, bound), max(0.0, bound)]] * 6)
        with pytest.raises(md.ModelError, match=r"^fitted_range: .*MAX_SIGNAL"):
            StateRange.from_dict(bad, 6, "fitted_range")


def test_a_silent_scheduler_is_not_blamed_on_the_output(tmp_path, log, capsys, monkeypatch):
    """Issue 28: "a silent scheduler is blamed on -o" ("OUT.toml: cannot write: scheduler ...")."""
    pytest.importorskip("distributed")
    import socket

    monkeypatch.setattr(limits, "MAX_SCHEDULER_WAIT_S", 1.0)     # the wait itself is not what is tested
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)
    try:
        code = main(["identify", "ur5", str(log), "--method", "ols", "-o", str(tmp_path / "o.toml"),
                     "--bootstrap", "4", "--scheduler", f"tcp://127.0.0.1:{srv.getsockname()[1]}"])
    finally:
        srv.close()
    line = err_line(capsys)
    assert code == 2 and "--scheduler" in line and "cannot write" not in line, line


def test_zero_velocities_from_a_driver_are_not_trusted(tmp_path, capsys):
    """Issue 28: "zero velocities from a driver are trusted" (a qd column of zeros while q moves)."""
    arm = md.load("ur5")
    ex = excitation(arm, duration=4.0, harmonics=3, rate=100.0, iterations=0, seed=2)
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    qd = np.array(ex.qd)
    qd[:, 2] = 0.0
    path = tmp_path / "zeros.csv"
    write_measurements_csv(path, ex.t, ex.q, tau, qd=qd)
    assert main(["identify", "ur5", str(path), "--method", "ols", "-o", str(tmp_path / "o.toml")]) == 2
    line = err_line(capsys)
    assert "qd3" in line and "zero" in line, line
    # the true velocities are read as they are
    write_measurements_csv(path, ex.t, ex.q, tau, qd=ex.qd)
    m = md.identification.read_log(str(path), arm.n)
    assert m.measured_qd
