"""The single-state shortcuts of the generated-C engine.

Layer 3 (engines: c), part of :mod:`manipdyn.engines.c.engine` (which alone uses it).

A call of one state through the general path validates each argument
(:func:`manipdyn._support.state.as_state`), makes it contiguous, asks numpy for
each array's address (``arr.ctypes.data``, some 0.7 us each) and allocates the
output: about 9 us, against the C's 0.3 us.  The shortcuts installed here by
:func:`install_fast_path`, per engine as closures (no method frame, no attribute
look-ups, as :mod:`manipdyn.engines.pinocchio.fast` does), call the single-state C
function (``md_<name>``, not the ``_batch`` loop) through a ctypes function whose
argument types are bound once, on buffers allocated once whose addresses are
known:

* a shortcut is taken only for plain 1-D ndarrays of native float64 and length
  n (``type(x) is ndarray``, ``x.dtype is float64``, ``x.shape == (n,)``); anything
  else (a list, a big-endian or integer array, a masked array, a batch, a wrong
  length) goes down the general path, which converts or refuses it, naming the
  argument;
* the inputs are copied into the engine's input buffer (a slice assignment,
  which also makes a strided view contiguous) and their finiteness is read off
  one sum over the buffer: a NaN or inf anywhere makes it non-finite, and the
  call goes down the general path, which names the entry (a sum that overflows
  on finite inputs only costs the general path);
* the answer is read from the output buffer, tested the same way (a non-finite
  answer, an overflow or a singular D(q), goes down the general path, which
  explains it) and returned as a new array: the caller owns it, as on the
  general path;
* the buffers are the engine's, guarded by a lock taken without waiting: ctypes
  releases the GIL during the C call, so a second thread calling the same engine
  at that moment finds the lock held and takes the general path (its own arrays)
  instead of waiting or sharing the buffers.  Several threads may still call
  one engine at once (tests/test_codegen_fast.py).

The answers are the general path's bit for bit: the same C function (the
batch function is a loop over it) on the same numbers.
"""

from __future__ import annotations

import ctypes
import math
import threading

import numpy as np

__all__ = ["install_fast_path", "FAST_METHODS"]

_isfinite = math.isfinite
_F64 = np.dtype(np.float64)  # native byte order: '>f8' is another object
_ND = np.ndarray  # exactly: a masked array's data would reach the C without its mask

#: method name -> (C function, argument names, output shape as "n" | "nn") of the shortcuts
FAST_METHODS = {
    "inverse_dynamics": ("inverse_dynamics", ("q", "qd", "qdd"), "n"),
    "forward_dynamics": ("forward_dynamics", ("q", "qd", "tau"), "n"),
    "nonlinear_effects": ("nonlinear_effects", ("q", "qd"), "n"),
    "coriolis_torque": ("coriolis", ("q", "qd"), "n"),
    "mass_matrix": ("mass_matrix", ("q",), "nn"),
    "gravity_torque": ("gravity", ("q",), "n"),
    "friction_torque": ("friction", ("qd",), "n"),
}


def _c_function(lib, symbol: str, nargs: int):
    """The C function ``symbol`` of ``lib`` with ``nargs`` pointer arguments bound once."""
    f = getattr(lib, symbol)
    f.restype = None
    f.argtypes = [ctypes.c_void_p] * nargs
    return f


def install_fast_path(eng, lib, prefix: str) -> None:
    """Shadow :data:`FAST_METHODS` of ``eng`` by closures with a single-state shortcut.

    ``lib``: the engine's loaded library (its single-state functions ``prefix_<name>``).
    Each closure falls back to the class's method (the general path) for anything
    but what the module docstring lists.  Same names, signatures and docstrings.
    A library without the single-state symbols (none that manipdyn generates) keeps
    the general path.
    """
    cls = type(eng)
    n = eng.n
    shape = (n,)
    ND, F64, isf = _ND, _F64, _isfinite
    for method, (cname, names, out) in FAST_METHODS.items():
        nin = len(names)
        try:
            cfun = _c_function(lib, f"{prefix}_{cname}", nin + 1)
        except AttributeError:
            continue
        general = getattr(cls, method).__get__(eng)
        # one input buffer (the inputs one after another), one output buffer, their addresses
        inbuf = np.zeros(nin * n)
        outbuf = np.zeros((n, n) if out == "nn" else n)
        views = [inbuf[k * n:(k + 1) * n] for k in range(nin)]
        addrs = [v.ctypes.data for v in views]
        oaddr = outbuf.ctypes.data
        flat = outbuf.reshape(-1)
        lock = threading.Lock()
        fn = _make(nin, names, cfun, general, views, addrs, oaddr, inbuf, outbuf, flat, lock, shape, ND, F64, isf)
        fn.__doc__ = getattr(cls, method).__doc__
        fn.__name__ = method
        fn.__qualname__ = f"{cls.__name__}.{method}"
        eng.__dict__[method] = fn


def _make(nin, names, cfun, general, views, addrs, oaddr, inbuf, outbuf, flat, lock, shape, ND, F64, isf):
    """The closure of one method, written out per signature (no loop, no ``*args`` in the hot
    path; the arguments keep the method's names, so keyword calls work)."""
    acquire, release = lock.acquire, lock.release
    a0, a1, a2 = (addrs + [0, 0])[:3]
    v0, v1, v2 = (views + [None, None])[:3]

    def one(x0):
        if type(x0) is ND and x0.dtype is F64 and x0.shape == shape and acquire(False):
            try:
                v0[:] = x0
                if isf(sum(inbuf.tolist())):
                    cfun(a0, oaddr)
                    if isf(sum(flat.tolist())):
                        return outbuf.copy()
            finally:
                release()
        return None

    def two(x0, x1):
        if (type(x0) is type(x1) is ND and x0.dtype is x1.dtype is F64
                and x0.shape == x1.shape == shape and acquire(False)):
            try:
                v0[:] = x0
                v1[:] = x1
                if isf(sum(inbuf.tolist())):
                    cfun(a0, a1, oaddr)
                    if isf(sum(flat.tolist())):
                        return outbuf.copy()
            finally:
                release()
        return None

    def three(x0, x1, x2):
        if (type(x0) is type(x1) is type(x2) is ND and x0.dtype is x1.dtype is x2.dtype is F64
                and x0.shape == x1.shape == x2.shape == shape and acquire(False)):
            try:
                v0[:] = x0
                v1[:] = x1
                v2[:] = x2
                if isf(sum(inbuf.tolist())):
                    cfun(a0, a1, a2, oaddr)
                    if isf(sum(flat.tolist())):
                        return outbuf.copy()
            finally:
                release()
        return None

    if names == ("q",):
        def f(q):
            r = one(q)
            return general(q) if r is None else r
    elif names == ("qd",):
        def f(qd):
            r = one(qd)
            return general(qd) if r is None else r
    elif names == ("q", "qd"):
        def f(q, qd):
            r = two(q, qd)
            return general(q, qd) if r is None else r
    elif names == ("q", "qd", "qdd"):
        def f(q, qd, qdd):
            r = three(q, qd, qdd)
            return general(q, qd, qdd) if r is None else r
    elif names == ("q", "qd", "tau"):
        def f(q, qd, tau):
            r = three(q, qd, tau)
            return general(q, qd, tau) if r is None else r
    else:  # pragma: no cover - FAST_METHODS names only these
        raise AssertionError(names)
    return f
