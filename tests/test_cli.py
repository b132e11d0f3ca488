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
    import manipdyn.check.crosscheck as check

    real = check._compare  # nothing can pass a negative tolerance
    monkeypatch.setattr(check, "_compare", lambda *a, **k: real(*a, tol=-1.0))
    assert main(["check", "stanford", "--samples", "5", "--timing-calls", "0"]) == 1
    assert "DISAGREE" in capsys.readouterr().out


def test_python_dash_m(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('format = "manipdyn-model/1"\nname = "x"\n')
    r = subprocess.run([sys.executable, "-m", "manipdyn", "check", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert "bad.toml: missing key 'convention'" in r.stderr


def _arm_named(tmp_path, name):
    import manipdyn as md

    links = [md.DHLink(a=0.3, mass=1.0, com=(-0.15, 0, 0), inertia=[0.001, 0.01, 0.01])]
    path = tmp_path / f"m{abs(hash(name))}.toml"
    md.save(md.Manipulator(links, convention="standard", name=name, source="test"), path)
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


NOMASS = """<robot name="nomass">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0.1 0 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit effort="1" velocity="1" lower="-1" upper="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.2 0 0"/>
    <axis xyz="0 0 1"/><limit effort="1" velocity="1" lower="-1" upper="1"/></joint>
</robot>
"""


def test_singular_mass_matrix_is_named_not_a_crash(tmp_path, capsys):
    """A joint that moves no mass: D is singular, forward dynamics is undefined."""
    import numpy as np
    import manipdyn as md

    path = tmp_path / "nomass.urdf"
    path.write_text(NOMASS)
    # a quantity that cannot be compared is a failed condition (exit 1), never "all agree" (issue 11)
    assert main(["check", str(path), "--samples", "10", "--timing-calls", "2"]) == 1
    out = capsys.readouterr().out
    assert "qdd not compared" in out and "joint(s) [2] move no mass" in out and "all agree" not in out
    with pytest.warns(md.PhysicalConsistencyWarning, match="moves no mass"):
        arm = md.load(str(path))
    for eng in (arm.pinocchio, arm.lagrange, arm):
        with pytest.raises(md.SingularMassMatrixError, match=r"joint\(s\) \[2\] move no mass"):
            eng.forward_dynamics(np.zeros(2), np.zeros(2), np.ones(2))
