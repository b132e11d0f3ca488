"""Issue 20, as a newcomer meets manipdyn: each item's test (the item number in the name).

Usage errors exit 2 with a one-line message, names are forgiving, files load back,
nothing is left behind.  Tests that need a long run stay small (a few iterations,
a few runs) and assert outcomes, never times.
"""

from __future__ import annotations

import sys

import pytest

from manipdyn.cli import main


def _err_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


# -- item 10: usage errors exit 2 with a message, never 3 ---------------------------------------
@pytest.mark.parametrize("size", ["0", "-1"])
def test_item10_montecarlo_chunk_size_is_usage_error(size, capsys):
    assert main(["montecarlo", "puma560", "--runs", "2", "--scheduler", "sync", "--chunk-size", size]) == 2
    assert "--chunk-size" in _err_line(capsys)


def test_item10_check_negative_timing_calls_is_usage_error(capsys):
    assert main(["check", "stanford", "--samples", "2", "--timing-calls", "-1"]) == 2
    assert "--timing-calls" in _err_line(capsys)


def test_item10_urdf_without_outdir_says_missing_outdir(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["urdf", "puma560"]) == 2
    assert "missing OUTDIR" in _err_line(capsys)
    assert not (tmp_path / "puma560").exists()


def test_item10_controllers_any_case(capsys):
    assert main(["montecarlo", "puma560", "--runs", "1", "--scheduler", "sync", "--controllers", "pd,CT",
                 "--duration", "0.05", "--json"]) == 0
    assert main(["montecarlo", "puma560", "--runs", "1", "--scheduler", "sync", "--controllers", "pd,XX"]) == 2
    line = _err_line(capsys)
    assert "pd,pdg,ct,adaptive" in line


def test_item10_missing_dask_hint_is_a_command_line(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)   # import distributed -> ImportError
    assert main(["montecarlo", "puma560", "--runs", "1", "--duration", "0.05"]) == 2
    line = _err_line(capsys)
    assert "--scheduler sync" in line and "scheduler='sync'" not in line


# -- item 6: excite checks -o before it optimises --------------------------------------------
def test_item6_excite_checks_output_before_optimising(tmp_path, monkeypatch, capsys):
    import manipdyn.identification as ident

    def never(*a, **k):                       # the optimiser must not start
        raise AssertionError("excitation ran before -o was checked")

    monkeypatch.setattr(ident, "excitation", never)
    assert main(["excite", "ur5", "-o", str(tmp_path / "missing" / "traj.csv")]) == 2
    assert "-o" in _err_line(capsys)
    assert main(["excite", "ur5", "-o", str(tmp_path)]) == 2      # a folder
    assert "folder" in _err_line(capsys)


# -- item 15: caps with messages that say how to raise them; a scheduler with no workers ------
@pytest.mark.parametrize("argv, limit", [
    (["excite", "ur5", "--harmonics", "1000"], "MAX_HARMONICS"),
    (["excite", "ur5", "--rate", "1e6", "--duration", "100"], "MAX_EXCITATION_SAMPLES"),
    (["montecarlo", "puma560", "--runs", "100000000"], "MAX_STUDY_STEPS"),
    (["montecarlo", "puma560", "--runs", "1", "--dt", "1e-9"], "MAX_RUN_STEPS"),
])
def test_item15_caps_say_how_to_raise_them(argv, limit, tmp_path, capsys):
    if argv[0] == "excite":
        argv = argv + ["-o", str(tmp_path / "t.csv")]
    assert main(argv) == 2
    line = _err_line(capsys)
    assert f"manipdyn.limits.{limit} = " in line and "from the shell" in line


def test_item15_caps_can_be_raised(monkeypatch):
    import manipdyn._support.limits as limits
    from manipdyn.control.montecarlo import check_study_size

    with pytest.raises(ValueError, match="MAX_STUDY_STEPS"):
        check_study_size(10**6, 4, 2.0, 1e-3, 10.0)
    monkeypatch.setattr(limits, "MAX_STUDY_STEPS", 1e10)
    check_study_size(10**6, 4, 2.0, 1e-3, 10.0)          # raised: accepted


def test_item15_scheduler_without_workers_times_out(monkeypatch, capsys):
    distributed = pytest.importorskip("distributed", reason="the scale extra is not installed")
    import manipdyn.check.scale as scale

    monkeypatch.setattr(scale, "WORKER_WAIT_S", 1.0)
    # a scheduler of this process on tcp (manipdyn takes tcp:// addresses only, issue 27 item 19)
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp://", dashboard_address=None) as cluster:
        assert main(["montecarlo", "puma560", "--runs", "1", "--duration", "0.05",
                     "--scheduler", cluster.scheduler_address]) == 2
    line = _err_line(capsys)
    assert "no worker" in line and "dask worker" in line


# -- item 19: exit 2, never 3, on bad excite and montecarlo options ---------------------------
@pytest.mark.parametrize("argv, culprit", [
    (["excite", "ur5", "--duration", "0.005"], "--rate x --duration"),
    (["excite", "ur5", "--rate", "1e-9"], "--rate x --period"),      # --duration: the period's old name
    (["excite", "ur5", "--seed", "-1"], "--seed"),
    (["excite", "ur5", "--duration", "nan"], "--duration"),
    (["montecarlo", "puma560", "--runs", "1", "--scheduler", "garbage"], "--scheduler"),
    (["montecarlo", "puma560", "--runs", "1", "--scheduler", "http://x:80"], "--scheduler"),
    (["montecarlo", "puma560", "--runs", "1", "--scheduler", ""], "--scheduler"),
    (["montecarlo", "puma560", "--runs", "1", "--scheduler", "sync", "--bandwidth", "1e300"], "--bandwidth"),
])
def test_item19_bad_options_exit_2(argv, culprit, tmp_path, capsys):
    if argv[0] == "excite":
        argv = argv + ["-o", str(tmp_path / "t.csv")]
    assert main(argv) == 2
    assert culprit in _err_line(capsys)
    assert not (tmp_path / "t.csv").exists()


# -- item 3: whatever md.save writes, md.load reads back --------------------------------------
def _arm_like(arm, **kw):
    import manipdyn as md

    base = dict(convention=arm.convention, gravity=arm.gravity, name=arm.name, source=arm.source,
                sources=arm.sources, description=arm.description)
    base.update(kw)
    return md.Manipulator(kw.pop("links", arm.links), **{k: v for k, v in base.items() if k != "links"})


def test_item3_save_refuses_what_load_would_refuse(tmp_path):
    import manipdyn as md
    from manipdyn._support.errors import ModelError

    arm = _arm_like(md.load("ur5"), description="x" * (2 * 1024 * 1024))
    with pytest.raises(ModelError, match="MAX_MODEL_FILE_BYTES"):
        md.save(arm, tmp_path / "long.toml")
    assert not (tmp_path / "long.toml").exists()


def test_item3_extreme_valid_models_round_trip(tmp_path):
    import dataclasses

    import numpy as np

    import manipdyn as md
    import manipdyn._support.limits as limits

    ur5 = md.load("ur5")
    # 100 joints (MAX_JOINTS), names at MAX_NAME_LENGTH, non-ASCII text, the heaviest
    # allowed body, subnormal and exactly-representable numbers, a description that
    # fills the file up to just under the load limit (multi-byte characters counted as bytes)
    link = dataclasses.replace(ur5.links[1], name="ł" * limits.MAX_NAME_LENGTH)
    heavy = dataclasses.replace(ur5.links[2], mass=limits.MAX_MASS, com=(5e-324, -0.0, 0.1),
                                inertia=np.diag([limits.MAX_INERTIA, limits.MAX_INERTIA, 1.0]))
    links = [link if k % 2 else heavy for k in range(limits.MAX_JOINTS)]
    arm = _arm_like(ur5, links=links, name="Ω arm\r", source="tab\there \x7f\x1b[31m",
                    sources={"kinematics": "a\rb\x00c", "key with space": "é"}, description="")
    room = limits.MAX_MODEL_FILE_BYTES - len(md.to_toml(arm).encode()) - 64
    arm = _arm_like(arm, links=links, description="€" * (room // 3))
    md.save(arm, tmp_path / "extreme.toml")
    assert (tmp_path / "extreme.toml").stat().st_size <= limits.MAX_MODEL_FILE_BYTES
    back = md.load(tmp_path / "extreme.toml")
    assert (back.name, back.source, back.sources, back.description) == \
        (arm.name, arm.source, arm.sources, arm.description)
    for a, b in zip(arm.links, back.links):
        assert a.name == b.name and a.mass == b.mass
        assert np.array_equal(a.com, b.com) and np.array_equal(a.inertia, b.inertia)


# -- item 18: control characters and foreign values at save ------------------------------------
@pytest.mark.parametrize("field", ["name", "source", "description", "sources"])
@pytest.mark.parametrize("ch", ["\r", "\x7f", "\x00", "\x0b", "\x1f", "\b", "\f", "\\", '"', "\u2028"])
def test_item18_toml_writer_escapes_every_control_character(field, ch, tmp_path):
    import manipdyn as md

    value = {"kinematics": f"a{ch}b"} if field == "sources" else f"a{ch}b"
    if field == "name" and ch in "\x00\x0b\x1f\b\f\x7f":
        pytest.skip("names refuse control characters at construction (links.check_name)")
    arm = _arm_like(md.load("ur5"), **{field: value})
    md.save(arm, tmp_path / "m.toml")
    assert getattr(md.load(tmp_path / "m.toml"), field) == value


@pytest.mark.parametrize("kw, culprit", [
    ({"sources": {"k": 1}}, "sources['k']"),
    ({"source": "a\ud800b"}, "source"),
    ({"description": "\udcff"}, "description"),
])
def test_item18_save_names_the_bad_field(kw, culprit, tmp_path):
    import manipdyn as md
    from manipdyn._support.errors import ModelError

    try:
        arm = _arm_like(md.load("ur5"), **kw)
    except ModelError:
        return                                # refused at construction: as good
    with pytest.raises(ModelError, match=f"save: {pytest.importorskip('re').escape(culprit)}"):
        md.save(arm, tmp_path / "m.toml")
    assert not (tmp_path / "m.toml").exists()


@pytest.mark.parametrize("source", ["a\x01b", "a\ud800b", "x\x7f\x9f--y-"])
def test_item18_write_urdf_holds_any_source_text(source, tmp_path):
    import manipdyn as md

    arm = _arm_like(md.load("ur5"), source=source)
    md.write_urdf(arm, tmp_path / "a.urdf")
    back = md.load(tmp_path / "a.urdf")
    assert back.n == 6


# -- item 13: generated URDFs write round-off as 0 ---------------------------------------------
@pytest.mark.parametrize("name", ["stanford", "ur10", "puma560", "panda"])
def test_item13_generated_urdf_has_no_round_off(name):
    import re

    import manipdyn as md

    text = md.to_urdf(md.load(name))
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)   # the values, not the comments' figures (a completion's
    tiny = [m for m in re.findall(r"-?[0-9.]+e-[0-9]+", text) if abs(float(m)) < 1e-12]   # 1e-15 N m agreement)
    assert not tiny, tiny
    assert not re.findall(r'[" ]-0\.0[" ]', text)          # no negative zeros either


# -- item 11: model names: did-you-mean, erd:NAME everywhere, models --erd, labels ---------------
def test_item11_model_typo_gets_did_you_mean(capsys):
    assert main(["check", "puma650"]) == 2
    assert "did you mean 'puma560'" in _err_line(capsys)
    assert main(["check", "erd:ur5_robt"]) == 2
    assert "did you mean 'ur5_robot'" in _err_line(capsys)


@pytest.mark.parametrize("argv", [
    ["check", "erd:ur5_robot", "--samples", "3", "--timing-calls", "0"],
    ["check", "erd:panda", "--tip", "panda_hand", "--samples", "3", "--timing-calls", "0"],
    ["urdf", "erd:ur5_robot", "{tmp}"],
    ["track", "erd:ur5_robot", "--duration", "0.05"],
    ["montecarlo", "erd:ur5_robot", "--runs", "1", "--duration", "0.05", "--scheduler", "sync",
     "--controllers", "pd"],
    ["excite", "erd:ur5_robot", "-o", "{tmp}/t.csv", "--iterations", "0", "--duration", "1"],
])
def test_item11_erd_names_work_in_every_subcommand(argv, tmp_path, capsys):
    pytest.importorskip("scipy", reason="excite needs the identify extra")
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 0, capsys.readouterr().err


def test_item11_models_erd_lists_names(capsys):
    from manipdyn.formats.erd import urdf_names

    assert main(["models", "--erd"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == len(urdf_names()) and any(l.startswith("erd:ur5_robot ") for l in lines)


def test_item11_labels_tell_bundled_from_erd(capsys):
    assert main(["compare", "ur5", "erd:ur5_robot"]) == 1            # NOT THE SAME ARM (README)
    out = capsys.readouterr().out
    assert "a = 'ur5' with b = 'erd:ur5_robot'" in out


# -- item 12: --version, track --json (bench: tests/test_bench_smoke.py) -------------------------
def test_item12_version(capsys):
    import manipdyn

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"manipdyn {manipdyn.__version__}"


def test_item12_track_json_is_one_strict_document(capsys):
    import json

    strict = {"parse_constant": lambda c: pytest.fail(f"not strict JSON: {c}")}
    assert main(["track", "puma560", "--duration", "1", "--compare", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out, **strict)
    assert set(doc["controllers"]) == {"PD", "PD + gravity", "computed torque", "adaptive (Slotine-Li)", "LQR"}
    ct = doc["controllers"]["computed torque"]
    assert len(ct["rms_error"]) == 6 and all(x >= 0 for x in ct["peak_torque"])
    # a 0.2 s demo path is too fast for the adaptive controller: exit 1, still one document
    assert main(["track", "puma560", "--duration", "0.2", "--controller", "adaptive", "--json"]) == 1
    doc = json.loads(capsys.readouterr().out, **strict)
    assert doc["controllers"]["adaptive (Slotine-Li)"]["diverged"] is True


# -- item 1: inertias in the wrong unit are flagged, and refused under --strict -------------------
def _ur5_text(inertia_factor: float, units: str = "") -> str:
    import dataclasses

    import manipdyn as md

    ur5 = md.load("ur5")
    links = [dataclasses.replace(l, inertia=l.inertia * inertia_factor) for l in ur5.links]
    text = md.to_toml(_arm_like(ur5, links=links))
    if units:
        text = text.replace('length = "m"\nangle = "rad"\nmass = "kg"', units)
    return text


@pytest.mark.parametrize("factor, units, direction", [
    (1e6, "", "smaller"),          # kg mm^2 pasted into an SI file
    (1e7, "", "smaller"),          # g cm^2
    (1e9, "", "smaller"),          # g mm^2
    # SI values pasted into a file of mm and g (and lengths converted by hand to mm)
    (1.0, 'length = "m"\nangle = "rad"\nmass = "g"', "larger"),
])
def test_item1_implausible_inertia_units_are_flagged(factor, units, direction, tmp_path, capsys):
    import manipdyn as md
    from manipdyn._support.errors import ModelError

    path = tmp_path / "ur5_units.toml"
    text = _ur5_text(factor, units)
    if units:   # masses in g: multiply them so the arm keeps its kg, inertias stay "kg m^2" numbers
        import re
        text = re.sub(r"^mass = ([0-9.e+-]+)$", lambda m: f"mass = {float(m.group(1)) * 1000!r}", text,
                      flags=re.M)
        text = re.sub(r"(i[xyz]{2}) = ([0-9.e+-]+)", lambda m: f"{m.group(1)} = {float(m.group(2)) * 1e-6!r}",
                      text)   # kg m^2 -> (g m^2 = 1e3 kg m^2 ...): a 1e-6 slip, 1e-3 in the radius
    path.write_text(text)
    _arm, notes = md.load_with_notes(path)
    assert any("radius of gyration" in n and f"in a {direction} unit" in n for n in notes), notes
    with pytest.raises(ModelError, match="radius of gyration"):
        md.load(path, strict=True)
    # check --strict: notes are a failed condition (exit 1), as angle and length notes are
    assert main(["check", str(path), "--strict", "--samples", "2", "--timing-calls", "0"]) == 1
    out = capsys.readouterr().out
    assert "radius of gyration" in out and "STRICT" in out


def test_item1_bundled_and_saved_arms_have_no_gyration_note(tmp_path):
    import manipdyn as md

    for name in md.models():
        _arm, notes = md.load_with_notes(name)
        assert not [n for n in notes if "gyration" in n], (name, notes)
    path = tmp_path / "ur5.toml"
    path.write_text(_ur5_text(1.0))
    assert md.load_with_notes(path)[1] == []


# -- item 7: one BLAS thread where it pays; threadpoolctl optional; progress in the demo ----------
def _blas_threads_now():
    threadpoolctl = pytest.importorskip("threadpoolctl", reason="threadpoolctl (identify extra) not installed")
    pools = [p["num_threads"] for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas"]
    if not pools:
        pytest.skip("no BLAS thread pool in this process")
    return pools


def test_item7_blas_threads_limits_and_restores():
    from manipdyn._support.threads import blas_threads

    before = _blas_threads_now()
    with blas_threads(1) as lim:     # SciPy's own BLAS is loaded first, and limited too (issue 46 item 19)
        inside = _blas_threads_now()
        assert lim.limited and len(inside) >= len(before) and set(inside) == {1}
    assert _blas_threads_now()[:len(before)] == before


def test_item7_without_threadpoolctl_nothing_breaks(monkeypatch):
    from manipdyn._support.threads import blas_threads

    monkeypatch.setitem(sys.modules, "threadpoolctl", None)
    with blas_threads(1) as lim:
        assert lim.limited is False
    assert main(["models"]) == 0


def test_item7_cli_runs_commands_on_one_blas_thread(monkeypatch):
    import manipdyn.cli.models as models_cli

    _blas_threads_now()
    seen = []
    monkeypatch.setattr(models_cli, "run", lambda args: seen.append(_blas_threads_now()) or 0)
    assert main(["models"]) == 0 and set(seen[0]) == {1}
    assert main(["--blas-threads", "0", "models"]) == 0 and seen[1] == _blas_threads_now()


def test_item7_demo_shows_progress(capsys):
    pytest.importorskip("cvxpy", reason="the demo needs the identify extra")
    from manipdyn.identification.experiments.demo import run_demo

    run_demo("ur5", iterations=1, progress=True)
    err = capsys.readouterr().err
    for stage in ("optimising the excitation", "1/1 iterations", "fit: ols", "fit: consistent"):
        assert stage in err


# -- item 5: the README's identification commands run as written -----------------------------------
def _readme_block(after: str, lang: str) -> str:
    from pathlib import Path

    import guide

    text = guide.TEXT                                # the README and the guide's pages (issue 38 item 15)
    start = text.index(f"```{lang}\n", text.index(after)) + len(lang) + 4
    return text[start:text.index("```", start)]


def test_item5_readme_identification_commands_run_as_written(tmp_path, monkeypatch, capsys):
    import json
    import shlex

    pytest.importorskip("cvxpy", reason="identification needs the identify extra")
    monkeypatch.chdir(tmp_path)
    lines = [l.split("#")[0].strip() for l in _readme_block("# Identification from logs", "sh").splitlines()]
    commands = [shlex.split(l) for l in lines if l]
    assert [c[1] for c in commands] == ["excite", "synthesize", "identify", "check"]
    for argv in commands:
        assert argv[0] == "manipdyn"
        code = main(argv[1:])
        out = capsys.readouterr().out
        assert code == 0, (argv, out)
        if argv[1] == "identify":                         # --json: the fit, strict JSON
            import numpy as np

            doc = json.loads(out)
            tau = np.loadtxt(tmp_path / "data.csv", delimiter=",", skiprows=1)[:, -6:]
            sigma = 0.01 * np.abs(tau).max(axis=0)        # the noise synthesize added (--noise 0.01)
            # the fit explains everything but that noise: residual RMS / sigma within 10 %
            # (some 1700 samples: the RMS of Gaussian noise is within a few % of sigma; the
            # peak read back carries the noise too, 1 % of itself at most a few times over)
            ratio = np.array(doc["rms_residual"]) / sigma
            assert np.all(np.abs(ratio - 1) < 0.1), ratio
    assert (tmp_path / "ur5_identified.toml").is_file()


def test_item5_synthesize_is_exact_without_noise_and_names_bad_rows(tmp_path):
    import numpy as np

    import manipdyn as md
    from manipdyn._support.errors import ModelError
    from manipdyn.identification import read_trajectory, synthesize

    arm = md.load("ur5")
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.standard_normal((50, 6)) for _ in range(3))
    assert np.array_equal(synthesize(arm, q, qd, qdd, noise=0.0), arm.inverse_dynamics(q, qd, qdd))
    a, b = synthesize(arm, q, qd, qdd, seed=3), synthesize(arm, q, qd, qdd, seed=3)
    assert np.array_equal(a, b) and not np.array_equal(a, synthesize(arm, q, qd, qdd, seed=4))
    header = "t," + ",".join(f"{p}{i}" for p in ("q", "qd", "qdd") for i in range(1, 7))
    rows = [",".join(["0"] * 19), ",".join(["0.01"] * 18 + ["x"])]
    (tmp_path / "t.csv").write_text(header + "\n" + "\n".join(rows) + "\n")
    with pytest.raises(ModelError, match=r"row 3, column 19 \('qdd6'\)"):
        read_trajectory(tmp_path / "t.csv", 6)
    with pytest.raises(ModelError, match="expected the header"):
        read_trajectory(tmp_path / "t.csv", 7)
    assert main(["synthesize", "ur5", "/dev/zero", "-o", str(tmp_path / "d.csv")]) == 2


def test_a_trajectory_of_positions_alone_is_read_with_derivatives_false(tmp_path):
    """The one trajectory reader (formats/logs/trajectory.py, on the log reader's CSV parser) reads
    ``t,q1..qn`` when asked for positions alone, and refuses it where derivatives are needed."""
    import numpy as np

    from manipdyn._support.errors import ModelError
    from manipdyn.formats.logs import read_trajectory

    f = tmp_path / "path.csv"
    f.write_text("t,q1,q2\n0,0.1,0.2\n0.5,0.3,0.4\n1.0,0.5,0.6\n")
    traj = read_trajectory(f, 2, derivatives=False)
    assert np.array_equal(traj.t, [0, 0.5, 1.0]) and np.array_equal(traj.q[:, 1], [0.2, 0.4, 0.6])
    assert traj.qd is None and traj.qdd is None
    with pytest.raises(ModelError, match="expected the header t,q1,q2,qd1,qd2,qdd1,qdd2"):
        read_trajectory(f, 2)
    f.write_text("t,q1,q2\n0,0.1,0.2\n0,0.3,0.4\n")
    with pytest.raises(ModelError, match=r"column 't' must increase strictly \(row 3\)"):
        read_trajectory(f, 2, derivatives=False)


# -- item 4: the README's Monte-Carlo snippet runs as a script -------------------------------------
def _run_script(path, tmp_path):
    import os
    import subprocess
    from pathlib import Path

    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    return subprocess.run([sys.executable, str(path)], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=900)


def test_item4_readme_montecarlo_snippet_runs_as_a_script(tmp_path):
    pytest.importorskip("distributed", reason="the scale extra is not installed")
    script = tmp_path / "study.py"
    script.write_text(_readme_block("`--json` prints every figure", "python"))
    proc = _run_script(script, tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "computed torque" in proc.stdout and "adaptive" in proc.stdout
    assert "Traceback" not in proc.stderr and "Nanny" not in proc.stderr


def test_item4_unguarded_script_fails_in_one_message(tmp_path):
    pytest.importorskip("distributed", reason="the scale extra is not installed")
    script = tmp_path / "unguarded.py"
    script.write_text("import warnings; warnings.simplefilter('ignore')\n"
                      "import manipdyn as md\nfrom manipdyn import montecarlo as mc\n"
                      "study = mc.study(md.load('ur5'), runs=2, seed=1, controllers=('ct',), duration=0.1)\n"
                      "report = mc.run(study, workers=1)\n")
    proc = _run_script(script, tmp_path)
    assert proc.returncode == 1
    assert "if __name__ ==" in proc.stderr and "Nanny failed to start" in proc.stderr
    assert proc.stderr.count("Traceback") == 1 and len(proc.stderr.splitlines()) < 30


# -- item 9: Ctrl-C stops montecarlo and bench quietly, exit 130, nothing left behind ---------------
def _interrupt_after(seconds: float, argv, cwd, after_children: bool = False, after_output: bool = False):
    """Run ``manipdyn ARGV``; Ctrl-C it ``seconds`` after it started (``after_children``: after
    its first child process, a Dask worker, appeared; ``after_output``: after its first line on
    stdout, i.e. once it is at work, whatever the machine's load); return (exit code, stderr).

    The child gets SIGINT's default action, as a terminal's foreground job has it, even when this
    test runs under a shell that started it in the background (``tests/common.py``)."""
    from common import sigint_as_a_terminal_gives_it

    import os
    import signal
    import subprocess
    import time
    from pathlib import Path

    def children():                 # of any thread: Dask starts its workers from its loop's thread
        found = []
        for task in Path(f"/proc/{proc.pid}/task").glob("*"):
            try:
                found += (task / "children").read_text().split()
            except OSError:
                pass
        return found

    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    proc = subprocess.Popen([sys.executable, "-m", "manipdyn", *argv], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=sigint_as_a_terminal_gives_it)
    try:
        t0 = time.monotonic()
        while after_children and not children() and time.monotonic() - t0 < 120:
            time.sleep(0.02)
        if after_output:
            assert proc.stdout.readline(), "ended before it printed anything"
        time.sleep(seconds)
        assert proc.poll() is None, "finished before the interrupt: make the run longer"
        os.killpg(proc.pid, signal.SIGINT)            # Ctrl-C: the whole process group, as a terminal does
        _out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:                       # never leave the run (or its workers) behind
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    return proc.returncode, err


@pytest.mark.parametrize("seconds", [0.0, 0.5, 4.0])     # as the workers start; while the study runs
def test_item9_montecarlo_ctrl_c_is_quiet(seconds, tmp_path):
    pytest.importorskip("distributed", reason="the scale extra is not installed")
    code, err = _interrupt_after(seconds, ["montecarlo", "puma560", "--runs", "5000", "--no-progress",
                                           "--plot", str(tmp_path / "mc.png")], tmp_path, after_children=True)
    assert code == 130 and err.strip().splitlines() == ["manipdyn: interrupted"], err[-3000:]
    assert list(tmp_path.iterdir()) == []


def test_item9_bench_ctrl_c_is_quiet_and_removes_its_folder(tmp_path):
    from pathlib import Path

    if not (Path(__file__).resolve().parents[1] / "benchmarks" / "run.py").is_file():
        pytest.skip("no benchmark suite beside the package")
    out = tmp_path / "run"
    code, err = _interrupt_after(1.0, ["bench", "--no-rtb", "--out", str(out)], tmp_path, after_output=True)
    assert code == 130 and "Traceback" not in err, err[-3000:]
    assert err.strip().splitlines()[-1] == "manipdyn bench: interrupted"
    assert not out.exists()


# -- item 14: figure legends never cover data; the Monte-Carlo figure is not a strip -------------
def _legend_overlaps(fig):
    """(legend extent, axes extent) pairs where a legend overlaps axes that draw lines."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    legends = [a.get_legend() for a in fig.axes if a.get_legend() is not None] + list(fig.legends)
    data_axes = [a for a in fig.axes if a.lines]
    return [(lg, ax) for lg in legends for ax in data_axes
            if lg.get_window_extent(r).overlaps(ax.get_window_extent(r))]


def test_item14_montecarlo_legend_off_the_data(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib", reason="the plot extra is not installed")
    import manipdyn as md
    import manipdyn.control.montecarlo.plot as mcplot
    from manipdyn import montecarlo as mc

    figs = []
    monkeypatch.setattr(mcplot, "save_figure", lambda fig, path: figs.append(fig))
    monkeypatch.setattr(mcplot.pyplot(), "close", lambda fig=None: None)
    report = mc.run(mc.study(md.load("ur5"), runs=6, seed=1, duration=0.3), scheduler="sync")
    mcplot.plot_report(report, str(tmp_path / "mc.png"))
    (fig,) = figs
    assert not _legend_overlaps(fig)
    w, h = fig.get_size_inches()
    assert w / h <= 2.0              # was 15 x 4.2 (3.6)


def test_item14_scaling_legend_off_the_lines(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib", reason="the plot extra is not installed")
    import json
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    from benchmarks import scaling as bench_scaling
    import matplotlib.pyplot as plt

    figs = []
    monkeypatch.setattr(plt, "close", lambda fig=None: figs.append(fig))
    ref = json.loads((root / "benchmarks" / "results" / "reference.json").read_text())["scaling"]
    bench_scaling.plot_scaling(ref["n"], ref["median_s"], ref["exponents"], str(tmp_path))
    (fig,) = figs
    assert not _legend_overlaps(fig)


# -- item 8: README facts -------------------------------------------------------------------------
def _readme() -> str:
    from pathlib import Path

    import guide

    return guide.TEXT                                # the README and the guide's pages (issue 38 item 15)


def test_item8_readme_states_python_version_sizes_and_seed_source():
    import re
    import tomllib
    from pathlib import Path

    text = _readme()
    project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"]
    version = re.fullmatch(r">=(\d+\.\d+)", project["requires-python"]).group(1)
    assert f"Python {version} or later" in text
    assert re.search(r"`pip install -e \.`\s+about [0-9.]+ GB", text)
    assert re.search(r"`pip install -e '\.\[test\]'`.*about [0-9.]+ GB", text, re.S)
    assert '"Manipulator Mathematical Model"' in text and "## Sources" in text


def test_item8_example_robot_data_missing_is_a_clear_message(monkeypatch):
    """example-robot-data is a core dependency (fixed by the project's design); a broken install
    without it gets the install command, not a traceback."""
    import importlib.metadata
    import tomllib
    from pathlib import Path

    import manipdyn.formats.erd as erd
    from manipdyn._support.errors import ModelError

    project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"]
    assert any(d.startswith("example-robot-data") for d in project["dependencies"])

    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)

    erd.robots_dir.cache_clear()
    monkeypatch.setattr(importlib.metadata, "distribution", missing)
    try:
        with pytest.raises(ModelError, match=r"pip install example-robot-data"):
            erd.urdf_path("ur5_robot")
    finally:
        erd.robots_dir.cache_clear()
