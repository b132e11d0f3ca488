"""The C benchmark of the generated code against Pinocchio's C++ (issue 26, item 4):
the drivers read the shared states file, time the four calls and write their answers,
and the harness flags a wrong answer.  No times are asserted."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import bench_codegen as bc  # noqa: E402  (the repository root is on sys.path above)

import manipdyn as md  # noqa: E402

# A 1-joint pendulum written by hand with the generated header's signatures (a test
# fixture for the driver, not generated code): point mass M at length L on a joint
# about z, gravity along -y of the base, so g(q) = M G L cos q, D = M L^2 + ROTOR.
PEND_H = """#ifndef PEND_H
#define PEND_H
#define pend_NQ 1
void pend_inverse_dynamics(const double *q, const double *qd, const double *qdd, double *tau);
void pend_mass_matrix(const double *q, double *M);
void pend_gravity(const double *q, double *g);
void pend_nonlinear_effects(const double *q, const double *qd, double *h);
void pend_forward_dynamics(const double *q, const double *qd, const double *tau, double *qdd);
void pend_inverse_dynamics_derivatives(const double *q, const double *qd, const double *qdd,
                                       double *dtau_dq, double *dtau_dqd);
void pend_forward_dynamics_derivatives(const double *q, const double *qd, const double *tau,
                                       double *dqdd_dq, double *dqdd_dqd, double *dqdd_dtau);
void pend_regressor(const double *q, const double *qd, const double *qdd, double *Y);
#endif
"""
PEND_C = """#include <math.h>
#include "pend.h"
#define MGL (MASS * 9.81 * 0.5)
#define D0 (MASS * 0.25 + 0.01)
void pend_mass_matrix(const double *q, double *M) { (void)q; M[0] = D0; }
void pend_gravity(const double *q, double *g) { g[0] = MGL * cos(q[0]); }
void pend_nonlinear_effects(const double *q, const double *qd, double *h) { (void)qd; h[0] = MGL * cos(q[0]); }
void pend_inverse_dynamics(const double *q, const double *qd, const double *qdd, double *tau)
{ (void)qd; tau[0] = D0 * qdd[0] + MGL * cos(q[0]); }
void pend_forward_dynamics(const double *q, const double *qd, const double *tau, double *qdd)
{ (void)qd; qdd[0] = (tau[0] - MGL * cos(q[0])) / D0; }
void pend_inverse_dynamics_derivatives(const double *q, const double *qd, const double *qdd,
                                       double *dq, double *dqd)
{ (void)qd; (void)qdd; dq[0] = -MGL * sin(q[0]); dqd[0] = 0.0; }
void pend_forward_dynamics_derivatives(const double *q, const double *qd, const double *tau,
                                       double *a, double *b, double *c)
{ (void)qd; (void)tau; a[0] = MGL * sin(q[0]) / D0; b[0] = 0.0; c[0] = 1.0 / D0; }
void pend_regressor(const double *q, const double *qd, const double *qdd, double *Y)
{ (void)qd; Y[0] = qdd[0]; Y[1] = cos(q[0]); }
"""


def _pendulum_answers(q, qd, qdd, tau, mass=1.0):
    mgl, d0 = mass * 9.81 * 0.5, mass * 0.25 + 0.01
    k = len(q)
    return {"tau": d0 * qdd + mgl * np.cos(q), "M": np.full((k, 1, 1), d0),
            "qdd": (tau - mgl * np.cos(q)) / d0, "dtau_dq": (-mgl * np.sin(q)).reshape(k, 1, 1),
            "dtau_dqd": np.zeros((k, 1, 1)), "ddq_dq": (mgl * np.sin(q) / d0).reshape(k, 1, 1),
            "ddq_dv": np.zeros((k, 1, 1)), "Minv": np.full((k, 1, 1), 1.0 / d0)}


@pytest.fixture
def pendulum(tmp_path):
    """(build(mass) -> binary, states file, (q, qd, qdd, tau)) for the pendulum."""
    if bc.compiler_version(os.environ.get("CC") or "cc") is None:
        pytest.skip("no C compiler (cc, or $CC)")
    rng = np.random.default_rng(3)
    q, qd, qdd, tau = (rng.uniform(-2.0, 2.0, (7, 1)) for _ in range(4))
    states = tmp_path / "states.txt"
    states.write_text(bc.states_text(q, qd, qdd, tau, [0.0, -9.81, 0.0], [0.01]))

    def build(mass):
        gen = tmp_path / f"gen{mass}"
        gen.mkdir()
        (gen / "pend.h").write_text(PEND_H)
        (gen / "pend.c").write_text(f"#define MASS {mass!r}\n" + PEND_C)
        binary = tmp_path / f"pend{mass}"
        bc.build_generated(gen, "pend", ("-O2",), binary)
        return binary

    return build, states, (q, qd, qdd, tau)


def test_generated_driver_reads_the_states_and_writes_the_answers(pendulum, tmp_path):
    build, states, (q, qd, qdd, tau) = pendulum
    binary = build(1.0)
    dump = tmp_path / "pend.dump"
    subprocess.run([str(binary), str(states), "1", "1", str(dump)], check=True, capture_output=True)
    got = bc.read_dump(dump, 1, len(q))
    errors = bc.rel_errors(got, _pendulum_answers(q, qd, qdd, tau))
    # the C and numpy evaluate the same expressions: equal to a few units of rounding
    assert max(errors.values()) <= 1e-14, errors
    assert bc.problems(errors) == []


def test_a_wrong_answer_is_flagged(pendulum, tmp_path):
    build, states, (q, qd, qdd, tau) = pendulum
    wrong = build(1.001)                   # a pendulum 0.1 % heavier than the reference
    dump = tmp_path / "wrong.dump"
    subprocess.run([str(wrong), str(states), "1", "1", str(dump)], check=True, capture_output=True)
    errors = bc.rel_errors(bc.read_dump(dump, 1, len(q)), _pendulum_answers(q, qd, qdd, tau))
    bad = bc.problems(errors)
    assert any(b.startswith("tau ") for b in bad) and any(b.startswith("M ") for b in bad), bad


def test_interleaved_runs_give_every_call_and_paired_ratios(pendulum):
    build, states, _ = pendulum
    a, b = build(1.0), build(2.0)
    runs = bc.interleave({"generated": [str(a), str(states)], "pinocchio-header": [str(b), str(states)]},
                         outer=3, inner=4)
    assert [len(r) for r in runs["generated"]] == [4, 4, 4]          # inner rounds per outer run
    s = bc.summarize(runs, "generated")
    for op in bc.OPS:
        assert s["generated"][op]["median_ns"] > 0 and s["generated"][op]["blocks"] == 12
        r = s["generated"][op]["ratio_to_pinocchio-header"]
        assert math.isfinite(r) and r > 0
    assert "ratio_to_generated" not in s["pinocchio-header"]["mass_matrix"]


def test_driver_sources_compile_cleanly(pendulum, tmp_path):
    """generated_timing.c is C99 without warnings under the generated code's own flags."""
    build, _, _ = pendulum
    build(1.0)
    cc = os.environ.get("CC") or "cc"
    res = subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-fsyntax-only",
                          "-DMDPREFIX=pend", f"-I{tmp_path / 'gen1.0'}", str(bc.C_DIR / "generated_timing.c")],
                         capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stderr


def test_quick_run_against_pinocchio_cpp(tmp_path):
    """The whole benchmark on ur5, quick: Pinocchio's C++ (the wheel's) must answer as
    manipdyn's Pinocchio engine does; the generated C too when md.codegen exists.
    The first run compiles Pinocchio's driver (minutes); later runs take seconds
    (the binary is cached in benchmarks/results/runs/cache/)."""
    if bc.compiler_version(os.environ.get("CXX") or "c++") is None:
        pytest.skip("no C++ compiler (c++, or $CXX)")
    try:
        bc.pinocchio_flags()
    except bc.Unavailable as exc:   # CI has no Eigen: it does not install system packages for this
        pytest.skip(f"Pinocchio's C++ cannot be built here: {exc}")
    out = tmp_path / "run"
    assert bc.main(["--quick", "--arms", "ur5", "--out", str(out)]) == 0
    res = json.loads((out / "results.json").read_text())
    assert res["environment"]["cxx_version"] and res["environment"]["blas_config"] is not None
    (arm,) = res["results"]
    assert arm["problems"] == []
    for errors in arm["pinocchio_cpp_vs_python"].values():
        assert max(errors.values()) <= 1e-10
    times = arm["rows"]["O2"]["times"]
    assert all(times["pinocchio-library"][op]["median_ns"] > 0 for op in bc.OPS)
    if "generated" not in arm:           # md.codegen exists and wrote the arm's C
        row = arm["rows"]["O2"]
        assert max(row["generated_errors"].values()) <= 1e-9
        assert set(row["verdicts"]) == set(bc.OPS)
    else:
        assert not hasattr(md, "codegen") or "md.codegen failed" in arm["generated"]
