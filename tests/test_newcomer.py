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
    import manipdyn.limits as limits
    from manipdyn.montecarlo import check_study_size

    with pytest.raises(ValueError, match="MAX_STUDY_STEPS"):
        check_study_size(10**6, 4, 2.0, 1e-3, 10.0)
    monkeypatch.setattr(limits, "MAX_STUDY_STEPS", 1e10)
    check_study_size(10**6, 4, 2.0, 1e-3, 10.0)          # raised: accepted


def test_item15_scheduler_without_workers_times_out(monkeypatch, capsys):
    distributed = pytest.importorskip("distributed", reason="the scale extra is not installed")
    import manipdyn.scale as scale

    monkeypatch.setattr(scale, "WORKER_WAIT_S", 1.0)
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        assert main(["montecarlo", "puma560", "--runs", "1", "--duration", "0.05",
                     "--scheduler", cluster.scheduler_address]) == 2
    line = _err_line(capsys)
    assert "no worker" in line and "dask worker" in line


# -- item 19: exit 2, never 3, on bad excite and montecarlo options ---------------------------
@pytest.mark.parametrize("argv, culprit", [
    (["excite", "ur5", "--duration", "0.005"], "--rate x --duration"),
    (["excite", "ur5", "--rate", "1e-9"], "--rate x --duration"),
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
    from manipdyn.errors import ModelError

    arm = _arm_like(md.load("ur5"), description="x" * (2 * 1024 * 1024))
    with pytest.raises(ModelError, match="MAX_MODEL_FILE_BYTES"):
        md.save(arm, tmp_path / "long.toml")
    assert not (tmp_path / "long.toml").exists()


def test_item3_extreme_valid_models_round_trip(tmp_path):
    import dataclasses

    import numpy as np

    import manipdyn as md
    import manipdyn.limits as limits

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
    from manipdyn.errors import ModelError

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
    tiny = [m for m in re.findall(r"-?[0-9.]+e-[0-9]+", text) if abs(float(m)) < 1e-12]
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
    from manipdyn.erd import urdf_names

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
    assert set(doc["controllers"]) == {"PD", "PD + gravity", "computed torque", "adaptive (Slotine-Li)"}
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
    from manipdyn.errors import ModelError

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
