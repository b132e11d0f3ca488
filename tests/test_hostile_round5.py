"""Issue 38, items 17 to 21: hostile input on the newest surfaces, round five.

One test (or one parametrised family) per finding, named after it.  Each builds the issue's
reproducer (a trust record with weights of 1e308 or nested 10,000 deep, ``--ramp 1e-300``, an
output under ``/proc``, a complex or bool pose, ``--smoothing 1e-320``, a UTF-32 log,
``--cutoff 1e-300``, a file-size limit, a relative cache folder) and checks the outcome:
exit 2 with one line naming the option, key or file, nothing left behind, or a ModelError
naming the argument in the API.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.formats.save import to_toml
from manipdyn.formats.trust import TRUST_FORMAT, check_trust

from common import ROOT, err_line


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    """A short UR5 log with exact torques and measured qd, qdd (validate reads it as it is)."""
    from manipdyn.formats.logs.data import write_measurements_csv

    arm = md.load("ur5")
    t = np.arange(200) / 100.0
    q = 0.3 * np.sin(np.outer(t, np.arange(1, 7)))
    qd = 0.3 * np.arange(1, 7) * np.cos(np.outer(t, np.arange(1, 7)))
    qdd = -0.3 * np.arange(1, 7) ** 2 * np.sin(np.outer(t, np.arange(1, 7)))
    path = tmp_path_factory.mktemp("round5") / "log.csv"
    write_measurements_csv(path, t, q, arm.inverse_dynamics(q, qd, qdd), qd, qdd)
    return path


def _record(**over):
    """A well-formed trust record of a 6-joint arm (the shapes a fit writes), with ``over`` set."""
    rec = {"format": TRUST_FORMAT, "data": "log.csv",
           "prediction_band": {"method": "blocked hold-out", "level": 0.95, "folds": 5, "samples": 200,
                               "half_width": [0.1] * 6, "held_out_rms": [0.05] * 6},
           "leverage": {"smoothing": 0.01, "weights": [20.0] * 6, "scale": [1.0] * 84, "mean": [1.0] * 6,
                        "largest": [3.0] * 6, "basis": [[0.0] * 84]}}
    for key, value in over.items():
        table, _, field = key.partition("__")
        rec[table] = dict(rec[table], **{field: value}) if field else value
    return rec


def _model_with_trust(tmp_path, body: str):
    path = tmp_path / "m.toml"
    path.write_text(to_toml(md.load("ur5")) + "\n[trust]\n" + body)
    return path


# -- 17. a hostile trust record -----------------------------------------------------------------
@pytest.mark.parametrize("key, value, match", [
    ("leverage__weights", [1e308] * 6, r"leverage\.weights\[0\]: 1e\+308 is beyond .*MAX_MAGNITUDE"),
    ("leverage__basis", [[1e308] + [0.0] * 83], r"leverage\.basis\[0\]\[0\]: 1e\+308 is beyond"),
    ("prediction_band__half_width", [-1.0] + [0.1] * 5,
     r"prediction_band\.half_width\[0\]: expected a number >= 0, got -1\.0"),
])
def test_a_hostile_trust_record_is_refused_naming_the_key(key, value, match):
    """Issue 38 item 17: "a leverage basis or weights of 1e308 give exit 3 (Out of range float values
    are not JSON compliant: inf); a negative band half-width is accepted"."""
    check_trust(_record())                        # the well-formed one reads
    with pytest.raises(md.ModelError, match=match):
        check_trust(_record(**{key: value}), "trust")


def test_a_model_file_with_weights_of_1e308_is_one_line_exit_2(tmp_path, log, capsys):
    """Item 17 through the command: validate on the model file exits 2 naming the file and the key
    (it exited 3, the JSON writer meeting an inf leverage)."""
    model = _model_with_trust(tmp_path, f'format = "{TRUST_FORMAT}"\n\n[trust.leverage]\n'
                                        "weights = [1e308, 1e308, 1e308, 1e308, 1e308, 1e308]\n")
    assert main(["validate", str(model), str(log), "--json"]) == 2
    line = err_line(capsys)
    assert "m.toml: key 'trust'" in line and "leverage.weights[0]" in line, line


def test_a_leverage_reference_that_overflows_is_a_note_not_inf():
    """Item 17: a reference within the record's limits whose leverage still overflows float64 is a
    ModelError (validate turns it into the note "...; no leverage"), never an inf in the JSON."""
    from manipdyn.identification.uncertainty.leverage import Leverage

    arm = md.load("ur5")
    rec = _record()["leverage"]
    rec["basis"] = [[1e55] * 84]
    ref = Leverage.from_dict(dict(rec, weights=[1e55] * 6, scale=[1e-55] * 84), 6, "leverage")
    q = np.full((3, 6), 0.3)
    with pytest.raises(md.ModelError, match="^leverage: .*overflow float64"):
        ref.leverage(arm, q, q, q)
    assert np.all(np.isfinite(Leverage.from_dict(rec, 6, "leverage").leverage(arm, q, q, q)))
    # a mean of 0 divides the leverage into inf (exit 3 in validate --json before): refused, so ignored with a note
    with pytest.raises(md.ModelError, match=r"^leverage: mean: expected finite numbers > 0, got \[0\.0"):
        Leverage.from_dict(dict(rec, mean=[0.0] * 6), 6, "leverage")


def test_a_urdf_trust_comment_nested_10000_deep_is_refused_by_name(tmp_path, capsys):
    """Item 17: "a URDF trust comment nested 10,000 deep gives exit 3 (RecursionError)"."""
    text = md.to_urdf(md.load("ur5"))
    deep = '{"format": "%s", "x": %s1%s}' % (TRUST_FORMAT, "[" * 10_000, "]" * 10_000)
    path = tmp_path / "deep.urdf"
    path.write_text(re.sub(r"(<robot[^>]*>)", lambda m: m.group(1) + f"\n<!-- {TRUST_FORMAT} {deep} -->", text,
                           count=1))
    with pytest.raises(md.ModelError, match=r"deep\.urdf, line \d+: the manipdyn-trust/1 comment is nested deeper "
                                            r"than the limit of 32"):
        md.load(str(path))
    assert main(["urdf", str(path), str(tmp_path / "o")]) == 2
    assert "nested deeper than the limit of 32" in err_line(capsys)
    # within the parser's reach but past the limit: the record's own depth check names the key
    with pytest.raises(md.ModelError, match=r"trust\.x(\[0\]){32}: nested deeper than the limit of 32"):
        check_trust({"format": TRUST_FORMAT, "x": eval("[" * 40 + "1" + "]" * 40)}, "trust")


# -- 25. one TOML string escaper ---------------------------------------------------------------
def test_a_trust_string_with_a_lone_surrogate_is_a_model_error(tmp_path):
    """Issue 38 item 25: "a trust string holding a lone surrogate makes md.save raise a raw
    UnicodeEncodeError, where the model file's escaper raises ModelError"."""
    arm = md.load("ur5")
    arm.trust = {"format": TRUST_FORMAT, "data": "log\ud800.csv"}
    with pytest.raises(md.ModelError, match=r"save: a string of the trust record holds the lone surrogate U\+D800"):
        md.save(arm, tmp_path / "s.toml")
    assert not (tmp_path / "s.toml").exists()
    # control characters and quotes in a trust string read back exactly, as in the rest of the file
    arm.trust = {"format": TRUST_FORMAT, "data": 'a"b\\c\x7f\x01\u2028.csv'}
    md.save(arm, tmp_path / "ok.toml")
    assert md.load(str(tmp_path / "ok.toml")).trust["data"] == arm.trust["data"]


# -- 18. excite --ramp 1e-300 ------------------------------------------------------------------
@pytest.mark.parametrize("ramp", ["1e-300", "0.004"])
def test_a_ramp_shorter_than_a_sample_is_refused(tmp_path, capsys, ramp):
    """Issue 38 item 18: "excite --ramp 1e-300: exit 3 (ZeroDivisionError)"."""
    out = tmp_path / "t.csv"
    assert main(["excite", "ur5", "--iterations", "0", "--duration", "1", "--rate", "100", "--ramp", ramp,
                 "-o", str(out)]) == 2
    assert err_line(capsys) == (f"manipdyn excite: error: --ramp: {float(ramp):g} s is shorter than one sample "
                                "(1 / --rate = 0.01 s); expected 0 (no ramp), 'auto', or at least one sample")
    assert not out.exists()
    from manipdyn.identification import excitation

    with pytest.raises(md.ModelError, match=r"^ramp: 1e-300 s is shorter than one sample \(1 / rate = 0\.01 s\)"):
        excitation(md.load("ur5"), duration=1.0, rate=100.0, ramp=1e-300, iterations=0)


# -- 19. synthesize --truth: both or neither ---------------------------------------------------
def test_synthesize_writes_the_log_and_the_truth_or_neither(tmp_path, log, capsys, monkeypatch):
    """Issue 38 item 19: "synthesize -o /proc/x.csv --truth T.toml leaves T.toml behind"."""
    monkeypatch.chdir(tmp_path)
    traj = tmp_path / "traj.csv"
    from manipdyn.formats.logs.data import write_trajectory_csv

    t = np.arange(50) / 100.0
    q = np.tile(0.1 * np.sin(t)[:, None], (1, 6))
    write_trajectory_csv(traj, t, q, 0.1 * np.cos(t)[:, None] * np.ones(6), -q)
    argv = ["synthesize", "ur5", str(traj), "--perturb"]
    assert main(argv + ["-o", "/proc/x.csv", "--truth", "T.toml"]) == 2
    assert "/proc/x.csv" in err_line(capsys)
    assert not (tmp_path / "T.toml").exists()
    assert main(argv + ["-o", "d.csv", "--truth", "/proc/T.toml"]) == 2
    assert "/proc/T.toml" in err_line(capsys)
    assert not (tmp_path / "d.csv").exists()
    # the truth written, then the log's rename failing: the truth is taken back
    import manipdyn.formats.logs.data as data

    real = data.atomic_write

    def failing(path, write, **kw):
        def then_fail(fh):
            write(fh)
            raise OSError(28, "No space left on device", os.fspath(path))
        return real(path, then_fail, **kw)

    monkeypatch.setattr(data, "atomic_write", failing)
    assert main(argv + ["-o", "d.csv", "--truth", "T.toml"]) == 2
    assert "No space left" in err_line(capsys)
    assert not (tmp_path / "T.toml").exists() and not (tmp_path / "d.csv").exists()
    monkeypatch.setattr(data, "atomic_write", real)
    assert main(argv + ["-o", "d.csv", "--truth", "T.toml"]) == 0
    capsys.readouterr()
    assert (tmp_path / "d.csv").exists() and md.load("T.toml").name == "ur5_true"


# -- 20. inverse_kinematics of a complex, bool or huge pose ------------------------------------
def test_inverse_kinematics_refuses_complex_bool_and_huge_poses(recwarn):
    """Issue 38 item 20: "a complex T is accepted (the imaginary part dropped); a bool-typed np.eye(4)
    is taken as a pose; a translation of 1e300 m gives 'q: entry 0 is nan' after an overflow warning"."""
    arm = md.load("ur5")
    T = arm.fkine(np.full(6, 0.3))
    with pytest.raises(md.ModelError, match=r"^T: expected a homogeneous transform of real numbers, got a complex "
                                            r"array \(dtype complex128\)"):
        arm.inverse_kinematics(T + 1e-3j)
    with pytest.raises(md.ModelError, match=r"^T: expected .* real numbers, got a bool array"):
        arm.inverse_kinematics(np.eye(4, dtype=bool))
    far = T.copy()
    far[0, 3] = 1e300
    with pytest.raises(md.ModelError, match=r"^T: field 'translation' has magnitude 1e\+300 m, over 1e\+60"):
        arm.inverse_kinematics(far)
    assert not recwarn.list, [str(w.message) for w in recwarn.list]
    assert np.allclose(arm.fkine(arm.inverse_kinematics(T)), T, atol=1e-9)


# -- 21. left from round four -----------------------------------------------------------------
def test_a_subnormal_smoothing_is_refused(tmp_path, log, capsys):
    """Issue 38 item 21: "--smoothing 1e-320 exits 0 with a RuntimeWarning"."""
    argv = ["identify", "ur5", str(log), "--method", "wls", "--friction-terms", "viscous,coulomb",
            "-o", str(tmp_path / "i.toml")]
    assert main(argv + ["--smoothing", "1e-320"]) == 2
    assert err_line(capsys).startswith("manipdyn identify: error: --smoothing: expected 0 (a sharp sign) or a "
                                       "velocity of at least 1e-09 rad/s")
    assert not (tmp_path / "i.toml").exists()
    with pytest.raises(md.ModelError, match=r"'smoothing' must be a finite number >= 0 \(0, or at least 1e-09: manipdyn.limits.MIN_SMOOTHING\), got 1e-320"):
        md.Friction(viscous=np.zeros(2), coulomb=np.ones(2), smoothing=1e-320)


def test_a_utf32_log_is_called_utf32(tmp_path, log, capsys):
    """Item 21: "a UTF-32 log is called UTF-16"."""
    for codec, name in (("utf-32", "UTF-32"), ("utf-32-be", "UTF-32"), ("utf-16", "UTF-16")):
        path = tmp_path / f"{codec}.csv"
        path.write_bytes(("\ufeff" if codec == "utf-32-be" else "").encode(codec)
                         + log.read_text().encode(codec))
        assert main(["validate", "ur5", str(path)]) == 2
        assert f"row 1: the file is {name} text" in err_line(capsys), codec


def test_a_tiny_cutoff_says_a_readable_limit(tmp_path, log, capsys):
    """Item 21: "--cutoff 1e-300 prints a 300-digit sample count"."""
    from manipdyn.formats.logs.data import write_measurements_csv

    arm = md.load("ur5")
    t = np.arange(200) / 100.0
    q = 0.3 * np.sin(np.outer(t, np.ones(6)))
    path = tmp_path / "q_only.csv"
    write_measurements_csv(path, t, q, arm.inverse_dynamics(q, 0 * q, 0 * q))
    assert main(["identify", "ur5", str(path), "--cutoff", "1e-300", "-o", str(tmp_path / "i.toml")]) == 2
    line = err_line(capsys)
    assert line.endswith("200 samples are too few to filter at 1e-300 Hz; that needs more than 6e+300 s of samples; "
                         "these allow cutoffs above 3 Hz"), line
    assert len(line) < 300


def _under_file_size_limit(argv, cwd, limit_bytes=8192):
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, *argv], cwd=cwd, env=env, preexec_fn=limit, capture_output=True,
                          text=True, timeout=300)


def test_a_file_size_limit_names_the_file(tmp_path):
    """Item 21: "codegen under a file-size limit says [Errno 27] File too large and names no file"
    (every atomic write now names its file; codegen's test-compile copy names itself)."""
    pytest.importorskip("casadi")
    from manipdyn.engines.c import build

    r = _under_file_size_limit(["-m", "manipdyn", "codegen", "ur5", "-o", "gen"], tmp_path)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "File too large" in lines[0], r.stderr
    if build.find_compiler() is not None:
        assert "(the copy to test-compile): '" in lines[0] and "ur5.c'" in lines[0], lines[0]
    assert not (tmp_path / "gen" / "ur5.c").exists()
    # the atomic write itself (no compiler in the way)
    code = ("from manipdyn._support.files import atomic_write_text\n"
            "try:\n    atomic_write_text('big.txt', 'x' * 100000)\n"
            "except OSError as e:\n    print(e)\n")
    r = _under_file_size_limit(["-c", code], tmp_path)
    assert r.stdout.strip() == "[Errno 27] File too large: 'big.txt'", r.stdout + r.stderr


def test_a_relative_cache_folder_is_refused_by_name(tmp_path, monkeypatch):
    """Item 21: "a relative MANIPDYN_CACHE_DIR silently makes a cache in the current folder"."""
    from manipdyn.engines.c import build

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(build.CACHE_ENV, "relcache")
    with pytest.raises(md.ModelError, match=r"^\$MANIPDYN_CACHE_DIR: expected an absolute folder .*'relcache'"):
        build.cache_dir()
    assert not (tmp_path / "relcache").exists()
    monkeypatch.setenv(build.CACHE_ENV, str(tmp_path / "abs"))
    assert build.cache_dir() == str(tmp_path / "abs")
    monkeypatch.setenv(build.CACHE_ENV, "~/c")
    assert build.cache_dir() == os.path.join(os.path.expanduser("~"), "c")
