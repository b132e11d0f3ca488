"""The command line: exit codes, one-line errors, JSON, URDF output."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from manipdyn.cli import main


def test_help_lists_commands(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "check" in out and "Exit codes" in out


def test_check_all_agrees(capsys):
    assert main(["check", "--all", "--samples", "20", "--timing-calls", "3"]) == 0
    out = capsys.readouterr().out
    assert "puma560" in out and "all agree" in out and "per call" in out


def test_check_json_and_urdf_out(tmp_path, capsys):
    assert main(["check", "stanford", "--samples", "10", "--timing-calls", "0", "--json",
                 "--urdf-out", str(tmp_path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc[0]["report"]["ok"] is True
    assert set(doc[0]["report"]["quantities"]) >= {"D", "h", "g", "tau", "qdd", "fk"}
    assert (tmp_path / "stanford.urdf").read_text().startswith("<?xml")


def test_unknown_model_is_exit_2_one_line(capsys):
    assert main(["check", "nosuch"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown model 'nosuch'" in err[0] and "puma560" in err[0]


def test_no_model_is_usage_error(capsys):
    assert main(["check"]) == 2


def test_bad_option_is_exit_2():
    with pytest.raises(SystemExit) as exc:
        main(["check", "--samples", "many"])
    assert exc.value.code == 2


def test_disagreement_is_exit_1(monkeypatch, capsys):
    import manipdyn.check as check

    monkeypatch.setattr(check, "TOLERANCE", -1.0)  # nothing can pass a negative tolerance
    monkeypatch.setattr(check.QuantityError, "tolerance", -1.0, raising=False)
    real = check._compare
    monkeypatch.setattr(check, "_compare", lambda *a, **k: real(*a, tol=-1.0))
    assert main(["check", "stanford", "--samples", "5", "--timing-calls", "0"]) == 1
    assert "DISAGREE" in capsys.readouterr().out


def test_python_dash_m(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n')
    r = subprocess.run([sys.executable, "-m", "manipdyn", "check", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert "bad.toml: missing key 'convention'" in r.stderr


def _arm_named(tmp_path, name):
    import manipdyn as md

    links = [md.DHLink(a=0.3, mass=1.0, com=(-0.15, 0, 0), inertia=[0.001, 0.01, 0.01])]
    path = tmp_path / f"m{abs(hash(name))}.toml"
    md.Manipulator(links, convention="standard", name=name, source="test").save(path)
    return str(path)


def test_urdf_names_are_made_safe_and_never_collide(tmp_path, capsys):
    out = tmp_path / "out"
    escaping = _arm_named(tmp_path, "../escaped")
    assert main(["urdf", escaping, str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["escaped.urdf"]
    assert not (tmp_path / "escaped.urdf").exists()
    empty = _arm_named(tmp_path, "")
    assert main(["urdf", empty, str(out)]) == 0
    assert (out / "arm.urdf").exists()
    twin = _arm_named(tmp_path, "../escaped/")   # same safe name as the first
    assert main(["urdf", escaping, twin, str(out)]) == 2
    assert "would both be written to escaped.urdf" in capsys.readouterr().err


def test_urdf_outdir_that_is_a_file_is_one_line(tmp_path, capsys):
    f = tmp_path / "plain"
    f.write_text("x")
    assert main(["urdf", "stanford", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "OUTDIR" in err[0] and "cannot create the folder" in err[0]
