"""The API-input matrix: every engine method x every state argument x bad
values and dtypes.

For each engine (the trace form, Pinocchio, and the arm itself, whose
dynamics calls take Pinocchio's single-call fast paths) and each public
method that takes states, every argument in turn receives each bad value
while the others are good.  The contract: a :class:`StateError` (a
``ValueError``) whose message starts with the argument's name, never a
foreign exception or a NaN.  Every accepted dtype gives exactly the answer
of the same numbers as native float64 (a big-endian or float32 state is
converted, never reinterpreted).  Huge but finite states give a finite
answer or a StateError saying the dynamics overflow at that state.
"""

from __future__ import annotations

import numpy as np
import pytest

import manipdyn as md

N = 6

#: method -> its state arguments, in order
METHODS = {
    "mass_matrix": ("q",), "coriolis_torque": ("q", "qd"), "gravity_torque": ("q",),
    "friction_torque": ("qd",), "dynamics_terms": ("q", "qd"), "inverse_dynamics": ("q", "qd", "qdd"),
    "forward_dynamics": ("q", "qd", "tau"), "kinetic_energy": ("q", "qd"), "potential_energy": ("q",),
    "fkine": ("q",), "coriolis_matrix": ("q", "qd"),
}
ARM_METHODS = ("mass_matrix", "coriolis_torque", "gravity_torque", "inverse_dynamics", "forward_dynamics", "fkine")


def _masked():
    return np.ma.masked_array(np.zeros(N), mask=[False, True] + [False] * (N - 2))


def _deep():
    a = [0.0] * N
    for _ in range(5000):
        a = [a]
    return a


BAD = {
    "None": lambda: None,
    "str": lambda: "0 0 0 0 0 0",
    "bytes": lambda: b"\x00" * 48,
    "scalar": lambda: 1.0,
    "empty": lambda: [],
    "too long": lambda: np.zeros(N + 1),
    "batch too wide": lambda: np.zeros((2, N + 1)),
    "3-d": lambda: np.zeros((2, 3, N)),
    "column": lambda: np.zeros((N, 1)),
    "bool": lambda: np.zeros(N, dtype=bool),
    "object": lambda: np.zeros(N, dtype=object),
    "complex": lambda: np.zeros(N, dtype=complex),
    "datetime": lambda: np.zeros(N, dtype="datetime64[s]"),
    "timedelta": lambda: np.zeros(N, dtype="timedelta64[s]"),
    "unicode": lambda: np.array(["0"] * N),
    "structured": lambda: np.zeros(N, dtype=[("x", "f8")]),
    "masked entry": _masked,
    "ragged": lambda: [[0.0] * N, [0.0] * (N - 1)],
    "int beyond float": lambda: [10**400] + [0] * (N - 1),
    "nested 5000 deep": _deep,
    "nan": lambda: np.full(N, np.nan),
    "inf": lambda: np.full(N, np.inf),
    "big-endian nan": lambda: np.full(N, np.nan).astype(">f8"),
    "float32 inf": lambda: np.full(N, np.inf, dtype=np.float32),
    "dict": lambda: {"q": 0},
    "set": lambda: {0.0},
    "list of bools": lambda: [False] * N,
    "list with a string": lambda: [0.0] * (N - 1) + ["0"],
}

GOOD_DTYPES = [">f8", "<f8", "f4", ">f4", "f2", "i8", ">i4", "u1", "longdouble", "list", "tuple", "strided",
               "fortran batch", "matrix"]


@pytest.fixture(scope="module")
def arm():
    return md.load("ur5")


def _engines(arm):
    return {"lagrange": arm.lagrange, "pinocchio": arm.pinocchio, "arm": arm}


def _good(rng, batch=False):
    return rng.uniform(-1.0, 1.0, (3, N) if batch else N)


CASES = [(e, m, a) for e in ("lagrange", "pinocchio", "arm") for m, args in METHODS.items()
         if e != "arm" or m in ARM_METHODS for a in args]


@pytest.mark.parametrize("engine,method,arg", CASES)
def test_every_bad_value_is_a_state_error_naming_the_argument(arm, engine, method, arg):
    E = _engines(arm)[engine]
    rng = np.random.default_rng(0)
    names = METHODS[method]
    for label, make in BAD.items():
        kwargs = {nm: _good(rng) for nm in names}
        kwargs[arg] = make()
        with pytest.raises(md.StateError) as info:
            getattr(E, method)(*(kwargs[nm] for nm in names))
        assert str(info.value).startswith(f"{arg}: "), f"{label}: {info.value}"


@pytest.mark.parametrize("engine,method", [(e, m) for e in ("lagrange", "pinocchio", "arm")
                                           for m in METHODS if (e != "arm" or m in ARM_METHODS)
                                           and len(METHODS[m]) > 1])
def test_mismatched_batches_name_the_argument(arm, engine, method):
    E = _engines(arm)[engine]
    rng = np.random.default_rng(1)
    names = METHODS[method]
    args = [_good(rng, batch=True) for _ in names]
    args[-1] = args[-1][:2]
    with pytest.raises(md.StateError, match=rf"^{names[-1]}: got shape \(2, {N}\), expected \(3, {N}\)"):
        getattr(E, method)(*args)


def _as(x, kind):
    if kind == "list":
        return x.tolist()
    if kind == "tuple":
        return tuple(map(tuple, x)) if x.ndim == 2 else tuple(x)
    if kind == "strided":
        y = np.zeros(x.shape[:-1] + (2 * N,))
        y[..., ::2] = x
        return y[..., ::2]
    if kind == "fortran batch":
        return np.asfortranarray(x)
    if kind == "matrix":
        return np.asmatrix(x) if x.ndim == 2 else x
    if kind == "longdouble":
        return x.astype(np.longdouble)
    return x.astype(kind)


@pytest.mark.filterwarnings("ignore:the matrix subclass:PendingDeprecationWarning")
@pytest.mark.parametrize("kind", GOOD_DTYPES)
@pytest.mark.parametrize("engine", ["lagrange", "pinocchio", "arm"])
def test_every_accepted_dtype_gives_the_float64_answer(arm, engine, kind):
    E = _engines(arm)[engine]
    rng = np.random.default_rng(2)
    for batch in (False, True):
        for method, names in METHODS.items():
            if engine == "arm" and method not in ARM_METHODS:
                continue
            raw = [_good(rng, batch) * (3 if kind in ("i8", ">i4", "u1") else 1) for _ in names]
            if kind == "u1":
                raw = [np.abs(r) for r in raw]
            cast = [_as(r, kind) for r in raw]
            # the numbers the cast holds, as native float64
            ref = [np.array(np.asarray(c), dtype=np.float64) for c in cast]
            got = getattr(E, method)(*cast)
            want = getattr(E, method)(*ref)
            for g, w in zip(got if isinstance(got, tuple) else (got,), want if isinstance(want, tuple) else (want,)):
                np.testing.assert_array_equal(np.asarray(g), np.asarray(w), err_msg=f"{method} {kind}")


@pytest.mark.parametrize("engine,method,arg", CASES)
def test_huge_finite_states_are_finite_or_an_overflow_error(arm, engine, method, arg):
    E = _engines(arm)[engine]
    rng = np.random.default_rng(3)
    names = METHODS[method]
    for big in (1e150, 1e300):
        kwargs = {nm: _good(rng) for nm in names}
        kwargs[arg] = np.full(N, big)
        try:
            out = getattr(E, method)(*(kwargs[nm] for nm in names))
        except md.StateError as exc:
            assert "overflow at this state" in str(exc), str(exc)
            continue
        except md.SingularMassMatrixError:
            continue
        for o in out if isinstance(out, tuple) else (out,):
            assert np.all(np.isfinite(o)), f"{method}({arg}={big:g}) returned non-finite values"


CONSTRUCTOR_BAD = [None, "x", b"x", 5, -1, 1e300, float("nan"), [], [1], [1, 2, 3], [[1] * 3] * 3, {}, {"a": 1},
                   True, 10**400, np.zeros(3), np.zeros((3, 3)), np.array(["a"] * 3), object(), complex(1, 1),
                   "a\x00b", "x" * 5000]


@pytest.mark.filterwarnings("ignore::manipdyn.PhysicalConsistencyWarning")
def test_constructors_and_load_raise_only_manipdyn_errors(arm):
    """Every keyword of the model constructors, md.load and md.crosscheck, given junk:
    a ModelError or StateError (or a valid object), never a foreign exception."""
    link = md.DHLink(a=0.5, mass=1.0, inertia=(0.1, 0.1, 0.1))
    body = md.LinkInertia(mass=1.0, inertia=(0.1, 0.1, 0.1))
    calls = {}
    for b in CONSTRUCTOR_BAD:
        calls[f"Manipulator(links={b!r:.20})"] = lambda b=b: md.Manipulator(b, convention="standard")
        for kw in ("convention", "gravity", "name"):
            base = {"convention": "standard"}
            base[kw] = b
            calls[f"Manipulator({kw}={b!r:.20})"] = lambda base=base: md.Manipulator([link], **base)
        for kw in ("joint", "a", "alpha", "d", "theta", "mass", "com", "inertia", "qlim", "motor_inertia",
                   "gear_ratio", "friction_viscous", "friction_coulomb", "name", "body"):
            calls[f"DHLink({kw}={b!r:.20})"] = lambda kw=kw, b=b: md.DHLink(**{kw: b})
        for kw in ("mass", "com", "inertia"):
            calls[f"LinkInertia({kw}={b!r:.20})"] = lambda kw=kw, b=b: md.LinkInertia(**{kw: b})
        for kw in ("name", "joint", "origin", "axis", "body", "qlim", "armature", "friction_viscous",
                   "effort", "velocity"):
            base = dict(name="j", joint="revolute", origin=np.eye(4), axis=(0, 0, 1), body=body)
            base[kw] = b
            calls[f"ChainJoint({kw}={b!r:.20})"] = lambda base=base: md.ChainJoint(**base)
        calls[f"load({b!r:.20})"] = lambda b=b: md.load(b)
        for kw in ("gravity", "name", "tip"):
            calls[f"load(ur5.urdf, {kw}={b!r:.20})"] = lambda kw=kw, b=b: md.load("urdf/ur5.urdf", **{kw: b})
        calls[f"crosscheck(samples={b!r:.20})"] = lambda b=b: md.crosscheck(arm, samples=b)
        calls[f"crosscheck(seed={b!r:.20})"] = lambda b=b: md.crosscheck(arm, samples=2, seed=b)
        calls[f"frame_placement(frame={b!r:.20})"] = lambda b=b: arm.pinocchio.frame_placement(np.zeros(N), b)
    foreign = []
    for label, call in calls.items():
        try:
            call()
        except (md.ModelError, md.StateError):
            pass
        except Exception as exc:  # noqa: BLE001 - collecting them is the test
            foreign.append(f"{label}: {type(exc).__name__}: {exc!s:.80}")
    assert not foreign, "\n".join(foreign)
