"""The third engine: the generated C, compiled and called through ctypes (``arm.compiled``).

Layer 3 (engines: c), the generated-C engine.  :func:`compiled_engine` (the factory
behind ``arm.engine("c")``) looks the arm's build up in the cache
(:mod:`manipdyn.engines.c.build`), and on a miss generates the C
(:mod:`manipdyn.engines.c.source`, CasADi needed) and compiles it.
:class:`CompiledEngine` answers :class:`manipdyn.DynamicsEngine`.

What the C computes: D, h (Coriolis alone), g, the friction law, tau, forward
dynamics (LDL^T of D), the tool pose, the potential energy, the regressor,
dtau/dq and dtau/dqd, the forward dynamics' derivatives (dqdd/dq, dqdd/dqd,
D^-1), dg/dq, dF/dqd and the Christoffel Coriolis matrix.  What
is derived here in Python from those (said in each docstring): the kinetic
energy ``qd^T D qd / 2`` and regressor friction columns other than the arm's own law's.

Batches of states (N, n) run in one C loop (the ``*_batch`` functions), and
ctypes releases the GIL during each call: two threads may call one engine at
once (the C keeps no state).  One state of plain float64 arrays takes the
single-state shortcuts of :mod:`manipdyn.engines.c.fast` (bound buffers, no
per-call conversion), with the same answers and the same errors.
"""

from __future__ import annotations

import ctypes
import os
import threading

import numpy as np

from ..._support.files import atomic_write_text
from ..._support.state import as_state, check_result, same_batch
from ..._support.errors import ModelError, SingularMassMatrixError
from ...model.friction import Friction, friction_spec
from . import build, cache
from .emit import check_prefix
from .fast import install_fast_path

__all__ = ["CompiledEngine", "compiled_engine", "library_for", "ENGINE_PREFIX"]

#: CasADi's graphs are not thread-safe: one generation at a time per process (compiles run in parallel)
_GENERATE = threading.Lock()

#: the prefix of the engine's own build (the files ``md.codegen`` writes use the arm's name)
ENGINE_PREFIX = "md"

_FUNCS = {
    # name: (inputs, output sizes as multiples of (n, n*n, n*p, 16, 1))
    "inverse_dynamics": (3, ("n",)), "mass_matrix": (1, ("nn",)), "gravity": (1, ("n",)),
    "nonlinear_effects": (2, ("n",)), "forward_dynamics": (3, ("n",)),
    "inverse_dynamics_derivatives": (3, ("nn", "nn")),
    "forward_dynamics_derivatives": (3, ("nn", "nn", "nn")), "regressor": (3, ("np",)), "coriolis": (2, ("n",)),
    "friction": (1, ("n",)), "tool_pose": (1, ("16",)), "potential_energy": (1, ("1",)),
    "gravity_derivative": (1, ("nn",)), "friction_derivative": (1, ("nn",)), "coriolis_matrix": (2, ("nn",)),
}


def _version() -> str:
    from .deps import manipdyn_version

    return manipdyn_version()


def _generator_digest() -> str:
    """sha256 of the generator's own source (graph, emit, source): a changed generator never
    serves a build of the old one from the cache."""
    import hashlib

    h = hashlib.sha256()
    for name in ("graph.py", "emit.py", "source.py"):
        with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), name), "rb") as f:
            h.update(f.read())
    return h.hexdigest()[:16]


def library_for(arm, cc: str | None = None, opt: str = "-O2") -> str:
    """Path of the compiled library of ``arm``: from the cache, or generated and built into it.

    Thread-safe: threads building several arms generate one at a time and compile in parallel.
    A cached build is used only after the checks of :mod:`manipdyn.engines.c.cache` (this user's
    0700 folder, files no one else can write, a manifest naming the model's sha256, n and p and
    the library's size and sha256); one that fails them is rebuilt, never opened.

    ``opt``: the optimisation flag (``-O0`` to ``-O3``).  The results do not depend on it
    (``-std=c99`` keeps GCC from contracting ``a * b + c`` into fused multiply-adds);
    only the build time and the speed do, so tests that build hundreds of arms use ``-O0``.
    """
    if opt not in ("-O0", "-O1", "-O2", "-O3", "-Os"):
        raise ModelError(f"opt: expected one of -O0, -O1, -O2, -O3, -Os, got {opt!r:.40}")
    from .source import GENERATOR_VERSION, check_arm, generate, model_sha256

    check_arm(arm)
    cc = cc or build.require_compiler("the 'c' engine")
    sha = model_sha256(arm)
    key = build.build_key(sha, _version(), GENERATOR_VERSION + opt + _generator_digest(), cc)
    root = cache.private_root()
    folder = os.path.join(root, key)
    name = f"lib{ENGINE_PREFIX}.so"
    expect = {"key": key, "model_sha256": sha, "n": int(arm.n), "p": _columns(arm), "prefix": ENGINE_PREFIX}
    if cache.valid_build(folder, os.path.join(folder, name), expect):
        return os.path.join(folder, name)

    def write(tmp):
        with _GENERATE:
            gen = generate(arm, ENGINE_PREFIX)
        atomic_write_text(os.path.join(tmp, f"{ENGINE_PREFIX}.h"), gen.header)
        cpath = os.path.join(tmp, f"{ENGINE_PREFIX}.c")
        atomic_write_text(cpath, gen.source)
        build.compile_shared(cc, cpath, os.path.join(tmp, name), extra=(opt,))

    return cache.install_build(root, folder, name, expect, write)


def _columns(arm) -> int:
    """p, the columns of the C regressor: ``arm.parameters(armature=True, friction=arm.friction_model)``."""
    law = arm.friction_model
    return len(arm.parameters(armature=True, friction=law if law is not None else False))


def _count(value, name: str) -> int:
    """``value`` as a positive int, or a ModelError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ModelError(f"{name}: expected a positive integer, got {value!r:.60}")
    return int(value)


def compiled_engine(arm, opt: str = "-O2") -> "CompiledEngine":
    """The generated-C engine of ``arm`` (the factory behind ``arm.engine("c")``), built with ``opt``."""
    from .source import model_sha256

    return CompiledEngine(library_for(arm, opt=opt), arm.n, _columns(arm), transmission=arm.transmission,
                          friction_model=arm.friction_model, model_sha256=model_sha256(arm))


class CompiledEngine:
    """The generated C of one arm behind the :class:`manipdyn.DynamicsEngine` methods.

    Parameters
    ----------
    library : str
        Path of the shared library built from the generated source with the
        prefix :data:`ENGINE_PREFIX` (:func:`library_for`).
    n, p : int
        Joints, and columns of the C regressor (``arm.parameters(armature=True,
        friction=arm.friction_model)``).
    transmission, friction_model :
        The arm's, for the regressor's friction columns of another law than
        the arm's own (computed by the law's Python code, :meth:`regressor`).
    model_sha256 : str, optional
        The arm's :func:`manipdyn.engines.c.model_sha256`: checked against the library's.

    The library is asked for its joint count, regressor columns and model hash
    (``P_joints``, ``P_parameters``, ``P_model_sha256``) before the first call: a
    library of another arm is a :class:`ModelError`, never arrays of the wrong size.
    Loading a library runs its code: load only libraries you built (``arm.compiled``
    checks its cache before loading, :mod:`manipdyn.engines.c.cache`).
    """

    name = "c"

    def __init__(self, library: str, n: int, p: int, prefix: str = ENGINE_PREFIX, transmission=None,
                 friction_model=None, model_sha256: str | None = None):
        if not isinstance(library, (str, os.PathLike)):
            raise ModelError(f"library: expected the path of a shared library, got {type(library).__name__}")
        library = os.fspath(library)
        self.library = library
        self.n, self.p = _count(n, "n"), _count(p, "p")
        prefix = check_prefix(prefix)
        self.transmission, self.friction_model = transmission, friction_model
        if "\x00" in library or not os.path.isfile(library):
            raise ModelError(f"library: {library!r:.200} is not a file")
        try:
            lib = ctypes.CDLL(os.path.abspath(library))
        except OSError as exc:
            raise ModelError(f"the 'c' engine: cannot load {library!r}: {exc}") from None
        self._lib = lib
        self._check_library(lib, prefix, model_sha256)
        self._fn = {}
        for name, (nin, _) in _FUNCS.items():
            try:
                f = getattr(lib, f"{prefix}_{name}_batch")
            except AttributeError:
                raise ModelError(f"the 'c' engine: {library!r} has no function {prefix}_{name}_batch "
                                 "(built by another generator?)") from None
            f.restype = None
            f.argtypes = [ctypes.c_long] + [ctypes.c_void_p] * (nin + len(_FUNCS[name][1]))
            self._fn[name] = f
        self._sizes = {"n": self.n, "nn": self.n * self.n, "np": self.n * self.p, "16": 16, "1": 1}
        install_fast_path(self, lib, prefix)   # one state: the single-state C on bound buffers (fast.py)

    def _check_library(self, lib, prefix: str, sha) -> None:
        """The library's own n, p and model sha256 against the ones asked for."""
        try:
            joints, params, digest = (getattr(lib, f"{prefix}_{x}") for x in ("joints", "parameters",
                                                                               "model_sha256"))
        except AttributeError:
            raise ModelError(f"the 'c' engine: {self.library!r} has no function {prefix}_joints (built by an "
                             "older generator, or not by manipdyn?): generate it again (md.codegen), so its "
                             "size can be checked before it is called") from None
        joints.restype = params.restype = ctypes.c_long
        joints.argtypes = params.argtypes = digest.argtypes = []
        digest.restype = ctypes.c_char_p
        got = (int(joints()), int(params()))
        if got != (self.n, self.p):
            raise ModelError(f"the 'c' engine: {self.library!r} was generated for n = {got[0]} joints and "
                             f"p = {got[1]} regressor columns, not n = {self.n}, p = {self.p}: the library of "
                             "another arm")
        if sha is not None and (digest() or b"").decode("ascii", "replace") != sha:
            raise ModelError(f"the 'c' engine: {self.library!r} was generated for the model sha256 "
                             f"{(digest() or b'').decode('ascii', 'replace')[:64]}, not this arm's {sha}")

    # -- calling the C -----------------------------------------------------------------
    def _call(self, name, *inputs):
        """Run ``name`` on validated inputs (each (n,) or (N, n), same shape): its outputs, each
        (N, size) or (size,)."""
        single = inputs[0].ndim == 1
        xs = [np.ascontiguousarray(x, dtype=np.float64).reshape(-1, self.n) for x in inputs]
        N = xs[0].shape[0]
        outs = [np.empty((N, self._sizes[s])) for s in _FUNCS[name][1]]
        if N:
            self._fn[name](N, *[x.ctypes.data for x in xs], *[o.ctypes.data for o in outs])
        return [o[0] if single else o for o in outs]

    def _states(self, *named):
        arrs = [as_state(x, nm, self.n) for x, nm in named]
        if len(arrs) > 1 and any(a.shape != arrs[0].shape for a in arrs):
            same_batch(*zip(arrs, (nm for _, nm in named)))
        return arrs

    def _square(self, a):
        return a.reshape(a.shape[:-1] + (self.n, self.n))

    # -- the DynamicsEngine methods ------------------------------------------------------
    def mass_matrix(self, q) -> np.ndarray:
        """D(q) (rotors ``R^T diag(Jm) R`` included): (n, n) or (N, n, n), kg m^2 (C: composite inertias)."""
        (q,) = self._states((q, "q"))
        return check_result(self._square(self._call("mass_matrix", q)[0]), "mass_matrix", q=q)

    def coriolis_torque(self, q, qd) -> np.ndarray:
        """h(q, qd), Coriolis and centripetal alone: (n,) or (N, n), N m (C: RNEA without gravity)."""
        q, qd = self._states((q, "q"), (qd, "qd"))
        return check_result(self._call("coriolis", q, qd)[0], "coriolis_torque", q=q, qd=qd)

    def gravity_torque(self, q) -> np.ndarray:
        """g(q), the torque that holds the arm still: (n,) or (N, n), N m."""
        (q,) = self._states((q, "q"))
        return check_result(self._call("gravity", q)[0], "gravity_torque", q=q)

    def friction_torque(self, qd) -> np.ndarray:
        """The arm's friction law at the joints, offsets included: (n,) or (N, n), N m."""
        (qd,) = self._states((qd, "qd"))
        return check_result(self._call("friction", qd)[0], "friction_torque", qd=qd)

    def dynamics_terms(self, q, qd) -> tuple:
        """``(D, h, g)`` (shapes as above)."""
        return self.mass_matrix(q), self.coriolis_torque(q, qd), self.gravity_torque(q)

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """tau = D qdd + h + g + friction: (n,) or (N, n), N m (C: RNEA)."""
        q, qd, qdd = self._states((q, "q"), (qd, "qd"), (qdd, "qdd"))
        return check_result(self._call("inverse_dynamics", q, qd, qdd)[0], "inverse_dynamics", q=q, qd=qd, qdd=qdd)

    def nonlinear_effects(self, q, qd) -> np.ndarray:
        """``tau(q, qd, 0) = h + g + friction``: (n,) or (N, n), N m."""
        q, qd = self._states((q, "q"), (qd, "qd"))
        return check_result(self._call("nonlinear_effects", q, qd)[0], "nonlinear_effects", q=q, qd=qd)

    def forward_dynamics(self, q, qd, tau) -> np.ndarray:
        """qdd solving ``D qdd = tau - h - g - friction``: (n,) or (N, n) (C: unrolled LDL^T of D).

        A singular D raises :class:`SingularMassMatrixError`."""
        q, qd, tau = self._states((q, "q"), (qd, "qd"), (tau, "tau"))
        qdd = self._call("forward_dynamics", q, qd, tau)[0]
        if not np.isfinite(np.add.reduce(qdd.reshape(-1))):
            D = self.mass_matrix(q if q.ndim == 2 else q[None])
            w = np.linalg.eigvalsh(D)
            if np.any(w[:, 0] <= 1e-12 * np.maximum(1.0, np.abs(w[:, -1]))):
                raise SingularMassMatrixError.for_mass_matrix(D)
        return check_result(qdd, "forward_dynamics", q=q, qd=qd, tau=tau)

    def kinetic_energy(self, q, qd):
        """K = qd^T D qd / 2 (J), rotors included; float or (N,).  Derived here from the C's D."""
        q, qd = self._states((q, "q"), (qd, "qd"))
        D = self.mass_matrix(q)
        K = 0.5 * np.einsum("...i,...ij,...j->...", qd, D, qd)
        return float(K) if q.ndim == 1 else K

    def potential_energy(self, q):
        """P = -sum m_i g^T c_i (J), zero at the base origin's height; float or (N,)."""
        (q,) = self._states((q, "q"))
        P = check_result(self._call("potential_energy", q)[0], "potential_energy", q=q)
        return float(P[0]) if q.ndim == 1 else P[:, 0]

    def coriolis_matrix(self, q, qd) -> np.ndarray:
        """C(q, qd), Christoffel form (C qd = h, dD/dt - 2C skew): (n, n) or (N, n, n)."""
        q, qd = self._states((q, "q"), (qd, "qd"))
        return check_result(self._square(self._call("coriolis_matrix", q, qd)[0]), "coriolis_matrix", q=q, qd=qd)

    def fkine(self, q) -> np.ndarray:
        """The tool frame's pose in the base frame: (4, 4) or (N, 4, 4), metres."""
        (q,) = self._states((q, "q"))
        T = self._call("tool_pose", q)[0]
        return check_result(T.reshape(T.shape[:-1] + (4, 4)), "fkine", q=q)

    def regressor(self, q, qd, qdd, armature: bool = False, friction=False) -> np.ndarray:
        """Y with ``Y @ arm.parameters(armature, friction) = tau``: (n, p) or (N, n, p).

        The link and armature columns, and the friction columns of the arm's
        own law (``friction=arm.friction_model``), are the C's (``d tau / d
        pi`` of the generated RNEA); friction columns of any other law or
        terms (``friction=True``, term names) are computed here by that law's
        Python code (:meth:`manipdyn.Friction.columns`).
        """
        q, qd, qdd = self._states((q, "q"), (qd, "qd"), (qdd, "qdd"))
        Y = self._call("regressor", q, qd, qdd)[0]
        Y = Y.reshape(Y.shape[:-1] + (self.n, self.p))
        n = self.n
        blocks = [Y[..., :10 * n]]
        if armature:
            blocks.append(Y[..., 10 * n:11 * n])
        if friction is not False and friction is not None:
            law = self.friction_model
            if isinstance(friction, Friction) and law is not None and (friction is law or friction == law):
                blocks.append(Y[..., 11 * n:])
            else:
                blocks.append(friction_spec(friction, n).columns(qd, self.transmission))
        out = np.concatenate(blocks, axis=-1) if len(blocks) > 1 else np.ascontiguousarray(blocks[0])
        return check_result(out, "regressor", q=q, qd=qd, qdd=qdd)

    # -- derivatives ---------------------------------------------------------------
    def inverse_dynamics_derivatives(self, q, qd, qdd) -> tuple:
        """``(dtau_dq, dtau_dqd)``, each (n, n) or (N, n, n), friction included (C: the
        Jacobians of the generated RNEA, ``[i, m] = d tau_i / d x_m``)."""
        q, qd, qdd = self._states((q, "q"), (qd, "qd"), (qdd, "qdd"))
        a, b = self._call("inverse_dynamics_derivatives", q, qd, qdd)
        return (check_result(self._square(a), "inverse_dynamics_derivatives", q=q, qd=qd, qdd=qdd),
                check_result(self._square(b), "inverse_dynamics_derivatives", q=q, qd=qd, qdd=qdd))

    def forward_dynamics_derivatives(self, q, qd, tau) -> tuple:
        """``(dqdd_dq, dqdd_dqd, dqdd_dtau)``, each (n, n) or (N, n, n), ``[i, m] = d qdd_i / d x_m``
        (C: ``P_forward_dynamics_derivatives``: ``-D^-1 dtau/dx`` at the forward dynamics' qdd,
        and ``D^-1`` from the LDL^T of D; rotors and the friction law included).

        A singular D raises :class:`SingularMassMatrixError`."""
        q, qd, tau = self._states((q, "q"), (qd, "qd"), (tau, "tau"))
        out = self._call("forward_dynamics_derivatives", q, qd, tau)
        if not np.isfinite(np.add.reduce(out[2].reshape(-1))):
            D = self.mass_matrix(q if q.ndim == 2 else q[None])
            w = np.linalg.eigvalsh(D)
            if np.any(w[:, 0] <= 1e-12 * np.maximum(1.0, np.abs(w[:, -1]))):
                raise SingularMassMatrixError.for_mass_matrix(D)
        return tuple(check_result(self._square(x), "forward_dynamics_derivatives", q=q, qd=qd, tau=tau)
                     for x in out)

    def gravity_derivative(self, q) -> np.ndarray:
        """``dg/dq``: (n, n) or (N, n, n), N m/rad (C: the Jacobian of the generated g)."""
        (q,) = self._states((q, "q"))
        return check_result(self._square(self._call("gravity_derivative", q)[0]), "gravity_derivative", q=q)

    def friction_derivative(self, qd) -> np.ndarray:
        """``dF/dqd`` of the friction law: (n, n) or (N, n, n).  At a kink: the sharp sign's
        derivative is 0, the deadband's 0 inside it, an asymmetric law's at v = 0 the mean of
        its sides (CasADi's derivative of fmax/fmin there is 1/2)."""
        (qd,) = self._states((qd, "qd"))
        return check_result(self._square(self._call("friction_derivative", qd)[0]), "friction_derivative", qd=qd)
