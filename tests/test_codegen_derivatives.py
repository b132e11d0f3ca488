"""Forward-dynamics derivatives in the generated C (issue 34 item 1).

``P_forward_dynamics_derivatives(q, qd, tau, dqdd_dq, dqdd_dqd, dqdd_dtau)``
and its ``_batch`` twin: row-major ``[i*n + m] = d qdd_i / d x_m``,
``dqdd_dtau = M^-1``, rotors through a coupled transmission and the friction
law included.  Checked against raw Pinocchio's ``computeABADerivatives``
(``ddq_dq``, ``ddq_dv``, ``Minv``) on rigid arms (every bundled arm, the
Panda without its friction law, every file in ``urdf/``, seeded random
arms), and against both other engines on drive models (coupled rotors and
every friction law).

Builds use ``-O0`` (fast to compile; the numbers are -O2's: ``-std=c99``
forbids fused multiply-adds).  Tolerance: 1e-10 relative, the issue's, in
the cross-check's measure ``max |x - ref| / max(1, max |ref|)``; healthy
float64 answers agree to about 1e-13 (a few hundred ulp of the largest
entry after an LDL^T of a matrix of condition up to ~1e3).
"""

from __future__ import annotations

import ctypes
import glob
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn.check.crosscheck import draw_states
from manipdyn.model.friction import Friction
from tests.arms import random_arm

pytest.importorskip("casadi", reason="generating C needs CasADi: pip install 'manipdyn[codegen]'")
pin = pytest.importorskip("pinocchio", reason="the reference is raw Pinocchio: pip install 'manipdyn[fast]'")

from manipdyn.engines.c import build, compiled_engine, generate  # noqa: E402
from manipdyn.engines.c.engine import library_for  # noqa: E402
from manipdyn.engines.pinocchio.engine import model_for_arm  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
needs_cc = pytest.mark.skipif(build.find_compiler() is None, reason="no C compiler ($CC, cc or gcc) on this machine")
#: the issue's bound, relative (module docstring)
TOL = 1e-10
SIGNATURE = ("void {p}_forward_dynamics_derivatives(const double *q, const double *qd, const double *tau, "
             "double *dqdd_dq, double *dqdd_dqd, double *dqdd_dtau);")


@pytest.fixture(scope="module", autouse=True)
def _build_cache(tmp_path_factory):
    """One build cache for the module, not the user's."""
    old = os.environ.get(build.CACHE_ENV)
    os.environ[build.CACHE_ENV] = str(tmp_path_factory.mktemp("manipdyn-cache"))
    yield
    if old is None:
        os.environ.pop(build.CACHE_ENV, None)
    else:
        os.environ[build.CACHE_ENV] = old


def _load(spec):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")         # the published Puma data's notes are tested elsewhere
        return md.load(spec)


def _rel(x, ref) -> float:
    return float(np.max(np.abs(x - ref)) / max(1.0, float(np.max(np.abs(ref)))))


def _rigid(arm):
    """``arm`` as Pinocchio's rigid model holds it: no friction law (bundled Panda: its sigmoid law)."""
    if arm.friction_model is None and arm.friction is None and arm.transmission.is_diagonal:
        return arm
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.Manipulator(arm.links, arm.convention, gravity=arm.gravity, name=f"{arm.name}_rigid")


def _c_call(arm, q, qd, tau):
    """The three outputs of ``md_forward_dynamics_derivatives_batch`` through ctypes, (N, n, n) each."""
    lib = ctypes.CDLL(library_for(arm, opt="-O0"))
    f = lib.md_forward_dynamics_derivatives_batch
    f.restype = None
    f.argtypes = [ctypes.c_long] + [ctypes.c_void_p] * 6
    xs = [np.ascontiguousarray(x, dtype=np.float64) for x in (q, qd, tau)]
    N, n = xs[0].shape
    outs = [np.full((N, n, n), np.nan) for _ in range(3)]
    f(N, *[x.ctypes.data for x in xs], *[o.ctypes.data for o in outs])
    return outs


def _against_raw_pinocchio(arm, samples=8, seed=0):
    """The C (by ctypes, in one batch) against ``pin.computeABADerivatives`` state by state."""
    arm = _rigid(arm)
    model = model_for_arm(arm)
    data = model.createData()
    q, qd, _ = draw_states(arm, samples, seed=seed)
    tau = arm.pinocchio.inverse_dynamics(q, qd, np.random.default_rng(seed).normal(size=q.shape))
    got = _c_call(arm, q, qd, tau)
    for k in range(samples):
        ref = [np.array(x) for x in pin.computeABADerivatives(model, data, q[k], qd[k], tau[k])]
        for name, x, r in zip(("ddq_dq", "ddq_dv", "Minv"), (g[k] for g in got), ref):
            assert _rel(x, r) <= TOL, f"{arm.name} state {k}: {name} off by {_rel(x, r):.2e} (relative)"


@needs_cc
def test_the_header_declares_the_function_and_its_batch_twin(tmp_path):
    arm = random_arm(4, n=3)
    h, c, note = md.codegen(arm, tmp_path, prefix="drv")      # also the strict -pedantic -Werror compile
    assert "test-compiled" in note
    hdr = Path(h).read_text()
    assert SIGNATURE.format(p="drv") in hdr
    assert ("void drv_forward_dynamics_derivatives_batch(long N, const double *q, const double *qd, "
            "const double *tau, double *dqdd_dq, double *dqdd_dqd, double *dqdd_dtau);") in hdr
    assert "malloc" not in Path(c).read_text()


@needs_cc
@pytest.mark.parametrize("name", md.models())
def test_bundled_arms_match_raw_pinocchio_aba_derivatives(name):
    _against_raw_pinocchio(_load(name))


@needs_cc
@pytest.mark.parametrize("path", sorted(glob.glob(str(ROOT / "urdf" / "*.urdf"))), ids=os.path.basename)
def test_urdf_files_match_raw_pinocchio_aba_derivatives(path):
    _against_raw_pinocchio(_load(path))


@needs_cc
@pytest.mark.parametrize("seed", range(12))
def test_random_arms_match_raw_pinocchio_aba_derivatives(seed):
    """Seeded random DH arms (1 to 8 joints, R and P, standard or modified, diagonal rotors or none)."""
    _against_raw_pinocchio(random_arm(seed), samples=4, seed=seed)


def _drive_arm(law: str, seed: int = 3, n: int = 5):
    """A random arm with rotors on a coupled transmission and one friction law."""
    base = random_arm(seed, n=n, rotors=True)
    rng = np.random.default_rng(seed)
    laws = {
        "viscous+coulomb": Friction(viscous=rng.random(n), coulomb=rng.random(n)),
        "asymmetric+offset motor": Friction(viscous=rng.random(n) * 1e-3, coulomb_pos=rng.random(n) * 1e-2,
                                            coulomb_neg=rng.random(n) * 2e-2, offset=rng.normal(size=n),
                                            side="motor", smoothing=0.5),
        "stribeck": Friction(coulomb=rng.random(n), stribeck_level=rng.random(n), smoothing=0.02,
                             stribeck_velocity=0.1 + rng.random(n), stribeck_exponent=1.5),
        "sigmoid motor": Friction(sigmoid_A=rng.random(n) * 1e-2, sigmoid_alpha=1 + 5 * rng.random(n),
                                  sigmoid_p3=0.1 * rng.normal(size=n), side="motor"),
    }
    G = [l.gear_ratio for l in base.links]
    tr = md.Transmission.from_gear_ratios(G, coupling=[[n, n - 1, 32.0], [2, 3, -5.0]])
    return md.Manipulator(base.links, base.convention, transmission=tr, friction=laws[law], name=law)


def _against_both_engines(arm, samples=6, seed=1):
    q, qd, _ = draw_states(arm, samples, seed=seed)
    tau = arm.lagrange.inverse_dynamics(q, qd, np.random.default_rng(seed).normal(size=q.shape))
    got = compiled_engine(arm, opt="-O0").forward_dynamics_derivatives(q, qd, tau)
    for engine in ("lagrange", "pinocchio"):
        ref = arm.engine(engine).forward_dynamics_derivatives(q, qd, tau)
        for name, x, r in zip(("dqdd_dq", "dqdd_dqd", "dqdd_dtau"), got, ref):
            assert _rel(x, r) <= TOL, f"{arm.name}: {name} vs {engine} off by {_rel(x, r):.2e}"
    return got


@needs_cc
@pytest.mark.parametrize("law", ["viscous+coulomb", "asymmetric+offset motor", "stribeck", "sigmoid motor"])
def test_drive_models_match_both_other_engines(law):
    arm = _drive_arm(law)
    dq, dqd, Minv = _against_both_engines(arm)
    # the rotors' coupling is in M^-1: without it the answer would differ by far more than TOL
    q = draw_states(arm, 1, seed=1)[0][0]
    assert _rel(np.linalg.inv(arm.pinocchio.mass_matrix(q) - arm.rotor_inertia), Minv[0]) > 1e3 * TOL


@needs_cc
def test_bundled_panda_with_its_sigmoid_law_matches_both_other_engines():
    _against_both_engines(_load("panda"), samples=4)


@needs_cc
def test_the_engine_calls_the_c_and_single_states_equal_batch_rows():
    arm = random_arm(5, n=4)
    C = compiled_engine(arm, opt="-O0")
    q, qd, _ = draw_states(arm, 3, seed=2)
    tau = np.random.default_rng(2).normal(size=q.shape)
    batch = C.forward_dynamics_derivatives(q, qd, tau)
    raw = _c_call(arm, q, qd, tau)
    for b, r in zip(batch, raw):
        np.testing.assert_array_equal(b, r)          # the engine's numbers are the C's, bit for bit
    for k in range(3):
        for b, s in zip(batch, C.forward_dynamics_derivatives(q[k], qd[k], tau[k])):
            np.testing.assert_array_equal(s, b[k])


def test_the_function_is_generated_only_with_derivatives():
    arm = random_arm(1, n=2)
    assert "_forward_dynamics_derivatives(" in generate(arm, "x").header
    assert "_forward_dynamics_derivatives(" not in generate(arm, "x", derivatives=False).header


# -- examples/linearize.c (issue 34 item 3) ---------------------------------------------------

def _read_example_output(text: str, n: int):
    A_part, B_part = text.split("B\n")
    A = np.array([[float(x) for x in ln.split()] for ln in A_part.split("A\n")[1].strip().splitlines()])
    B = np.array([[float(x) for x in ln.split()] for ln in B_part.strip().splitlines()])
    assert A.shape == (2 * n, 2 * n) and B.shape == (2 * n, n)
    return A, B


@needs_cc
@pytest.mark.parametrize("name", ["ur5", "panda"])        # rigid, and with the Panda's sigmoid friction law
def test_linearize_example_builds_strictly_runs_and_matches_md_linearize(tmp_path, name):
    import subprocess

    arm = _load(name)
    md.codegen(arm, tmp_path, prefix="arm")
    exe = tmp_path / "linearize"
    res = subprocess.run([build.find_compiler(), *build.STRICT_FLAGS, "-O1", "-I", str(tmp_path),
                          str(ROOT / "examples" / "linearize.c"), str(tmp_path / "arm.c"), "-o", str(exe), "-lm"],
                         capture_output=True, text=True)
    assert res.returncode == 0 and not res.stderr, res.stderr
    # 1e-9 relative (the issue's): both sides sum the same 18-term series of the same matrix, from
    # derivatives that agree to ~1e-13; the squarings amplify that by at most ||exp|| per step
    q = np.full(arm.n, 0.3)
    out = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    A, B = _read_example_output(out.stdout, arm.n)
    Ar, Br = md.linearize(arm, q, np.zeros(arm.n), arm.pinocchio.gravity_torque(q), dt=1e-3)
    assert _rel(A, Ar) <= 1e-9 and _rel(B, Br) <= 1e-9, (_rel(A, Ar), _rel(B, Br))
    # a moving state, a longer period (scaling and squaring at work), passed on the command line
    rng = np.random.default_rng(7)
    q, qd, tau = rng.normal(size=arm.n), rng.normal(size=arm.n), 5 * rng.normal(size=arm.n)
    args = [repr(float(x)) for x in (0.02, *q, *qd, *tau)]
    out = subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    A, B = _read_example_output(out.stdout, arm.n)
    Ar, Br = md.linearize(arm, q, qd, tau, dt=0.02)
    assert _rel(A, Ar) <= 1e-9 and _rel(B, Br) <= 1e-9, (_rel(A, Ar), _rel(B, Br))
    assert not np.allclose(A, np.eye(2 * arm.n), atol=1e-3)          # the period is long enough to matter
    bad = subprocess.run([str(exe), "0.001", "x"], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "usage: linearize" in bad.stderr
