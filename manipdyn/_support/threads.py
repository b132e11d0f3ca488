"""BLAS threads: one per process where manipdyn's work is many small matrix products.

Layer 0 (support).

OpenBLAS starts one thread per core for every product above a small size;
manipdyn's products (6 x 6 to 70 x 70, batched regressors) are too small to
gain, and on a machine shared with other work the threads only wait on each
other: ``manipdyn excite ur5 --iterations 5 --rate 200`` took 18.2 s with
OpenBLAS's 2 threads and 2.1 s with one, on a 2-core machine shared with other
jobs (``check``: 3.2 s and 2.0 s; ``compare``: 0.68 s and 0.38 s).

:func:`blas_threads` limits the BLAS pools of this process with threadpoolctl
for the duration of a ``with`` block.  threadpoolctl is optional (the
``identify`` extra brings it): without it the block runs unchanged, and
:func:`blas_threads` says so in its ``limited`` attribute.
"""

from __future__ import annotations

import contextlib

__all__ = ["blas_threads"]


class _Limit(contextlib.AbstractContextManager):
    def __init__(self, n: int | None):
        self.n, self.limited, self._ctl = n, False, None

    def __enter__(self):
        if self.n is None:
            return self
        try:
            from threadpoolctl import threadpool_limits
        except ImportError:            # optional: run with the library's own threads
            return self
        _load_scipy_blas()
        self._ctl = threadpool_limits(limits=self.n, user_api="blas")
        self.limited = True
        return self

    def __exit__(self, *exc):
        if self._ctl is not None:
            self._ctl.restore_original_limits()
            self._ctl = None
        return False


def _load_scipy_blas() -> None:
    """Load SciPy's own BLAS (it ships another OpenBLAS than NumPy's) before the limit is set: threadpoolctl
    limits only the libraries loaded at that moment, and SciPy is imported lazily, inside the block.  Left
    unlimited, its two threads spun against the other work: ``observe --fit-data`` on the Panda log (its
    refits) took 9.3 s of CPU where 2.9 s do with SciPy loaded first (a shared 2-core machine under load)."""
    import importlib.util

    if importlib.util.find_spec("scipy") is not None:
        try:
            import scipy.linalg  # noqa: F401
        except ImportError:
            pass


def blas_threads(n: int | None = 1):
    """A context manager limiting BLAS to ``n`` threads (None: unchanged), if threadpoolctl
    is installed; its ``limited`` attribute says whether the limit was applied."""
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
        raise ValueError(f"blas threads: expected a positive integer or None, got {n!r}")
    return _Limit(n)
