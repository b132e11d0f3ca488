"""Base parameters: the combinations of the standard parameters that the torques see.

Layer 5 (identification).

Many parameter combinations never change the joint torques (link 1's inertia
about axes other than its joint axis, for one).  The torques depend on the
full parameter vector ``pi`` (:mod:`manipdyn.model.parameters`) only through
``r`` base parameters ``beta = K pi``; :func:`base_parameters` finds them
numerically, the standard way (Gautier 1990): the regressor ``W`` (N n, p) is
stacked over random states and factored by QR with column pivoting,
``W P = Q [R11 R12]``.  The first ``r`` pivoted columns are independent, the
others are ``W2 = W1 R11^-1 R12``; hence

    W pi = W1 (pi1 + B pi2),   B = R11^-1 R12,   beta = pi1 + B pi2.

Rank tolerance: column k of the pivoted R counts as independent when
``|R_kk| > rtol * |R_00|`` with ``rtol = 1e-8`` by default.  The states are
drawn so that ``W`` is generic (q uniform in the joint limits, qd and qdd
uniform in +-2 rad/s, +-5 rad/s^2), so the dependent columns' ``|R_kk|`` sit
at rounding level (1e-14 relative) and the independent ones above 1e-5: the
tolerance falls in a gap of many decades.  Entries of B below ``1e-10`` are
rounding and are set to zero.
"""

from __future__ import annotations

from dataclasses import dataclass

import numbers

import numpy as np

from ..._support.errors import ModelError
from ...model.parameters import parameter_count, parameter_names, stacked_regressor

__all__ = ["BaseParameters", "base_parameters", "check_base", "stacked_regressor"]

#: default rank tolerance, relative to the largest pivot (see the module docstring)
RTOL = 1e-8


@dataclass(frozen=True)
class BaseParameters:
    """The base parameters of an arm.

    Attributes
    ----------
    count : int
        Number r of base parameters.
    names : list of str
        The p full parameter names (:func:`manipdyn.model.parameters.parameter_names`).
    independent : (r,) int
        Full-parameter indices whose regressor columns are the base regressor:
        ``Y_base = Y[..., independent]``.
    dependent : (p - r,) int
        The other indices.
    K : (r, p)
        ``beta = K @ pi`` (identity on ``independent``, B on ``dependent``).
    armature : bool
        Whether the parameter vector holds armature entries.
    friction : bool or friction spec
        The regressor's ``friction=`` (:func:`manipdyn.model.friction.friction_spec`).
    """

    count: int
    names: list
    independent: np.ndarray
    dependent: np.ndarray
    K: np.ndarray
    armature: bool = False
    friction: object = False

    def from_full(self, pi) -> np.ndarray:
        """Base parameters ``beta = K pi`` (r,) from full parameters (p,)."""
        return self.K @ np.asarray(pi, dtype=np.float64)

    def regressor(self, Y) -> np.ndarray:
        """Base regressor ``Y[..., independent]`` (..., n, r) from the full one (..., n, p)."""
        return np.asarray(Y)[..., self.independent]

    def full_closest_to(self, beta, prior) -> np.ndarray:
        """The full ``pi`` with ``K pi = beta`` closest to ``prior`` (least squares), (p,).

        ``pi = prior + K^+ (beta - K prior)``; with no PSD constraint (see
        :func:`manipdyn.identification.fit` for the consistent case).
        """
        prior = np.asarray(prior, dtype=np.float64)
        return prior + np.linalg.pinv(self.K) @ (np.asarray(beta) - self.K @ prior)

    def expressions(self, digits: int = 4) -> list[str]:
        """Each base parameter as a readable combination, e.g. ``"link2.Izz + 0.1823 link3.m"``."""
        out = []
        for row in self.K:
            terms = []
            for j in np.flatnonzero(row):
                c = row[j]
                name = self.names[j]
                if abs(c - 1.0) < 10 ** -digits:
                    t = f"+ {name}"
                elif abs(c + 1.0) < 10 ** -digits:
                    t = f"- {name}"
                else:
                    t = f"{'-' if c < 0 else '+'} {abs(c):.{digits}g} {name}"
                terms.append(t)
            s = " ".join(terms)
            out.append(s[2:] if s.startswith("+ ") else s)
        return out


def base_parameters(arm, armature: bool = False, friction: bool = False, samples: int = 200,
                    seed: int = 0, rtol: float = RTOL) -> BaseParameters:
    """Find the base parameters of ``arm`` numerically (see the module docstring).

    Parameters
    ----------
    arm : manipdyn.Arm
    armature, friction : bool
        Include armature (n) and friction (2n) parameters.
    samples : int
        Random states stacked (each gives n rows).
    seed : int
        Seed of the states.
    rtol : float
        Rank tolerance, relative to the largest pivot of R.
    """
    from ..._support.deps import require

    p = parameter_count(arm.n, armature, friction) if friction in (True, False, None) else None
    if isinstance(samples, (bool, np.bool_)) or not isinstance(samples, numbers.Integral) or samples < 1:
        raise ModelError(f"samples: expected a positive integer, got {samples!r}")
    if p is not None and int(samples) * arm.n < p:
        # fewer rows than columns: the rank is capped by the rows, not by the arm
        raise ModelError(f"samples: {samples} states give {int(samples) * arm.n} rows for {p} parameter "
                         f"columns; the base parameters need at least {-(-p // arm.n)} states "
                         f"(default 200)")
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ModelError(f"seed: expected an integer >= 0, got {seed!r}")
    if isinstance(rtol, (bool, np.bool_)) or not isinstance(rtol, numbers.Real) or not 0 < rtol < 1:
        raise ModelError(f"rtol: expected a number in (0, 1), got {rtol!r}")
    samples, seed = int(samples), int(seed)
    linalg = require("scipy.linalg", "base_parameters")
    W = stacked_regressor(arm, samples, seed, armature, friction)
    _, R, perm = linalg.qr(W, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    r = int(np.sum(d > rtol * d[0])) if d.size and d[0] > 0 else 0
    ind, dep = perm[:r], perm[r:]
    B = linalg.solve_triangular(R[:r, :r], R[:r, r:])
    B[np.abs(B) < 1e-10] = 0.0
    # order the base parameters by their leading full parameter (readable tables)
    order = np.argsort(ind)
    ind, B = ind[order], B[order]
    p = W.shape[1]
    K = np.zeros((r, p))
    K[np.arange(r), ind] = 1.0
    K[:, dep] = B
    return BaseParameters(count=r, names=parameter_names(arm.n, armature, friction),
                          independent=np.array(ind), dependent=np.sort(dep), K=K,
                          armature=bool(armature), friction=friction)


def check_base(base, arm, armature=False, friction=False, what: str = "base") -> None:
    """Raise :class:`ModelError` unless ``base`` are base parameters of ``arm`` with these
    armature/friction columns.

    Checked on the numbers, not on names: the full regressor of ``arm`` at a few seeded
    random states must equal its base columns times ``K`` (``Y = Y[..., independent] K``,
    the defining property), to ``1e-6`` of the regressor's scale (the factorisation
    leaves ~1e-10; another arm's kinematics leaves order 1).
    """
    if not isinstance(base, BaseParameters):
        raise ModelError(f"{what}: expected a BaseParameters (from base_parameters), got {type(base).__name__}")
    if base.names != parameter_names(arm.n, armature, friction):
        raise ModelError(f"{what}: computed with other armature/friction columns (or for an arm with "
                         f"another number of joints) than this call: {len(base.names)} parameter columns, "
                         f"expected {len(parameter_names(arm.n, armature, friction))}")
    W = stacked_regressor(arm, 4, 12345, armature, friction)
    err = np.abs(W - W[:, base.independent] @ base.K).max()
    if not err <= 1e-6 * max(float(np.abs(W).max()), 1e-300):
        raise ModelError(f"{what}: not the base parameters of {getattr(arm, 'name', '') or 'this arm'!r}: "
                         f"its regressor is not its base columns times K (off by {err:.3g}, relative "
                         f"{err / max(float(np.abs(W).max()), 1e-300):.2g}); was it computed for another arm? "
                         f"Call base_parameters(arm, ...) for this one")
