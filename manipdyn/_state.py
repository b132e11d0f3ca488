"""Validation of joint-state arguments at the API boundary.

Layer: 0 (utilities): joint-state validation at the API boundary.

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
    received and the shape expected, or the first non-finite entry.

    The common case (a float64 ndarray of shape ``(n,)``) costs well under a
    microsecond: this sits in control loops.
    """
    if type(x) is _ND and x.dtype is _F64 and x.shape == (n,):
        # NaN and inf propagate through a sum; only when it is not finite (or
        # overflows) do we pay for the element-wise check.
        if not _isfinite(sum(x.tolist())):
            check_finite(x, name)
        return x
    if type(x) is _ND and x.dtype == _F64:
        arr = x
    else:
        if np.iscomplexobj(x):
            raise StateError(
                f"{name}: expected a real array of shape ({n},) or (N, {n}), got complex values"
            )
        try:
            arr = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise StateError(
                f"{name}: expected a real array of shape ({n},) or (N, {n}), "
                f"could not convert {type(x).__name__}: {exc}"
            ) from None
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
