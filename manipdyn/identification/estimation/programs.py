"""The consistent fit's conic programs, compiled once per structure (cvxpy's DPP).

Layer 5 (identification).  Used by :mod:`.sdp`.

The consistent fit (:func:`.sdp.consistent_fit`) solves up to five conic programs per call, and
``identify`` calls it for every fold and candidate of the smoothing choice, every weight of the
prior-weight choice, every refit of the band and the final fit: dozens of programs that differ
only in their numbers.  cvxpy spends most of a small program's time canonicalizing it (turning
the expressions into the solver's matrices); a program whose data are ``cp.Parameter``\\ s obeying
its disciplined parametrized programming rules (DPP) is canonicalized once, and each later solve
only multiplies the stored map by the new parameter values.

So the three kinds of program are built here with their data as *slots*:

* ``"closest"``: ``min ||s x - t||^2`` s.t. ``K x = beta`` and the constraints (the full
  parameters closest to the prior with given base parameters: :func:`.sdp`'s least-squares
  shortcut and step 2), ``s = 1 / pscale``, ``t = prior / pscale``;
* ``"fit"``: ``min ||A x - c|| + ||g x - g prior||`` s.t. the constraints (step 1 without prior
  weight), ``A = u R K / ||c||``;
* ``"weighted"``: ``min ||A x - c||^2 + lin . x - wn sum_i log det J_i(x)
  [+ ||d * (x_e - prior_e)||^2]`` s.t. the constraints (step 1 with a prior weight),
  ``A = u R K / sqrt(rows)``, ``lin`` the divergence's linear part (``wn tr(J0_i^-1 J_i)``);

and the constraints (:func:`constraints`): ``J_i(x) - floor_i^2 m_i diag(1, 1, 1, 0) - eps I >= 0``,
the extras >= 0, mass, centre-of-mass and total-mass bounds; ``"closest"`` may also hold the bodies
fixed (``x[:10 n] = fixed``).  The compiled program is kept, keyed by the structure (sizes, which
constraints and bounds are present, which links have a gyration floor, which extras are >= 0, whether
the extra-scale term is present, the sparsity pattern of ``K``, whose Parameter holds only its
nonzeros).  Inside :func:`uncached`, or when cvxpy finds the program not DPP, the program is built
afresh from the numbers with the expressions the fit always built (``||(x - prior) / pscale||^2``,
``||R (K x) - c|| / ||c|| + REG ||x - prior|| / max(1, ||prior||)``, ``||R K x - c||^2 / rows + w
sum_i d(J_i, J0_i) / n``), as before the cache.  The two are the same problems scaled differently,
so the solver stops at points that agree to its accuracy (tests/test_sdp_programs.py).  The cache is
per thread (a program's Parameters hold one call's numbers while it is solved) and bounded
(:data:`CACHE_SIZE`).
:func:`cache_info` counts its hits and compilations; :func:`uncached` switches it off in a block.
"""

from __future__ import annotations

import contextlib
import threading
from collections import OrderedDict

import numpy as np

from ...model.parameters import PARAMETER_BASIS

__all__ = ["program", "constraints", "bound_values", "cache_info", "clear_cache", "uncached", "CACHE_SIZE"]

#: the most compiled programs kept per thread (least recently used dropped first)
CACHE_SIZE = 64

_local = threading.local()
_GYRATION_AXES = np.diag([1.0, 1.0, 1.0, 0.0])
#: slots whose sign DPP must know (a nonnegative weight times a concave term)
_NONNEG = ("wn",)


def _state():
    if not hasattr(_local, "cache"):
        _local.cache, _local.enabled = OrderedDict(), True
        _local.info = {"hits": 0, "compiles": 0, "uncached": 0, "not_dpp": 0}
    return _local


def cache_info() -> dict:
    """This thread's counts: ``hits`` (a compiled program reused), ``compiles`` (a program compiled
    for a new structure), ``uncached`` (built afresh: cache off or not DPP), ``not_dpp``, ``size``."""
    s = _state()
    return dict(s.info, size=len(s.cache))


def clear_cache() -> None:
    """Drop this thread's compiled programs and zero its counts."""
    s = _state()
    s.cache.clear()
    s.info.update(dict.fromkeys(s.info, 0))


@contextlib.contextmanager
def uncached():
    """Within the block, every program is built afresh from its numbers (the path before the cache)."""
    s = _state()
    before, s.enabled = s.enabled, False
    try:
        yield
    finally:
        s.enabled = before


def bound_values(bounds, eps: float) -> dict:
    """The constraints' numbers: ``eps`` and those of the present bounds (already in the solver's units)."""
    v = {"eps": float(eps)}
    if bounds is None:
        return v
    if bounds.gyration is not None:
        v["floor2"] = np.asarray(bounds.gyration, dtype=np.float64) ** 2
    if bounds.mass is not None:
        mb = np.asarray(bounds.mass, dtype=np.float64)
        v["mass_lo"], v["mass_hi"] = mb[:, 0].copy(), mb[:, 1].copy()
    if bounds.com is not None:
        cb = np.asarray(bounds.com, dtype=np.float64)
        v["com_lo"], v["com_hi"] = cb[:, 0, :].copy(), cb[:, 1, :].copy()
    if bounds.total_mass is not None:
        v["tot_lo"], v["tot_hi"] = float(bounds.total_mass[0]), float(bounds.total_mass[1])
    return v


def constraints(cp, x, n: int, extra_idx, slots: dict, floor_links) -> list:
    """The constraints of every program: each link's pseudo-inertia ``J_i(x)`` less its gyration floor
    (``floor_links``: the links with one) ``>= eps I``; ``x[extra_idx] >= 0``; the bounds whose slots are given."""
    E = PARAMETER_BASIS
    cons = []
    for i in range(n):
        J = sum(x[10 * i + k] * E[k] for k in range(10))
        if i in floor_links:
            J = J - slots["floor2"][i] * x[10 * i] * _GYRATION_AXES
        cons.append(J - slots["eps"] * np.eye(4) >> 0)
    if len(extra_idx):
        cons.append(x[extra_idx] >= 0)
    masses = x[10 * np.arange(n)]
    if "mass_lo" in slots:
        cons += [masses >= slots["mass_lo"], masses <= slots["mass_hi"]]
    if "com_lo" in slots:
        for i in range(n):
            m, mc = x[10 * i], x[10 * i + 1:10 * i + 4]
            cons += [mc >= m * slots["com_lo"][i], mc <= m * slots["com_hi"][i]]
    if "tot_lo" in slots:
        tot = cp.sum(masses)
        cons += [tot >= slots["tot_lo"], tot <= slots["tot_hi"]]
    return cons


def _objective(cp, kind: str, x, n: int, v: dict, dpp: bool):
    """``(objective, constraints)`` of ``kind`` (module docstring) beyond the common constraints.

    ``dpp``: ``v`` holds the Parameters of :func:`_slots` (each product a Parameter times an affine
    expression of ``x``, as DPP requires); else ``v`` holds the caller's numbers and the expressions
    are the ones the fit has always built (the path before the cache, kept for programs that are not DPP)."""
    E = PARAMETER_BASIS
    if kind == "closest":
        obj = cp.sum_squares(v["s"] * x - v["t"]) if dpp else cp.sum_squares((x - v["prior"]) / v["pscale"])
        cons = [v["K"] @ x == v["beta"]]
        if "fixed" in v:                 # the bodies held where step 1 put them (only the extras move)
            cons.append(x[:10 * n] == v["fixed"])
        return obj, cons
    if kind == "fit":
        if dpp:
            return cp.norm(v["A"] @ x - v["c"]) + cp.norm(v["g"] * x - v["gt"]), []
        return (cp.norm(v["R"] @ (v["K"] @ x) - v["c"]) / v["scale"]
                + v["reg"] * cp.norm(x - v["prior"]) / v["pnorm"]), []
    if kind != "weighted":
        raise ValueError(f"kind: expected 'closest', 'fit' or 'weighted', got {kind!r}")
    Js = [sum(x[10 * i + k] * E[k] for k in range(10)) for i in range(n)]
    if dpp:
        obj = (cp.sum_squares(v["A"] @ x - v["c"]) + v["lin"] @ x[:10 * n]
               - v["wn"] * sum(cp.log_det(J) for J in Js))
    else:
        div = sum(cp.trace(v["J0inv"][i] @ Js[i]) - cp.log_det(Js[i]) for i in range(n))
        obj = cp.sum_squares(v["R"] @ (v["K"] @ x) - v["c"]) / v["rows"] + v["weight"] * div / n
    if "d" in v:
        obj = obj + cp.sum_squares(cp.multiply(v["d"], x[10 * n:]) - v["dt"])
    return obj, []


def _slots(kind: str, n: int, v: dict) -> dict:
    """The DPP program's Parameter values from the caller's numbers ``v`` (:func:`_objective`)."""
    out = {k: v[k] for k in ("eps", "floor2", "mass_lo", "mass_hi", "com_lo", "com_hi", "tot_lo", "tot_hi",
                              "d", "dt", "fixed") if k in v}
    if kind == "closest":
        out.update(s=1.0 / v["pscale"], t=v["prior"] / v["pscale"], K=v["K"], beta=v["beta"])
    elif kind == "fit":
        g = v["reg"] / v["pnorm"]
        out.update(A=(v["R"] @ v["K"]) / v["scale"], c=v["c"] / v["scale"], g=g, gt=g * v["prior"])
    else:
        root, wn = float(np.sqrt(v["rows"])), v["weight"] / n
        # tr(J0_i^-1 J_i(x)) = sum_k x_10i+k tr(J0_i^-1 E_k): the divergence's linear part
        lin = wn * np.einsum("iab,kba->ik", v["J0inv"], PARAMETER_BASIS).reshape(-1)
        out.update(A=(v["R"] @ v["K"]) / root, c=v["c"] / root, lin=lin, wn=wn)
    return out


def _build(cp, kind: str, n: int, p: int, extra_idx, v: dict, floor_links, dpp: bool):
    x = cp.Variable(p)
    obj, cons = _objective(cp, kind, x, n, v, dpp)
    return cp.Problem(cp.Minimize(obj), cons + constraints(cp, x, n, extra_idx, v, floor_links)), x


def program(cp, kind: str, n: int, p: int, extra_idx, values: dict):
    """``(problem, x)``: the program ``kind`` holding ``values`` (the caller's numbers: :func:`_objective`
    and :func:`bound_values`), from this thread's cache when one of the same structure was compiled
    before (its Parameters then take the numbers), else built (and, when DPP, kept).
    ``extra_idx``: the entries constrained >= 0."""
    extra_idx = np.asarray(extra_idx, dtype=np.int64)
    floor2 = values.get("floor2")
    floor_links = frozenset() if floor2 is None else frozenset(int(i) for i in np.flatnonzero(floor2 > 0))
    s = _state()
    if not s.enabled:
        s.info["uncached"] += 1
        return _build(cp, kind, n, p, extra_idx, values, floor_links, dpp=False)
    slots = _slots(kind, n, values)
    # K (base parameters of the full ones) is sparse: its Parameter holds only its nonzeros (a dense one would
    # fill the solver's KKT matrix with explicit zeros and slow every iteration), so its pattern is structure
    pattern = np.nonzero(slots["K"]) if "K" in slots else None
    key = (kind, n, p, extra_idx.tobytes(), floor_links, tuple(sorted((k, np.shape(v)) for k, v in slots.items())),
           None if pattern is None else np.packbits(slots["K"] != 0).tobytes())
    hit = s.cache.get(key)
    if hit is None:
        params = {k: cp.Parameter(np.shape(v), nonneg=k in _NONNEG, **({"sparsity": pattern} if k == "K" else {}))
                  for k, v in slots.items()}
        problem, x = _build(cp, kind, n, p, extra_idx, params, floor_links, dpp=True)
        if not problem.is_dpp():        # cvxpy would re-canonicalize it anyway: the plain path
            s.info["not_dpp"] += 1
            s.info["uncached"] += 1
            return _build(cp, kind, n, p, extra_idx, values, floor_links, dpp=False)
        hit = (problem, x, params)
        s.cache[key] = hit
        s.info["compiles"] += 1
        while len(s.cache) > CACHE_SIZE:
            s.cache.popitem(last=False)
    else:
        s.cache.move_to_end(key)
        s.info["hits"] += 1
    problem, x, params = hit
    for k, v in slots.items():
        if params[k].sparse_idx is not None:
            params[k].value_sparse = _coo(v, params[k].sparse_idx)
        else:
            params[k].value = v
    return problem, x


def _coo(a, idx):
    """The entries ``idx`` of the dense ``a`` as a SciPy COO array (a sparse Parameter's value)."""
    import scipy.sparse as sp

    return sp.coo_array((np.asarray(a)[idx], idx), shape=np.shape(a))
