"""A massless arm, subnormal masses and a solver's panic in the completion (issue 46, item 21).

``manipdyn mjcf MODEL OUT`` (and ``urdf``) on an arm whose every link has mass 0 and zero
inertia (which ``load`` and ``check`` accept) made Clarabel panic inside the completion: a Rust
backtrace and a Python traceback, because pyo3's ``PanicException`` is a ``BaseException`` that the
CLI's ``except Exception`` misses; a 5e-324 mass on every link gave exit 3 ("data contains NaN").
Now: a massless arm is refused by the completion with one line (the MJCF, which MuJoCo would
refuse) or written as it is (the URDF holds it exactly); subnormal parameters are taken as 0 with
a note; and a solver's panic is that solver's failure, never a BaseException out of the library.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support.errors import is_solver_panic
from manipdyn.cli import main

pytest.importorskip("cvxpy", reason="cvxpy (the identify extra) is not installed: no completion")

from pathlib import Path  # noqa: E402

UR5 = Path(md.__file__).parent / "formats" / "models" / "ur5.toml"


def _ur5_with(tmp_path, mass: str, which=None, name="arm.toml") -> Path:
    """The bundled UR5's file with ``mass`` and zero inertia and COM on the links ``which`` (all by default)."""
    text = UR5.read_text(encoding="utf-8")
    parts = re.split(r"(?m)^(?=\[\[links\]\])", text)
    for k in range(1, len(parts)):
        if which is None or k in which:
            p = re.sub(r"(?m)^mass = .*$", f"mass = {mass}", parts[k])
            p = re.sub(r"inertia = \{[^}]*\}", "inertia = { ixx = 0.0, iyy = 0.0, izz = 0.0, ixy = 0.0, ixz = 0.0, "
                       "iyz = 0.0 }", p)
            parts[k] = re.sub(r"(?m)^com = .*$", "com = [0.0, 0.0, 0.0]", p)
    path = tmp_path / name
    path.write_text("".join(parts), encoding="utf-8")
    return path


@pytest.mark.parametrize("mass", ["0.0", "5e-324"])
def test_massless_arm_mjcf_is_one_line_exit_2(tmp_path, capsys, mass):
    """Fails on the code before: a PanicException (mass 0) out of main(), or exit 3 / a solver's
    'no physical arm at all' after minutes (5e-324)."""
    model = _ur5_with(tmp_path, mass)
    assert main(["mjcf", str(model), str(tmp_path / "out.xml")]) == 2
    err = capsys.readouterr().err
    assert "every link of the arm is massless" in err and "--as-published" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "out.xml").exists()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        arm = md.load(str(model))
    with pytest.raises(md.ModelError, match="massless.*as_published=True"):
        md.to_mjcf(arm)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert "<mujoco" in md.to_mjcf(arm, as_published=True)    # what was asked: as the model has it


@pytest.mark.parametrize("mass", ["0.0", "5e-324"])
def test_massless_arm_urdf_is_written_as_it_is(tmp_path, capsys, mass):
    """A URDF holds a massless arm exactly: no completion, exit 0, the masses as the model has them."""
    model = _ur5_with(tmp_path, mass)
    assert main(["urdf", str(model), str(tmp_path / "out")]) == 0
    assert "Traceback" not in capsys.readouterr().err
    text = (tmp_path / "out" / "ur5.urdf").read_text(encoding="utf-8")
    masses = [float(m) for m in re.findall(r'<mass value="([^"]+)"', text)]
    # a massless link is written without <inertial> (URDF's own massless link), a subnormal one as given
    assert len(masses) == (0 if float(mass) == 0 else 6) and all(m == float(mass) for m in masses), masses


def test_a_subnormal_mass_is_taken_as_zero_with_a_note(tmp_path):
    """One link of 5e-324 kg (and no inertia) among real ones: the completion works in the arm's units
    with that mass as 0, and says so."""
    from manipdyn.model.completion import complete_bodies

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        arm = md.load(str(_ur5_with(tmp_path, "5e-324", which={6})))
    bodies, c = complete_bodies(arm)
    assert any("subnormal" in x and "link 6 entry 0" in x for x in c.notes), c.notes
    assert all(np.isfinite(b.mass) and b.mass > 1e-15 for b in bodies)
    # wrist 3's mass is identifiable, so a massless wrist 3 has no exact completion: the nearest arm
    # (bodies at the margin J >= 1e-9 I) differs by 1.5e-9 of the largest torque, measured; a decade over it
    assert not c.exact and c.torque_rtol < 1e-8, c.summary()


class PanicException(BaseException):
    """Stands for pyo3's (raised by Clarabel's Rust code): same name, same module, a BaseException."""


PanicException.__module__ = "pyo3_runtime"


class _PanickingProblem:
    status = None

    def solve(self, solver=None):
        raise PanicException("Eigval error: Eigen(1)")

    def variables(self):
        return []


def test_solver_panics_are_solver_failures():
    """Both solver wrappers keep a panic as that solver's failure: the completion's answers None (its
    callers raise ModelError), the fit's raises ModelError naming it; Ctrl-C still goes through."""
    import cvxpy as cp

    from manipdyn.identification.estimation import solvers
    from manipdyn.model import completion

    assert is_solver_panic(PanicException("x")) and not is_solver_panic(KeyboardInterrupt())
    assert not is_solver_panic(RuntimeError("x"))
    assert completion._solve(cp, _PanickingProblem()) is None
    with pytest.raises(md.ModelError, match="panicked"):
        solvers.solve(cp, _PanickingProblem(), "a test")

    class Interrupted(_PanickingProblem):
        def solve(self, solver=None):
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        completion._solve(cp, Interrupted())
