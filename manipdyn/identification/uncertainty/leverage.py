"""How far a new state is from what the fit data excited, joint by joint: the leverage.

Layer 5 (identification), room ``uncertainty``.

Why not the joint's own range
-----------------------------
Joint j's predicted torque is ``y_j(x) . pi``: its row of the regressor, a function of
**every** joint's position, velocity and acceleration (joint 1 of an arm carries the
inertia of everything outboard, which depends on q2 and q4).  A new state can keep
``q_j``, ``qd_j`` and ``tau_j`` inside their fitted intervals while joints 2 and 4 go 30-50 %
beyond theirs, and joint 1's prediction then extrapolates with no per-joint flag
(:mod:`.coverage` flags by joint, and missed that: a band holding 28 % on such a joint).

The measure
-----------
The statistical leverage of joint j's regressor row against the fit data's rows,

    ``h_j(x) = w_j^2 z_j(x)^T G^+ z_j(x)``,   ``G = sum over the fit samples k and joints i of w_i^2 z_i z_i^T``,

is the variance of the least-squares prediction of joint j at ``x`` in units of the noise
(``sigma^2 h`` for white noise): it is small where the data excited every direction that
``z_j(x)`` points along, and large where ``z_j(x)`` points where the data never went,
whichever joint took it there.  On the fit data itself ``h <= 1`` and its mean is
``rank / (N n)``.  ``z`` (:func:`features`) is the rigid-body regressor (10 columns per link,
standard parameters) and, per joint, ``[qd_j, tanh(qd_j / v_s), 1, qdd_j]`` (viscous and
Coulomb friction, an offset, a rotor inertia): one fixed model class, whatever friction law
the fit used, so a model read from any file gives the same measure from its kinematics
alone.  ``w_j`` is 1 / joint j's held-out RMS error (joints in units of their own error, as the
fit weighs them by their noise); the columns are scaled to unit RMS before the eigenvalues
of ``G`` are cut at ``1e-10`` of the largest (directions the regressor never has).

What is kept (:class:`Leverage`, in the trust record's ``leverage``): the basis
``B = V diag(lambda)^(-1/2)`` of the kept eigenvectors (so ``h = w^2 |z^T B|^2``), the column
scales, the weights, and per joint the mean and the largest leverage over the fit samples.
A sample is **beyond the fit** on joint j when ``u_j(x)`` exceeds ``threshold_j``, the leverage
ratio calibrated on the held-out runs or blocks of the band (:mod:`.bands`, ``flag_leverage``: farther
than 99 % of the samples the band was checked on; ``validate --predictions``' ``x{i}`` columns,
``--json`` ``extrapolation[j].beyond_fit_fraction``).  A reference written before that threshold
existed keeps the older rule, ``h_j(x)`` over every fitted sample's.

States near rest
----------------
Where a joint barely moves, its torque is decided by the Coulomb friction's smoothed sign
``tanh(qd / v_s)``, which the fit can only have learnt where the fit data were near rest.  The
reference keeps, per joint, ``rest_speed`` (:data:`REST_SPEEDS` ``x v_s``: below it the smoothed sign is
in its linear part, ``tanh(1) = 0.76``, and the Coulomb torque there is what the smoothing assumes,
not what the data showed) and whether the fit data **visited** it (at least :data:`REST_FRACTION` of
the fitted samples that slow: an excitation only crosses it at its reversals, well under 1 % of the
time, a log that rests spends seconds there).  A new sample slower than that on a joint
whose fit data never rested is flagged too (:meth:`Leverage.rest_flags`): a log that pauses where
the excitation never did.  The ratio ``u_j = h_j / mean_j`` (1 on a typical
fitted sample) is what the band grows with (:mod:`.bands`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._support.errors import ModelError

__all__ = ["Leverage", "features", "gram_basis", "FRICTION_FEATURES"]

#: per joint: viscous, smoothed Coulomb, offset, rotor inertia
FRICTION_FEATURES = ("qd", "tanh(qd/v_s)", "1", "qdd")
#: eigenvalues of the scaled Gram matrix under this fraction of the largest are directions the rows never have
RTOL = 1e-10
#: significant digits of the basis in a file (a leverage to ~1e-8 relative: far below what it is compared with)
_DIGITS = 10
#: a leverage within this fraction of the fit's largest is the same sample's (the basis is stored rounded)
_SAME = 1e-6
#: near rest: a speed under this many times the Coulomb smoothing v_s (module docstring)
REST_SPEEDS = 1.0
#: the fit data visited rest on a joint when at least this fraction of its samples were that slow
REST_FRACTION = 0.01


def features(arm, q, qd, qdd, smoothing: float) -> np.ndarray:
    """``z`` (N, n, 10 n + 4 n): the rigid-body regressor of ``arm`` (Pinocchio) and the per-joint
    friction features (module docstring) at ``q, qd, qdd`` (N, n), SI; ``smoothing`` v_s, rad/s."""
    q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=np.float64)) for x in (q, qd, qdd))
    N, n = q.shape
    Y = np.asarray(arm.regressor(q, qd, qdd), dtype=np.float64).reshape(N, n, -1)[:, :, :10 * n]
    extra = np.zeros((N, n, len(FRICTION_FEATURES) * n))
    vs = float(smoothing) if smoothing and smoothing > 0 else 0.01
    for j in range(n):
        k = len(FRICTION_FEATURES) * j
        extra[:, j, k:k + 4] = np.stack([qd[:, j], np.tanh(qd[:, j] / vs), np.ones(N), qdd[:, j]], axis=1)
    return np.concatenate([Y, extra], axis=2)


def gram_basis(Z, weights) -> tuple[np.ndarray, np.ndarray]:
    """``(B, scale)`` of the rows ``Z`` (N, n, p) weighted per joint by ``weights`` (n,):
    ``h = w_j^2 |(z / scale) B|^2`` is the leverage (module docstring)."""
    Zw = (Z * np.asarray(weights, dtype=np.float64)[None, :, None]).reshape(-1, Z.shape[2])
    scale = np.sqrt(np.mean(Zw**2, axis=0))
    scale = np.where(scale > 0, scale, 1.0)
    Zs = Zw / scale
    lam, V = np.linalg.eigh(Zs.T @ Zs)
    keep = lam > RTOL * max(float(lam[-1]), 1e-300)
    return V[:, keep] / np.sqrt(lam[keep]), scale


def _h(Z, B, scale, weights) -> np.ndarray:
    """Leverage (N, n) of the rows ``Z`` (N, n, p)."""
    return np.asarray(weights)[None, :] ** 2 * np.sum(((Z / scale) @ B) ** 2, axis=2)


@dataclass(frozen=True)
class Leverage:
    """The extrapolation measure's reference from the fit data (module docstring).

    ``basis`` (p, k), ``scale`` (p,), ``weights`` (n,) 1 / (N m), ``smoothing`` v_s (rad/s),
    ``mean`` and ``largest`` (n,): per joint, the mean and the largest leverage of the fit samples;
    ``threshold`` (n,) or None: the leverage ratio past which a sample is beyond the fit (calibrated on
    held-out data, :mod:`.bands`); ``rest_speed`` (n,) rad/s and ``rest_visited`` (n,) bool, or None:
    the near-rest speeds and whether the fit data visited them (module docstring).
    """

    basis: np.ndarray
    scale: np.ndarray
    weights: np.ndarray
    smoothing: float
    mean: np.ndarray
    largest: np.ndarray
    threshold: np.ndarray | None = None
    rest_speed: np.ndarray | None = None
    rest_visited: np.ndarray | None = None

    @classmethod
    def of_fit(cls, arm, q, qd, qdd, weights, smoothing, threshold=None) -> "Leverage":
        """The reference of the fit samples ``q, qd, qdd`` (N, n); ``threshold`` (n,): the held-out
        leverage ratio past which a sample is flagged (None: the older rule)."""
        Z = features(arm, q, qd, qdd, smoothing)
        weights = np.asarray(weights, dtype=np.float64)
        B, scale = gram_basis(Z, weights)
        h = _h(Z, B, scale, weights)
        rest = np.full(Z.shape[1], REST_SPEEDS * float(smoothing))
        visited = np.mean(np.abs(np.asarray(qd, dtype=np.float64)) < rest, axis=0) >= REST_FRACTION
        return cls(basis=B, scale=scale, weights=weights, smoothing=float(smoothing),
                   mean=np.maximum(np.mean(h, axis=0), 1e-300), largest=np.max(h, axis=0),
                   threshold=None if threshold is None else np.asarray(threshold, dtype=np.float64),
                   rest_speed=rest, rest_visited=visited)

    def rest_flags(self, qd) -> np.ndarray:
        """(N, n) bool: the sample is near rest on a joint whose fit data never rested (module docstring)."""
        qd = np.asarray(qd, dtype=np.float64)
        if self.rest_speed is None or self.rest_visited is None:
            return np.zeros(qd.shape, dtype=bool)
        return (np.abs(qd) < self.rest_speed) & ~np.asarray(self.rest_visited, dtype=bool)

    @property
    def n(self) -> int:
        return len(self.weights)

    def leverage(self, arm, q, qd, qdd) -> np.ndarray:
        """``h`` (N, n) of new states (module docstring)."""
        Z = features(arm, q, qd, qdd, self.smoothing)
        if Z.shape[2] != self.basis.shape[0]:
            raise ModelError(f"leverage: the model's regressor has {Z.shape[2]} columns, the fit's reference "
                             f"{self.basis.shape[0]}: not the arm it was fitted on")
        with np.errstate(over="ignore", invalid="ignore"):
            h = _h(Z, self.basis, self.scale, self.weights)
        if not np.all(np.isfinite(h)):
            raise ModelError("leverage: the reference's basis, scale or weights overflow float64 on these states "
                             "(not a reference a fit wrote)")
        return h

    def ratio(self, arm, q, qd, qdd) -> tuple[np.ndarray, np.ndarray]:
        """``(u, beyond)``, each (N, n): the leverage over the fit samples' mean, and whether the sample is
        beyond the fit on that joint: ``u`` over the held-out ``threshold``, or (a reference without one)
        ``h`` over every fit sample's."""
        h = self.leverage(arm, q, qd, qdd)
        with np.errstate(over="ignore"):
            u = h / self.mean
        if not np.all(np.isfinite(u)):
            raise ModelError("leverage: the ratio to the reference's mean overflows float64 (not a reference a fit wrote)")
        if self.threshold is not None:
            return u, u > self.threshold
        return u, h > self.largest * (1.0 + _SAME)

    def to_dict(self) -> dict:
        def r(a):
            return [float(f"{x:.{_DIGITS}g}") for x in np.asarray(a).reshape(-1)]

        return {"features": "rigid-body regressor + per joint [qd, tanh(qd/v_s), 1, qdd]",
                "smoothing": float(self.smoothing), "weights": r(self.weights), "scale": r(self.scale),
                "mean": r(self.mean), "largest": r(self.largest),
                **({} if self.threshold is None else {"threshold": r(self.threshold)}),
                **({} if self.rest_speed is None else {"rest_speed": r(self.rest_speed),
                                                      "rest_visited": [bool(x) for x in self.rest_visited]}),
                "basis": [r(col) for col in self.basis.T]}

    @classmethod
    def from_dict(cls, value, n: int, where: str) -> "Leverage":
        if not isinstance(value, dict):
            raise ModelError(f"{where}: expected an object with basis, scale, weights, smoothing, mean, largest")
        try:
            basis = np.array(value["basis"], dtype=np.float64).T
            scale = np.array(value["scale"], dtype=np.float64)
            out = cls(basis=basis.reshape(len(scale), -1), scale=scale,
                      weights=np.array(value["weights"], dtype=np.float64), smoothing=float(value["smoothing"]),
                      mean=np.array(value["mean"], dtype=np.float64),
                      largest=np.array(value["largest"], dtype=np.float64),
                      threshold=_optional(value, "threshold", np.float64),
                      rest_speed=_optional(value, "rest_speed", np.float64),
                      rest_visited=_optional(value, "rest_visited", bool))
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelError(f"{where}: malformed leverage reference ({exc})") from None
        if out.n != n or out.mean.shape != (n,) or out.largest.shape != (n,) or len(scale) != 14 * n:
            raise ModelError(f"{where}: expected {n} joints and {14 * n} columns, got {out.n} and {len(scale)}")
        for key in ("weights", "scale", "mean"):          # divisors and weights: a fit writes them > 0
            a = getattr(out, key)
            if not np.all(np.isfinite(a) & (a > 0)):
                raise ModelError(f"{where}: {key}: expected finite numbers > 0, got {a[~(np.isfinite(a) & (a > 0))][:3].tolist()}")
        for k in ("threshold", "rest_speed", "rest_visited"):
            a = getattr(out, k)
            if a is not None and (a.shape != (n,) or (a.dtype != bool and not np.all(np.isfinite(a)))):
                raise ModelError(f"{where}: {k}: expected {n} finite values, got {a.tolist()}")
        if (out.rest_speed is None) != (out.rest_visited is None):
            raise ModelError(f"{where}: rest_speed and rest_visited go together")
        return out


def _optional(value, key, dtype):
    if value.get(key) is None:
        return None
    if dtype is bool and not all(isinstance(x, bool) for x in value[key]):
        raise ValueError(f"{key}: expected true or false per joint")
    return np.array(value[key], dtype=dtype)
