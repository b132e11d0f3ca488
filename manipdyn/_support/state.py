"""Validation of joint-state arguments at the API boundary.

Layer 0 (support): joint-state validation at the API boundary.

Every public dynamics function accepts one state of shape ``(n,)`` or a batch
of shape ``(N, n)``; these helpers check that and name the argument when it
is wrong.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import StateError

_F64 = np.dtype(np.float64)
_ND = np.ndarray
_isfinite = math.isfinite


def as_state(x, name: str, n: int) -> np.ndarray:
    """Return ``x`` as a float64 array of shape ``(n,)`` or ``(N, n)``.

    Raises :class:`StateError` (a ``ValueError``) naming ``name``, the shape
    received and the shape expected, the first non-finite entry, or why the
    input is not real numbers (:func:`state_array`: any float or integer dtype
    and byte order is converted; bool, object, string, datetime, masked,
    ragged input and integers beyond float range are refused).

    The common case (a float64 ndarray of shape ``(n,)``) costs well under a
    microsecond: this sits in control loops.  Only a plain ndarray whose dtype
    IS the native float64 takes it (``np.dtype('>f8')`` is another object).
    """
    if type(x) is _ND and x.dtype is _F64 and x.shape == (n,):
        # NaN and inf propagate through a sum; only when it is not finite (or
        # overflows) do we pay for the element-wise check.
        if not _isfinite(sum(x.tolist())):
            check_finite(x, name)
        return x
    arr = state_array(x, name, n)
    shape = arr.shape
    if not ((len(shape) == 1 and shape[0] == n) or (len(shape) == 2 and shape[1] == n)):
        raise StateError(
            f"{name}: got shape {shape}, expected ({n},) or (N, {n})"
        )
    # np.add.reduce, not a dot product: BLAS would start threads on large
    # batches and compete with Pinocchio's own.
    if not _isfinite(np.add.reduce(arr.reshape(-1))):
        check_finite(arr, name)
    return arr


_KIND_NAMES = {"b": "bool", "c": "complex", "O": "object", "M": "datetime64", "m": "timedelta64",
               "U": "string", "S": "bytes", "V": "structured (void)"}


def _refuse(name: str, n: int, what: str):
    sep = ", " if what.startswith("could not") else ", got "
    return StateError(f"{name}: expected a real array of shape ({n},) or (N, {n}){sep}{what}")


def state_array(x, name: str, n: int) -> np.ndarray:
    """``x`` as a native-byte-order float64 ndarray (any shape), or a :class:`StateError`.

    The strict conversion behind :func:`as_state`'s general path.  Accepted:
    float arrays of any width and byte order (a big-endian ``'>f8'`` state is
    converted, never reinterpreted), integer arrays, and (nested) lists or
    tuples of real numbers.  Refused, naming ``name``: bool, complex, object,
    string, datetime/timedelta and structured dtypes; masked arrays with a masked entry
    (the mask would be silently dropped: fill them first, ``x.filled(value)``); ragged
    or too deeply nested sequences; numbers beyond the float64 range (a huge
    Python ``int`` or a ``longdouble``), which would become inf.
    """
    if isinstance(x, np.ma.MaskedArray):
        if np.ma.getmaskarray(x).any():
            raise _refuse(name, n, "a masked array with masked entries: the mask would be dropped; "
                                   "pass x.filled(value) or the unmasked rows")
        x = np.ma.getdata(x)  # nothing masked: the data is the state
    if isinstance(x, (bool, np.bool_)):
        raise _refuse(name, n, "a bool")
    if isinstance(x, (str, bytes)):
        raise _refuse(name, n, f"could not convert {type(x).__name__} {x!r:.40}")
    if isinstance(x, np.ndarray):
        src = x
    else:
        try:
            src = np.asarray(x)
        except RecursionError:
            raise _refuse(name, n, f"a {type(x).__name__} nested too deeply") from None
        except (TypeError, ValueError, OverflowError) as exc:
            kind = "a ragged sequence (rows of different lengths)" if "inhomogeneous" in str(exc) \
                else f"a {type(x).__name__} numpy cannot read as numbers ({exc})"
            raise _refuse(name, n, kind) from None
    kind = src.dtype.kind
    if kind == "O" and not isinstance(x, np.ndarray):
        src = _python_numbers(src, name, n)  # e.g. a list holding an int beyond float range
        kind = src.dtype.kind
    if kind not in "fiu":
        raise _refuse(name, n, f"dtype {src.dtype} ({_KIND_NAMES.get(kind, kind)})")
    if src.dtype is _F64 and type(src) is _ND:
        return src
    with np.errstate(over="ignore", invalid="ignore"):
        arr = np.asarray(src, dtype=np.float64)  # converts the byte order, never reinterprets it
    if type(arr) is not _ND:
        arr = arr.view(_ND)  # np.matrix and other subclasses: plain arrays
    if kind == "f" and src.dtype.itemsize > 8:
        big = np.isinf(arr) & np.isfinite(src)
        if big.any():
            idx = tuple(int(i) for i in np.argwhere(big)[0])
            raise StateError(f"{name}: entry {idx if len(idx) > 1 else idx[0]} = {src[idx]!r} "
                             "is beyond the float64 range")
    return arr


def _python_numbers(obj_arr: np.ndarray, name: str, n: int) -> np.ndarray:
    """An object array built from a Python sequence: real numbers only, within float range."""
    out = np.empty(obj_arr.shape, dtype=np.float64)
    flat = out.reshape(-1)
    for i, v in enumerate(obj_arr.reshape(-1)):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise _refuse(name, n, f"a sequence holding {type(v).__name__} {v!r:.40}")
        try:
            flat[i] = float(v)
        except OverflowError:
            idx = np.unravel_index(i, obj_arr.shape)
            idx = tuple(int(k) for k in idx)
            raise StateError(f"{name}: entry {idx if len(idx) > 1 else idx[0]} is an integer "
                             f"beyond the float64 range ({len(str(abs(v)))} digits)") from None
    return out


def check_result(out: np.ndarray, what: str, **states) -> np.ndarray:
    """Return ``out`` if finite, else a :class:`StateError` saying the dynamics overflow.

    For results computed from validated (finite) states: a NaN or inf there
    is not an input's fault, so the message gives the state where the
    arithmetic overflowed instead of blaming an argument.
    """
    if _isfinite(np.add.reduce(out.reshape(-1))):
        return out
    bad = ~np.isfinite(out)
    if not bad.any():  # the sum itself overflowed: the values are finite
        return out
    where = ""
    first = np.argwhere(bad)[0]
    arrays = {k: np.asarray(v) for k, v in states.items()}
    batch = any(a.ndim == 2 for a in arrays.values())
    if batch:
        i = int(first[0])
        where = f" (state {i} of the batch)"
        arrays = {k: (a[i] if a.ndim == 2 else a) for k, a in arrays.items()}
    shown = ", ".join(f"{k} = {np.array2string(a, precision=4, threshold=8)}" for k, a in arrays.items())
    raise StateError(f"{what}: the dynamics overflow at this state{where} (finite inputs, "
                     f"non-finite result): {shown}")


def check_finite(arr: np.ndarray, name: str) -> None:
    """Raise :class:`StateError` naming ``name`` if ``arr`` holds NaN or inf."""
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise StateError(
            f"{name}: entry {idx if len(idx) > 1 else idx[0]} is {float(arr[idx])!r}; "
            "states must be finite"
        )


def same_batch(*arrays_and_names) -> None:
    """Check that several validated states share one batch shape."""
    shapes = [(a.shape, nm) for a, nm in arrays_and_names]
    first_shape, first_name = shapes[0]
    for shape, nm in shapes[1:]:
        if shape != first_shape:
            raise StateError(
                f"{nm}: got shape {shape}, expected {first_shape} to match {first_name}"
            )
