"""Joint-space reference trajectories.

Layer 6 (control).

Every trajectory is called as ``q_d, qd_d, qdd_d = traj(t)``: for a scalar
time ``t`` (s) each is an ``(n,)`` array (rad or m, per second, per second
squared); for an array of times ``(N,)`` each is ``(N, n)``.  Outside its
time span ``[t_start, t_end]`` a trajectory holds its end position at rest
(zero velocity and acceleration).

* :class:`Quintic`: rest-to-rest point-to-point motion, the quintic
  ``s(u) = 10 u^3 - 15 u^4 + 6 u^5`` (zero velocity and acceleration at both ends).
* :class:`ViaPoints`: a quintic spline through via points, continuous up to the
  4th derivative (so acceleration and jerk are continuous), starting and ending
  at rest with zero acceleration.
* :class:`Sampled`: positions (and optionally velocities and accelerations)
  sampled by the user, interpolated.

All of them are piecewise polynomials in the normalised time
``u = (t - t_k) / h_k`` of each segment, evaluated by one small matmul.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

__all__ = ["Trajectory", "PiecewisePolynomial", "Quintic", "ViaPoints", "Sampled"]

_DEG = 5  # every segment is stored as a quintic (lower degrees are zero-padded)


def _real(x, name: str) -> np.ndarray:
    """``x`` as float64, refusing a complex value by ``name`` (numpy would keep its real part and only warn)."""
    try:
        complex_given = np.iscomplexobj(np.asarray(x)) or isinstance(x, complex)
    except (TypeError, ValueError):       # ragged: float64 below says so
        complex_given = False
    if complex_given:
        raise ValueError(f"{name}: expected real numbers, got a complex value (its imaginary part would be dropped)")
    try:
        return np.array(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a real array, got {type(x).__name__}") from None


def _points(x, name, n=None) -> np.ndarray:
    arr = _real(x, name)
    if arr.ndim == 1 and n is None:
        arr = arr[:, None]
    if arr.ndim != 2 or (n is not None and arr.shape[1] != n):
        want = f"(N, {n})" if n is not None else "(N, n)"
        raise ValueError(f"{name}: expected shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: must be finite")
    return arr


def _times(t, name, count) -> np.ndarray:
    t = _real(t, name)
    if t.shape != (count,):
        raise ValueError(f"{name}: expected {count} times, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{name}: must be finite")
    if np.any(np.diff(t) <= 0):
        k = int(np.argmax(np.diff(t) <= 0))
        raise ValueError(f"{name}: must be strictly increasing, got {t[k]!r} then {t[k + 1]!r} "
                         f"at index {k}")
    return t


def _derivative_rows(u: float, h: float) -> np.ndarray:
    """``P`` (3, 6): rows ``d^r/dt^r [1, u, ..., u^5]`` for r = 0, 1, 2, with ``du/dt = 1/h``."""
    u2 = u * u
    u3 = u2 * u
    a, b = 1.0 / h, 1.0 / (h * h)
    return np.array([[1.0, u, u2, u3, u2 * u2, u3 * u2],
                     [0.0, a, 2 * u * a, 3 * u2 * a, 4 * u3 * a, 5 * u2 * u2 * a],
                     [0.0, 0.0, 2.0 * b, 6 * u * b, 12 * u2 * b, 20 * u3 * b]])


class Trajectory:
    """Interface: ``q_d, qd_d, qdd_d = traj(t)``; ``n``, ``t_start``, ``t_end``."""

    n: int
    t_start: float
    t_end: float

    @property
    def duration(self) -> float:
        return self.t_end - self.t_start

    def __call__(self, t):
        raise NotImplementedError


class PiecewisePolynomial(Trajectory):
    """Segments ``q(t) = sum_j c[k, j] u^j``, ``u = (t - breaks[k]) / h_k``, ``j <= 5``.

    Parameters
    ----------
    breaks : (m + 1,)
        Segment boundaries, s, strictly increasing.
    coefs : (m, 6, n)
        Coefficients of each segment in the normalised time ``u`` in [0, 1].
    """

    def __init__(self, breaks, coefs):
        breaks = _real(breaks, "breaks")
        coefs = _real(coefs, "coefs")
        m = len(breaks) - 1
        if m < 1 or coefs.shape[:2] != (m, _DEG + 1):
            raise ValueError(f"coefs: expected shape ({m}, {_DEG + 1}, n), got {coefs.shape}")
        self.breaks = breaks
        self.coefs = coefs
        self.n = coefs.shape[2]
        self.t_start, self.t_end = float(breaks[0]), float(breaks[-1])
        self._h = np.diff(breaks)
        self._blist, self._hlist = breaks.tolist(), self._h.tolist()
        self._q_start = coefs[0, 0].copy()             # q at u = 0 of the first segment
        self._q_end = coefs[-1].sum(axis=0)            # q at u = 1 of the last segment
        self._zero = np.zeros(self.n)

    def _eval_scalar(self, t):
        k = min(max(bisect.bisect_right(self._blist, t) - 1, 0), len(self._hlist) - 1)
        h = self._hlist[k]
        out = _derivative_rows((t - self._blist[k]) / h, h) @ self.coefs[k]
        return out[0], out[1], out[2]

    def __call__(self, t):
        if isinstance(t, (float, int, np.floating, np.integer)) or np.ndim(t) == 0:
            t = float(t)
            if t <= self.t_start:
                return self._q_start.copy(), self._zero.copy(), self._zero.copy()
            if t >= self.t_end:
                return self._q_end.copy(), self._zero.copy(), self._zero.copy()
            return self._eval_scalar(t)
        t = np.asarray(t, dtype=np.float64)
        if t.ndim != 1:
            raise ValueError(f"t: expected a scalar or a 1-D array of times, got shape {t.shape}")
        k = np.clip(np.searchsorted(self.breaks, t, side="right") - 1, 0, len(self._h) - 1)
        h = self._h[k][:, None]
        u = np.clip((t - self.breaks[k]) / self._h[k], 0.0, 1.0)[:, None]
        j = np.arange(_DEG + 1)
        P0 = u ** j
        P1 = j * u ** np.maximum(j - 1, 0) * (j >= 1) / h
        P2 = j * (j - 1) * u ** np.maximum(j - 2, 0) * (j >= 2) / h**2
        c = self.coefs[k]                                     # (N, 6, n)
        q = np.einsum("bj,bjd->bd", P0, c)
        qd = np.einsum("bj,bjd->bd", P1, c)
        qdd = np.einsum("bj,bjd->bd", P2, c)
        before, after = t <= self.t_start, t >= self.t_end
        q[before], q[after] = self._q_start, self._q_end
        qd[before | after] = 0.0
        qdd[before | after] = 0.0
        return q, qd, qdd


# -- quintic point-to-point ---------------------------------------------------
class Quintic(PiecewisePolynomial):
    """Rest-to-rest motion from ``q0`` to ``q1`` in ``duration`` seconds from ``t0``.

    ``q(t) = q0 + (q1 - q0) s(u)``, ``s(u) = 10 u^3 - 15 u^4 + 6 u^5``,
    ``u = (t - t0) / duration``: zero velocity and acceleration at both ends.
    Peak speed ``1.875 |q1 - q0| / duration``, peak acceleration
    ``5.77 |q1 - q0| / duration^2``.
    """

    def __init__(self, q0, q1, duration: float, t0: float = 0.0):
        q0 = np.atleast_1d(_real(q0, "q0"))
        q1 = np.atleast_1d(_real(q1, "q1"))
        if q0.ndim != 1 or q0.shape != q1.shape:
            raise ValueError(f"q0, q1: expected two (n,) arrays, got shapes {q0.shape} and {q1.shape}")
        if not (np.all(np.isfinite(q0)) and np.all(np.isfinite(q1))):
            raise ValueError("q0, q1: must be finite")
        duration, t0 = float(duration), float(t0)
        if not (duration > 0 and math.isfinite(duration)) or not math.isfinite(t0):
            raise ValueError(f"duration: must be a positive number of seconds, got {duration!r}")
        c = np.zeros((1, _DEG + 1, len(q0)))
        c[0, 0] = q0
        c[0, 3], c[0, 4], c[0, 5] = 10 * (q1 - q0), -15 * (q1 - q0), 6 * (q1 - q0)
        super().__init__([t0, t0 + duration], c)


# -- via points: quintic spline, C4, rest at both ends --------------------------
def _solve_banded(lu: tuple[int, int], ab: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``x`` (N, n) of ``A x = b`` for a band matrix ``A`` (N, N) of ``l`` sub- and ``u`` super-diagonals
    (``lu = (l, u)``), given in LAPACK's form ``ab`` (l + u + 1, N): ``ab[u + i - j, j] = A[i, j]``.

    ``scipy.linalg.solve_banded`` (LAPACK's banded LU with partial pivoting) when SciPy is installed;
    else the same elimination in NumPy, a column at a time (the core needs no SciPy).  Either is
    O(N l (l + u)), where a dense solve is O(N^3)."""
    try:
        from scipy.linalg import solve_banded
    except ImportError:
        solve_banded = None
    if solve_banded is not None:
        return solve_banded(lu, ab, b)
    l, u = lu
    N = ab.shape[1]
    w = np.zeros((2 * l + u + 1, N))              # room for the pivots' fill-in: U gets l + u super-diagonals
    w[l:] = ab
    top = l + u                                   # w[top + i - j, j] = A[i, j]
    x = np.array(b, dtype=np.float64)
    for j in range(N):
        last = min(N - 1, j + l)                  # candidate rows j..last
        cols = np.arange(j, min(N, j + l + u + 1))
        p = j + int(np.argmax(np.abs(w[top:top + last - j + 1, j])))
        if p != j:                                # swap rows j and p over the columns they may hold
            rj, rp = top + j - cols, top + p - cols
            w[rj, cols], w[rp, cols] = w[rp, cols].copy(), w[rj, cols].copy()
            x[[j, p]] = x[[p, j]]
        pivot = w[top, j]
        if pivot == 0.0:
            raise np.linalg.LinAlgError("singular band matrix")
        if last > j:                              # every row below at once
            rows = np.arange(j + 1, last + 1)
            f = w[top + rows - j, j] / pivot
            w[top + rows[:, None] - cols, cols] -= f[:, None] * w[top + j - cols, cols]
            x[j + 1:last + 1] -= f[:, None] * x[j]
    for i in range(N - 1, -1, -1):                # U x = y, U with l + u super-diagonals
        cols = np.arange(i + 1, min(N, i + l + u + 1))
        x[i] = (x[i] - w[top + i - cols, cols] @ x[cols]) / w[top, i]
    return x


def _quintic_spline(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Coefficients (m, 6, n) of the C4 quintic spline through ``y`` (m + 1, n) at ``t``.

    6m unknowns; 2m interpolation conditions, 4(m - 1) continuity conditions
    (derivatives 1 to 4 at the inner knots) and 4 end conditions (zero
    velocity and acceleration at both ends): a square linear system.  Its rows
    taken segment by segment (the start's end conditions, then per segment its two
    points and the continuity at its end, then the end's) make it a band matrix of
    7 sub- and 7 super-diagonals, solved banded (:func:`_solve_banded`): O(m), where
    the dense solve it replaces was O(m^3) (150 ms at 300 points).
    """
    m = len(t) - 1
    h = np.diff(t)
    N = 6 * m
    ab = np.zeros((15, N))                        # ab[7 + i - j, j] = A[i, j]
    b = np.zeros((N, y.shape[1]))
    fact = np.array([math.factorial(i) for i in range(6)], dtype=float)

    def drow(r, u):  # d^r/du^r of [1, u, ..., u^5]
        out = np.zeros(6)
        for jj in range(r, 6):
            out[jj] = fact[jj] / fact[jj - r] * u ** (jj - r)
        return out

    def put(rows, cols0, values):                 # A[rows[k], cols0[k] + c] = values[k, c]
        cols = cols0[:, None] + np.arange(values.shape[1])
        ab[7 + rows[:, None] - cols, cols] = values

    seg = np.arange(m)
    for r in (1, 2):                              # rows 0, 1: at rest at the start
        put(np.array([r - 1]), np.array([0]), drow(r, 0.0)[None])
    for side in (0, 1):                           # per segment, its two points: rows 2 + 6k, 3 + 6k
        put(2 + 6 * seg + side, 6 * seg, np.tile(drow(0, float(side)), (m, 1)))
        b[2 + 6 * seg + side] = y[seg + side]
    inner = seg[:-1]                              # d^r q/dt^r continuous at t_k+1, r = 1..4 (scaled by h_k^r)
    for r in range(1, 5):
        ratio = ((h[:-1] / h[1:]) ** r)[:, None]
        put(3 + 6 * inner + r, 6 * inner, np.hstack([np.tile(drow(r, 1.0), (m - 1, 1)), -drow(r, 0.0) * ratio]))
    for r in (1, 2):                              # the last two rows: at rest at the end
        put(np.array([N - 3 + r]), np.array([6 * (m - 1)]), drow(r, 1.0)[None])
    return _solve_banded((7, 7), ab, b).reshape(m, 6, -1)


class ViaPoints(PiecewisePolynomial):
    """A smooth path through via points: the C4 quintic spline, at rest at both ends.

    Parameters
    ----------
    points : (m + 1, n)
        Joint positions to pass through, the first and last included.
    times : (m + 1,)
        When to pass through each point, s, strictly increasing.

    Position, velocity, acceleration, jerk and snap are continuous; velocity and
    acceleration are zero at the first and the last point.  With two points
    this is :class:`Quintic`.
    """

    def __init__(self, points, times):
        y = _points(points, "points")
        if len(y) < 2:
            raise ValueError(f"points: need at least 2 via points, got {len(y)}")
        t = _times(times, "times", len(y))
        self.points, self.times = y, t
        super().__init__(t, _quintic_spline(t, y))


# -- user samples ----------------------------------------------------------------
_HERMITE5 = np.linalg.inv(np.array([
    # rows: q(0), q'(0), q''(0), q(1), q'(1), q''(1) of [1, u, ..., u^5]
    [1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0],
    [1, 1, 1, 1, 1, 1], [0, 1, 2, 3, 4, 5], [0, 0, 2, 6, 12, 20],
], dtype=float))


def _natural_cubic(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Second derivatives (m + 1, n) of the natural cubic spline: its tridiagonal, diagonally dominant
    system solved banded (:func:`_solve_banded`)."""
    m = len(t) - 1
    h = np.diff(t)
    M = np.zeros_like(y)
    if m < 2:
        return M
    slope = np.diff(y, axis=0) / h[:, None]
    ab = np.zeros((3, m - 1))                     # the super-diagonal, the diagonal, the sub-diagonal
    ab[0, 1:] = h[1:-1]
    ab[1] = 2.0 * (h[:-1] + h[1:])
    ab[2, :-1] = h[1:-1]
    M[1:-1] = _solve_banded((1, 1), ab, 6.0 * (slope[1:] - slope[:-1]))
    return M


class Sampled(PiecewisePolynomial):
    """A trajectory from samples supplied by the user, interpolated.

    Parameters
    ----------
    t : (N,)
        Sample times, s, strictly increasing, N >= 2.
    q : (N, n)
        Joint positions (rad or m) at the sample times.
    qd, qdd : (N, n), optional
        Velocities and accelerations at the sample times.

    Interpolation: with ``q``, ``qd`` and ``qdd``, quintic Hermite segments
    (positions, velocities and accelerations all match the samples: C2); with
    ``q`` and ``qd``, cubic Hermite (C1); with ``q`` alone, the natural cubic
    spline (C2, zero acceleration at both ends).  Before ``t[0]`` and after
    ``t[-1]`` the reference holds the end position at rest.
    """

    def __init__(self, t, q, qd=None, qdd=None):
        y = _points(q, "q")
        if len(y) < 2:
            raise ValueError(f"q: need at least 2 samples, got {len(y)}")
        n = y.shape[1]
        t = _times(t, "t", len(y))
        h = np.diff(t)[:, None]
        if qdd is not None and qd is None:
            raise ValueError("qdd: give qd as well (or neither)")
        if qd is None:
            M = _natural_cubic(t, y)
            c = np.zeros((len(h), 6, n))
            c[:, 0] = y[:-1]
            c[:, 2] = M[:-1] * h**2 / 2
            c[:, 3] = (M[1:] - M[:-1]) * h**2 / 6
            c[:, 1] = (y[1:] - y[:-1]) - h**2 * (2 * M[:-1] + M[1:]) / 6
        else:
            v = _points(qd, "qd", n)
            if len(v) != len(y):
                raise ValueError(f"qd: expected {len(y)} samples like q, got {len(v)}")
            if qdd is None:
                c = np.zeros((len(h), 6, n))
                dy = y[1:] - y[:-1]
                v0, v1 = v[:-1] * h, v[1:] * h
                c[:, 0], c[:, 1] = y[:-1], v0
                c[:, 2] = 3 * dy - 2 * v0 - v1
                c[:, 3] = -2 * dy + v0 + v1
            else:
                a = _points(qdd, "qdd", n)
                if len(a) != len(y):
                    raise ValueError(f"qdd: expected {len(y)} samples like q, got {len(a)}")
                ends = np.stack([y[:-1], v[:-1] * h, a[:-1] * h**2,
                                 y[1:], v[1:] * h, a[1:] * h**2], axis=1)   # (m, 6, n)
                c = _HERMITE5 @ ends
        super().__init__(t, c)
