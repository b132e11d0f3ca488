"""The generated-C engine's single-state calls (issue 46, item 20): the shortcuts of
``manipdyn.engines.c.fast``.

``check --engines lagrange,pinocchio,c`` measured 23 us a call of the C engine from Python
against 1.6 us for Pinocchio, while the C itself runs in 0.24 us.  How fast the shortcuts
are is measured by ``benchmarks/bench_c_calls.py``, never asserted here; these tests hold
what they must keep: the general path's answers bit for bit, its errors, the caller owning
the answer, threads, and that a plain float64 state does not go through the per-call
validation and conversion at all (which fails on the code before).
"""

from __future__ import annotations

import threading
import warnings

import numpy as np
import pytest

import manipdyn as md

pytest.importorskip("casadi", reason="generating C needs CasADi: pip install 'manipdyn[codegen]'")

from manipdyn.engines.c import build, compiled_engine  # noqa: E402
from manipdyn.engines.c import engine as c_engine  # noqa: E402
from manipdyn.engines.c.fast import FAST_METHODS  # noqa: E402

pytestmark = pytest.mark.skipif(build.find_compiler() is None, reason="no C compiler ($CC, cc or gcc) on this machine")

#: the arguments of each shortcut, by name
ARGS = {m: names for m, (_, names, _) in FAST_METHODS.items()}


@pytest.fixture(scope="module", autouse=True)
def _build_cache(tmp_path_factory):
    """A build cache for the module, not the user's."""
    import os

    old = os.environ.get(build.CACHE_ENV)
    os.environ[build.CACHE_ENV] = str(tmp_path_factory.mktemp("manipdyn-cache"))
    yield
    if old is None:
        os.environ.pop(build.CACHE_ENV, None)
    else:
        os.environ[build.CACHE_ENV] = old


@pytest.fixture(scope="module")
def engines():
    """The UR5 (no friction law) and the Panda (a friction law: the C computes it too)."""
    out = {}
    for name in ("ur5", "panda"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
            arm = md.load(name)
        out[name] = (arm, compiled_engine(arm, opt="-O0"))
    return out


def _states(arm, seed):
    rng = np.random.default_rng(seed)
    q = arm.random_state(rng)
    return {"q": q, "qd": rng.uniform(-1, 1, arm.n), "qdd": rng.uniform(-1, 1, arm.n),
            "tau": arm.inverse_dynamics(q, rng.uniform(-1, 1, arm.n), rng.uniform(-1, 1, arm.n))}


def _general(eng, method):
    return getattr(type(eng), method).__get__(eng)


@pytest.mark.parametrize("arm_name", ["ur5", "panda"])
def test_single_state_bit_for_bit_the_general_path(engines, arm_name):
    """Every shortcut gives the general path's answer exactly (the same C on the same numbers),
    and the batch path's row; with keyword arguments too."""
    arm, eng = engines[arm_name]
    for seed in range(5):
        s = _states(arm, seed)
        for method, names in ARGS.items():
            args = [s[nm] for nm in names]
            got = getattr(eng, method)(*args)
            assert getattr(eng, method) is not _general(eng, method)
            assert np.array_equal(got, _general(eng, method)(*args)), method
            batch = _general(eng, method)(*[a[None] for a in args])[0]
            assert np.array_equal(got, batch), method
            assert np.array_equal(getattr(eng, method)(**dict(zip(names, args))), got), method
            assert got.shape == ((arm.n, arm.n) if method == "mass_matrix" else (arm.n,))


def test_a_plain_state_is_not_validated_per_call(engines, monkeypatch):
    """The per-call validation of the general path (``as_state`` for each argument, a
    contiguous copy, numpy's ``ctypes`` address of each array) is what cost ~20 us: the
    shortcut does not call it.  Fails on the code before, where every call went through it."""
    arm, eng = engines["ur5"]
    s = _states(arm, 1)
    want = {m: getattr(eng, m)(*[s[nm] for nm in names]) for m, names in ARGS.items()}

    def refuse(*a, **k):
        raise AssertionError("as_state called on the single-state path")

    monkeypatch.setattr(c_engine, "as_state", refuse)
    for method, names in ARGS.items():
        assert np.array_equal(getattr(eng, method)(*[s[nm] for nm in names]), want[method])


def test_the_caller_owns_the_answer(engines):
    """The answer is a new array: a later call does not change it, and writing into it changes
    nothing the engine keeps."""
    arm, eng = engines["ur5"]
    a, b = _states(arm, 2), _states(arm, 3)
    for method, names in ARGS.items():
        f = getattr(eng, method)
        first = f(*[a[nm] for nm in names])
        keep = first.copy()
        f(*[b[nm] for nm in names])
        assert np.array_equal(first, keep)
        first[...] = 1e300
        assert np.array_equal(f(*[a[nm] for nm in names]), keep)


@pytest.mark.parametrize("method", list(ARGS))
def test_non_finite_and_odd_inputs_keep_the_general_paths_errors(engines, method):
    """NaN or inf in any entry of any argument: the StateError naming that argument (never a
    NaN answer); a list, an integer or big-endian array, a strided view: converted as the
    general path converts them; a wrong length or a 2-D state: the general path's error or batch."""
    arm, eng = engines["ur5"]
    names = ARGS[method]
    s = _states(arm, 4)
    args = [s[nm] for nm in names]
    want = getattr(eng, method)(*args)
    for k, nm in enumerate(names):
        for bad in (np.nan, np.inf, -np.inf):
            for i in (0, arm.n - 1):
                x = [a.copy() for a in args]
                x[k][i] = bad
                with pytest.raises(md.StateError, match=f"^{nm}: "):
                    getattr(eng, method)(*x)
        for other in (args[k].tolist(), args[k].astype(">f8")):
            x = list(args)
            x[k] = other
            assert np.array_equal(getattr(eng, method)(*x), want)
        wide = np.zeros(2 * arm.n)
        wide[::2] = args[k]
        x = list(args)
        x[k] = wide[::2]
        assert np.array_equal(getattr(eng, method)(*x), want)
        x[k] = args[k][:-1]
        with pytest.raises(md.StateError, match=f"^{nm}: "):
            getattr(eng, method)(*x)
        x[k] = np.zeros(1)        # would broadcast into the buffer: refused, never spread over n joints
        with pytest.raises(md.StateError, match=f"^{nm}: "):
            getattr(eng, method)(*x)


def test_threads_share_one_engine(engines):
    """ctypes releases the GIL during the C: threads calling one engine at once get their own
    answers (the buffers are taken by one call at a time; the others take the general path)."""
    arm, eng = engines["panda"]
    states = [_states(arm, 10 + k) for k in range(4)]
    want = [eng.inverse_dynamics(s["q"], s["qd"], s["qdd"]) for s in states]
    wrong = []

    def run(k):
        s = states[k]
        for _ in range(3000):
            if not np.array_equal(eng.inverse_dynamics(s["q"], s["qd"], s["qdd"]), want[k]):
                wrong.append(k)
                return

    threads = [threading.Thread(target=run, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not wrong
