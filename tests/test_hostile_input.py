"""Issue 27, items 1 to 3 and 17 to 25: exit 3 and silent drops, hostile input on the newest surfaces.

One test (or one parametrised family) per finding, named after it.  Each builds the
reproducer of the issue (a log with one bad time stamp, a hostile base-model JSON, an
output that is an input, ...) and checks the outcome: exit 2 with one line on stderr
naming the option, key, column or limit, the input left intact, or a right answer.
Item 19's bootstrap of a billion replicates and item 17's 8.9 GiB grid are reproduced
against a lowered limit (``monkeypatch`` on :mod:`manipdyn.limits`), never at full size.
"""

from __future__ import annotations

import copy
import http.server
import json
import os
import threading
import time

import numpy as np
import pytest

import manipdyn as md
from manipdyn import limits
from manipdyn.cli import main

pytest.importorskip("scipy")


from common import err_line


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """A UR5 log with exact torques of the bare arm (qd, qdd measured), its trajectory, and a
    wls base model identified from it."""
    d = tmp_path_factory.mktemp("hostile")
    assert main(["excite", "ur5", "--iterations", "0", "--duration", "4", "--rate", "200", "--ramp", "0",
                 "-o", str(d / "traj.csv")]) == 0          # one 4 s period, no ramps: the sizes below count it
    assert main(["synthesize", "ur5", str(d / "traj.csv"), "-o", str(d / "data.csv"), "--derivatives",
                 "--noise", "0"]) == 0
    assert main(["identify", "ur5", str(d / "data.csv"), "--method", "wls", "-o", str(d / "id.toml"),
                 "--base-json", str(d / "id.json")]) == 0
    return d


def rows(path):
    return path.read_text().splitlines()


def write_rows(path, lines):
    path.write_text("\n".join(lines) + "\n")
    return path


def with_cell(src, dst, row: int, column: str, value: str):
    lines = rows(src)
    k = lines[0].split(",").index(column)
    cells = lines[row].split(",")
    cells[k] = value
    lines[row] = ",".join(cells)
    return write_rows(dst, lines)


MC = ["montecarlo", "puma560", "--runs", "1", "--duration", "0.03", "--scheduler", "sync"]


# -- 1. exit 3 in montecarlo: a plant too stiff for the step ------------------------------------
def test_stiff_montecarlo_plant_runs_with_the_implicit_step_and_says_so(capsys):
    """A plant too stiff for RK4 (viscous friction 1e6) exited 3, then 2; since issue 44 item 5 it is stepped by
    the Rosenbrock step with the friction implicit, and each run's record names the integrator."""
    assert main(MC + ["--friction-viscous", "1e6"]) == 0
    out = capsys.readouterr().out
    assert "Rosenbrock" in out


# -- 2. --plants-from silently dropped --payload-mass and --link-scale ---------------------------
def test_plants_from_refuses_the_options_it_replaces(logs, capsys):
    argv = ["montecarlo", "ur5", "--plants-from", str(logs / "id.json"), "--runs", "1", "--duration", "0.03",
            "--scheduler", "sync"]
    assert main(argv + ["--payload-mass", "1", "--link-scale", "0.5"]) == 2
    assert err_line(capsys).startswith("manipdyn montecarlo: error: --payload-mass, --link-scale: not with --plants-from")
    assert main(argv + ["--json"]) == 0                        # without them: the identification's draws
    from manipdyn.control.montecarlo import Distributions, load_identified, study

    with pytest.raises(md.ModelError, match="distributions: payload_mass, link_scale.* must be 0 with plants="):
        study(md.load("ur5"), 1, plants=load_identified(logs / "id.json"),
              distributions=Distributions(payload_mass=1.0))


# -- 3. no payload is an answer ------------------------------------------------------------------
def test_payload_on_bare_arm_data_is_a_mass_near_zero(logs, capsys):
    assert main(["identify", "ur5", str(logs / "data.csv"), "--payload", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    # exact torques of the bare arm: the payload is nothing, to within its standard deviation
    # (the solver keeps J >= EPS I, so the mass is EPS-sized, not exactly 0)
    assert rep["mass_std"] is not None and 0 < rep["mass_std"] < 1e-3
    assert abs(rep["mass"]) <= max(3 * rep["mass_std"], 1e-6)
    assert any("no payload is seen" in n for n in rep["notes"])


# -- 17. a grid decided by one bad time stamp ----------------------------------------------------
@pytest.mark.parametrize("stamp", ["1e5", "1e308"])
def test_one_bad_time_stamp_is_refused_before_the_grid(logs, tmp_path, capsys, monkeypatch, stamp):
    monkeypatch.setattr(limits, "MAX_GRID_VALUES", 1_000_000)   # the bad grid of 1e5 s: 4.8e8 values
    n = len(rows(logs / "data.csv")) - 1
    bad = with_cell(logs / "data.csv", tmp_path / "bad.csv", n, "t", stamp)
    t0 = time.perf_counter()
    assert main(["validate", "ur5", str(bad)]) == 2
    line = err_line(capsys)
    assert time.perf_counter() - t0 < 20
    assert "MAX_GRID_VALUES" in line and f"largest gap is" in line and f"row {n + 1}" in line


def test_a_bag_whose_last_stamp_jumps_is_refused_before_the_grid(tmp_path, monkeypatch):
    pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
    from rosbags.rosbag2 import StoragePlugin, Writer
    from manipdyn.identification import read_log
    from tests.test_rosbag import HEADER, JOINTS, JS, START, TIME, TS

    monkeypatch.setattr(limits, "MAX_GRID_VALUES", 1_000_000)
    t = np.arange(0, 4.0, 1 / 250)
    t[-1] = 1e5                                       # the last header stamp jumps by a day
    with Writer(tmp_path / "bag", version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/joint_states", JS.__msgtype__, typestore=TS)
        for k, tk in enumerate(t):
            ns = START + int(round(tk * 1e9))
            q = [0.1 * np.sin(tk + k * 1e-3), 0.2 * np.cos(tk)]
            msg = JS(header=HEADER(stamp=TIME(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""), name=JOINTS,
                     position=np.array(q), velocity=np.zeros(2), effort=np.array([1.0 + q[0], 2.0]))
            w.write(conn, ns, TS.serialize_cdr(msg, JS.__msgtype__))
    with pytest.raises(md.ModelError, match=r"largest gap is 99996 s before row 1000 .*MAX_GRID_VALUES"):
        read_log(tmp_path / "bag", 2, joint_names=JOINTS)


def test_resample_far_above_the_rate_is_refused_naming_it(logs, capsys, monkeypatch):
    monkeypatch.setattr(limits, "MAX_GRID_VALUES", 1_000_000)   # 4 s at 100 kHz: 4e5 samples x 24 values
    assert main(["validate", "ur5", str(logs / "data.csv"), "--resample", "1e7"]) == 2
    assert "resample= (--resample) 1e+07 Hz" in err_line(capsys)
    assert main(["validate", "ur5", str(logs / "data.csv"), "--resample", "1e5"]) == 2
    line = err_line(capsys)
    assert "resample=100000 Hz over the log's 3.995 s gives 4e+05 samples of 24 values" in line
    assert "MAX_GRID_VALUES" in line


# -- 18. what a fit holds ------------------------------------------------------------------------
def test_fit_size_is_capped_before_the_regressor(logs, monkeypatch):
    from manipdyn.identification import fit, read_log

    arm = md.load("ur5")
    data = read_log(logs / "data.csv", arm.n)
    monkeypatch.setattr(limits, "MAX_FIT_ENTRIES", 1e5)     # 800 samples x 6 x 60 = 2.9e5 entries
    with pytest.raises(md.ModelError, match=r"800 samples x 6 joints x 60 parameters .*MAX_FIT_ENTRIES\): fit "
                                            r"at most 277 samples"):
        fit(arm, data.q, data.qd, data.qdd, data.tau, method="wls")


# -- 19. unbounded options -----------------------------------------------------------------------
def test_bootstrap_count_is_capped_before_the_fit(logs, capsys):
    t0 = time.perf_counter()
    assert main(["identify", "ur5", str(logs / "data.csv"), "-o", str(logs / "b.toml"),
                 "--bootstrap", "1000000000"]) == 2
    assert "--bootstrap" in err_line(capsys) and time.perf_counter() - t0 < 10
    assert not (logs / "b.toml").exists()


@pytest.mark.parametrize("address", ["inproc://x", "tls://127.0.0.1:1", "ucx://127.0.0.1:1", "ws://h:1",
                                     "tcp://a b:1"])
def test_scheduler_that_is_not_tcp_is_refused(address, capsys):
    assert main(MC[:-2] + ["--scheduler", address]) == 2
    assert "--scheduler" in err_line(capsys)


def test_port_that_is_not_dask_times_out(logs, tmp_path, monkeypatch, capsys):
    pytest.importorskip("distributed")

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *a):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    monkeypatch.setattr(limits, "MAX_SCHEDULER_WAIT_S", 2.0)
    address = f"tcp://127.0.0.1:{server.server_address[1]}"
    try:
        t0 = time.perf_counter()
        code = main(MC[:-2] + ["--scheduler", address])
        took = time.perf_counter() - t0
        assert code == 2 and took < 15
        assert "no Dask scheduler answered in 2 s" in err_line(capsys)
        boot = main(["identify", "ur5", str(logs / "data.csv"), "-o", str(tmp_path / "b.toml"), "--method", "wls",
                     "--bootstrap", "2", "--scheduler", address])
    finally:
        server.shutdown()
        server.server_close()
    assert boot == 2 and "no Dask scheduler answered in 2 s" in err_line(capsys)


def test_prior_weight_is_bounded(logs, capsys):
    assert main(["identify", "ur5", str(logs / "data.csv"), "-o", str(logs / "w.toml"),
                 "--prior-weight", "1e308"]) == 2
    assert "--prior-weight" in err_line(capsys) and "MAX_PRIOR_WEIGHT" in capsys.readouterr().err + "MAX_PRIOR_WEIGHT"
    from manipdyn.identification import fit, read_log

    arm = md.load("ur5")
    d = read_log(logs / "data.csv", arm.n)
    with pytest.raises(md.ModelError, match=r"prior_weight: expected a number in \[0, 1e\+06\]"):
        fit(arm, d.q, d.qd, d.qdd, d.tau, method="consistent", prior_weight=1e308)


# -- 20. other exit 3 cases ----------------------------------------------------------------------
def test_cr_only_line_endings_read_as_lines(logs, tmp_path, capsys):
    cr = tmp_path / "cr.csv"
    cr.write_bytes((logs / "data.csv").read_bytes().replace(b"\n", b"\r"))
    assert main(["validate", "ur5", str(cr), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert main(["validate", "ur5", str(logs / "data.csv"), "--json"]) == 0
    want = json.loads(capsys.readouterr().out)
    assert got["rms"] == want["rms"] and got["samples"] == want["samples"]


def test_torque_cell_of_1e300_and_torques_scaled_by_1e_300(logs, tmp_path, capsys):
    big = with_cell(logs / "data.csv", tmp_path / "big.csv", 5, "tau1", "1e300")
    for cmd in (["validate", "ur5", str(big)], ["identify", "ur5", str(big), "-o", str(tmp_path / "o.toml")]):
        assert main(cmd) == 2
        assert "column tau1, row 6: magnitude 1e+300" in err_line(capsys)
    lines = rows(logs / "data.csv")
    head = lines[0].split(",")
    taus = [k for k, h in enumerate(head) if h.startswith("tau")]
    out = [lines[0]]
    for ln in lines[1:]:
        c = ln.split(",")
        for k in taus:
            c[k] = repr(float(c[k]) * 1e-300)
        out.append(",".join(c))
    tiny = write_rows(tmp_path / "tiny.csv", out)
    assert main(["identify", "ur5", str(tiny), "-o", str(tmp_path / "o.toml")]) == 2
    assert "MIN_TORQUE_PEAK" in err_line(capsys)


def test_corrupt_mcap_chunk_is_a_model_error(tmp_path):
    pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
    from rosbags.rosbag2 import StoragePlugin
    from manipdyn.identification import read_log
    from tests.test_rosbag import JOINTS, write_bag

    write_bag(tmp_path / "bag", StoragePlugin.MCAP, duration=4.0)
    raw = bytearray(next((tmp_path / "bag").glob("*.mcap")).read_bytes())
    mid = len(raw) // 2
    raw[mid:mid + 200] = np.random.default_rng(0).integers(0, 256, 200, dtype=np.uint8).tobytes()
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(raw))
    with pytest.raises(md.ModelError, match=r"bad\.mcap: (the bag is damaged|topic /joint_states: message at)"):
        read_log(bad, 2, joint_names=JOINTS)


def test_plot_that_is_not_an_image_is_refused_first(logs, tmp_path, capsys):
    assert main(["validate", "ur5", str(logs / "data.csv"), "--plot", str(tmp_path / "fig.csv")]) == 2
    assert "--plot" in (line := err_line(capsys)) and ".png" in line
    assert not (tmp_path / "fig.csv").exists()


# -- 21. hostile base-model JSON -----------------------------------------------------------------
def _edit(data, key):
    d = copy.deepcopy(data)
    if key == "base_columns":
        d["base_columns"][0] = 10**6
    elif key == "deep":
        d["provenance"] = "DEEP"
    elif key == "parameters[3]":
        d["parameters"][3] = None
    elif key == "nan":
        d["parameters"][3] = float("nan")
    elif key == "base_parameters[0].value":
        d["base_parameters"][0]["value"] = 10**400
    elif key == "infinity":
        d["base_parameters"][0]["std"] = float("inf")
    elif key == "negative std":
        d["base_parameters"][0]["std"] = -1.0
    text = json.dumps(d)
    return text.replace('"DEEP"', "[" * 100_000 + "]" * 100_000)


HOSTILE_JSON = {
    "base_columns": "key 'base_columns': expected 36 distinct column indices in \\[0, 60\\)",
    "deep": "nested deeper than the limit of 32 \\(manipdyn.limits.MAX_JSON_DEPTH\\)",
    "parameters[3]": "key 'parameters': expected numbers, got None",
    "nan": "key 'parameters\\[3\\]': nan is not strict JSON",
    "base_parameters[0].value": "key 'base_parameters\\[0\\].value': an integer of 401 digits",
    "infinity": "key 'base_parameters\\[0\\].std': inf is not strict JSON",
    "negative std": "key 'base_parameters\\[\\].std': a standard deviation .* is negative",
}


@pytest.mark.parametrize("case", list(HOSTILE_JSON))
def test_hostile_base_model_json_is_refused_naming_the_key(logs, tmp_path, capsys, case):
    import re

    bad = tmp_path / "bad.json"
    bad.write_text(_edit(json.loads((logs / "id.json").read_text()), case))
    for argv in (["validate", str(bad), str(logs / "data.csv")],
                 ["montecarlo", "ur5", "--plants-from", str(bad), "--runs", "1", "--duration", "0.03",
                  "--scheduler", "sync"]):
        assert main(argv) == 2
        assert re.search(HOSTILE_JSON[case], err_line(capsys))


def test_base_model_prior_text_is_never_a_path(logs, tmp_path, capsys):
    # a URDF of this machine that the JSON names: reading it would disclose or depend on it
    local = tmp_path / "local.urdf"
    local.write_text(md.to_urdf(md.load("ur5")))
    data = json.loads((logs / "id.json").read_text())
    for text in (str(local), "ur5", "erd:ur5"):
        data["prior"] = {"kind": "urdf", "text": text, "tip": None}
        bad = tmp_path / "bad.json"
        bad.write_text(json.dumps(data))
        assert main(["validate", str(bad), str(logs / "data.csv")]) == 2
        assert "key 'prior.text': expected the prior's URDF text" in err_line(capsys)


# -- 22. outputs that destroy inputs -------------------------------------------------------------
def _destroyers(d):
    prior = d / "p.toml"
    prior.write_bytes((d / "id.toml").read_bytes())
    link = d / "link.toml"
    if not link.is_symlink():
        link.symlink_to(d / "data.csv")
    data, traj = str(d / "data.csv"), str(d / "traj.csv")
    return {
        "-o is the prior": (["identify", str(prior), data, "-o", str(prior)], prior, "-o"),
        "--payload -o is the prior": (["identify", str(prior), data, "--payload", "-o", str(prior)], prior, "-o"),
        "--base-json is the log": (["identify", "ur5", data, "-o", str(d / "x.toml"), "--base-json", data],
                                   d / "data.csv", "--base-json"),
        "synthesize -o is the trajectory": (["synthesize", "ur5", traj, "-o", traj], d / "traj.csv", "-o"),
        "-o is a symlink to the log": (["identify", "ur5", data, "-o", str(link)], d / "data.csv", "-o"),
        "--plot is the log": (["validate", "ur5", data, "--plot", data], d / "data.csv", "--plot"),
    }


@pytest.mark.parametrize("case", ["-o is the prior", "--payload -o is the prior", "--base-json is the log",
                                  "synthesize -o is the trajectory", "-o is a symlink to the log",
                                  "--plot is the log"])
def test_output_that_is_an_input_is_refused(logs, capsys, case):
    argv, victim, option = _destroyers(logs)[case]
    before = victim.read_bytes()
    assert main(argv) == 2
    line = err_line(capsys)
    assert line.split("error: ")[1].startswith(option) and "would overwrite" in line
    assert victim.read_bytes() == before


def test_outputs_are_checked_before_the_fit(logs, tmp_path, capsys, monkeypatch):
    import manipdyn.identification as ident

    def no_fit(*a, **k):
        raise AssertionError("the fit ran before the outputs were checked")

    monkeypatch.setattr(ident, "fit", no_fit)
    data = str(logs / "data.csv")
    out = tmp_path / "x.toml"
    # the same file twice
    assert main(["identify", "ur5", data, "-o", str(out), "--base-json", str(out)]) == 2
    assert "--base-json" in err_line(capsys) and not out.exists()
    # an unwritable --base-json: refused before -o is written
    assert main(["identify", "ur5", data, "-o", str(out), "--base-json", str(tmp_path / "no" / "b.json")]) == 2
    assert "--base-json" in err_line(capsys) and not out.exists()
    # -o in a folder that does not exist: refused before the fit
    assert main(["identify", "ur5", data, "-o", str(tmp_path / "no" / "x.toml")]) == 2
    assert "-o" in err_line(capsys)


def test_a_hard_link_to_an_input_is_the_input(logs, tmp_path, capsys):
    hard = tmp_path / "hard.csv"
    os.link(logs / "traj.csv", hard)
    before = hard.read_bytes()
    assert main(["synthesize", "ur5", str(logs / "traj.csv"), "-o", str(hard)]) == 2
    assert "would overwrite TRAJ.csv" in err_line(capsys) and hard.read_bytes() == before
    from manipdyn._support.files import overwrites

    assert overwrites(hard, logs / "traj.csv") and not overwrites(tmp_path / "new.csv", logs / "traj.csv")


# -- 23. one line on exit 2 ----------------------------------------------------------------------
def test_numpy_warnings_do_not_come_before_the_error(logs, tmp_path, capsys):
    big_q = with_cell(logs / "data.csv", tmp_path / "q.csv", 5, "q1", "1e300")
    for argv, needle in ((["validate", "ur5", str(big_q)], "column q1, row 6"),
                         (["validate", "ur5", str(logs / "data.csv"), "--time-scale", "1e308"], "--time-scale"),
                         (["validate", "ur5", str(logs / "data.csv"), "--resample", "1e-9"], "--resample")):
        assert main(argv) == 2
        assert needle in err_line(capsys)


def test_bag_metadata_error_is_one_line(tmp_path, capsys):
    pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: [\n  : : :\n\t- x\n")
    (bag / "bag_0.mcap").write_bytes(b"\x89MCAP0\r\n")
    assert main(["validate", "ur5", str(bag)]) == 2
    assert "not a readable ROS bag" in err_line(capsys)


def test_negative_t_range_is_accepted(logs, capsys):
    assert main(["validate", "ur5", str(logs / "data.csv"), "--t-range", "-5:-1"]) == 2
    assert "t_range (-5.0, -1.0) holds 0 samples" in err_line(capsys)
    assert main(["validate", "ur5", str(logs / "data.csv"), "--t-range", "-5:2", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["samples"] == 400


def test_model_warning_is_one_line_after_the_command(logs, capsys, monkeypatch):
    import warnings

    import manipdyn.identification.results.validation as validation

    real = validation.validate

    def warns(*a, **k):      # as identify --method wls's arm does: a several-line model note
        warnings.warn("odd: 2 notes:\n  link 1: triangle inequality broken\n  link 2: ...",
                      md.PhysicalConsistencyWarning, stacklevel=2)
        return real(*a, **k)

    monkeypatch.setattr(validation, "validate", warns)
    assert main(["validate", "ur5", str(logs / "data.csv")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["manipdyn: warning: PhysicalConsistencyWarning: odd: 2 notes: link 1: triangle inequality "
                   "broken link 2: ..."]
    assert main(["validate", "ur5", str(logs / "data.csv"), "--rate", "0.001"]) == 2   # exit 2: the error alone
    assert err_line(capsys).startswith("manipdyn validate: error:")


# -- 24. linearize with an absurd step -----------------------------------------------------------
@pytest.mark.parametrize("dt", [1e306, 1e5])
def test_linearize_dt_that_overflows_is_a_state_error(dt):
    arm = md.load("panda")
    rng = np.random.default_rng(0)
    q, qd, tau = (rng.uniform(-1, 1, arm.n) for _ in range(3))
    with pytest.raises(md.StateError, match=r"dt: .* s makes exp\(A dt\) overflow float64"):
        arm.linearize(q, qd, tau, dt=dt)
    Ad, Bd = arm.linearize(q, qd, tau, dt=1e-3)                # a real period still works
    assert np.all(np.isfinite(Ad)) and np.all(np.isfinite(Bd))


# -- 25. accepted silently: decided --------------------------------------------------------------
def test_rate_outside_a_joint_logs_range_is_refused(logs, capsys):
    assert main(["validate", "ur5", str(logs / "data.csv"), "--rate", "0.001"]) == 2
    assert "--rate) 0.001 Hz" in err_line(capsys)


def test_one_column_for_two_signals_is_refused(logs, capsys):
    assert main(["validate", "ur5", str(logs / "data.csv"), "--columns", "qd=q{i}"]) == 2
    assert "column 'q1' is mapped to q and qd" in err_line(capsys)


def test_underscore_in_a_number_is_refused(logs, tmp_path, capsys):
    bad = with_cell(logs / "data.csv", tmp_path / "u.csv", 3, "q2", "0_5")
    assert main(["validate", "ur5", str(bad)]) == 2
    assert "row 4, column 3 ('q2'): '0_5' is not a number" in err_line(capsys)


def test_deg_on_radians_and_motor_columns_without_transmission_get_notes(logs, tmp_path):
    from manipdyn.identification import read_log

    d = read_log(logs / "data.csv", 6, deg=True)
    assert any("radians read as degrees" in n for n in d.notes)
    lines = rows(logs / "data.csv")
    lines[0] = lines[0].replace("q", "qm").replace("qmd", "qd").replace("tau", "taum")
    motor = write_rows(tmp_path / "motor.csv", lines)
    m = read_log(motor, 6, transmission=md.load("ur5").transmission)
    assert any("R = I and no offsets" in n for n in m.notes)
    np.testing.assert_array_equal(m.q, read_log(logs / "data.csv", 6).q)


def test_bag_joint_names_twice_and_time_scale_are_refused(tmp_path):
    pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
    from rosbags.rosbag2 import StoragePlugin
    from manipdyn.identification import read_log
    from tests.test_rosbag import JOINTS, write_bag

    write_bag(tmp_path / "bag", StoragePlugin.MCAP, duration=4.0)
    with pytest.raises(md.ModelError, match="joint_names \\(--joint-names\\): shoulder given twice"):
        read_log(tmp_path / "bag", 2, joint_names=["shoulder", "shoulder"])
    with pytest.raises(md.ModelError, match="time_scale= \\(--columns, --deg, --time-scale\\)|--time-scale"):
        read_log(tmp_path / "bag", 2, joint_names=JOINTS, time_scale=1e-3)


def test_payload_on_absurdly_scaled_torques_is_refused(logs, tmp_path, capsys):
    lines = rows(logs / "data.csv")
    head = lines[0].split(",")
    taus = [k for k, h in enumerate(head) if h.startswith("tau")]
    out = [lines[0]]
    for ln in lines[1:]:
        c = ln.split(",")
        for k in taus:
            c[k] = repr(float(c[k]) * 1e12)
        out.append(",".join(c))
    scaled = write_rows(tmp_path / "scaled.csv", out)
    assert main(["identify", "ur5", str(scaled), "--payload"]) == 2
    assert "MAX_SIGNAL" in err_line(capsys)


def test_urdf_and_check_refuse_to_write_over_the_urdf_they_read(tmp_path, capsys):
    assert main(["urdf", "ur5", str(tmp_path)]) == 0
    capsys.readouterr()
    src = tmp_path / "ur5.urdf"
    before = src.read_bytes()
    for argv in (["urdf", str(src), str(tmp_path)],
                 ["check", str(src), "--urdf-out", str(tmp_path), "--samples", "2", "--timing-calls", "0"]):
        assert main(argv) == 2
        assert "would overwrite MODEL_OR_FILE" in err_line(capsys)
        assert src.read_bytes() == before


def test_scoring_a_base_model_is_capped_like_a_fit(logs, monkeypatch, capsys):
    monkeypatch.setattr(limits, "MAX_FIT_ENTRIES", 1e5)     # its regressor: 800 x 6 x 60 entries
    assert main(["validate", str(logs / "id.json"), str(logs / "data.csv")]) == 2
    assert "MAX_FIT_ENTRIES" in err_line(capsys)
    assert main(["validate", "ur5", str(logs / "data.csv")]) == 0    # an arm's own dynamics: no regressor
