"""Base parameters: the combinations of the standard parameters that the torques see.

Layer: application (identification).

Many parameter combinations never change the joint torques (link 1's inertia
about axes other than its joint axis, for one).  The torques depend on the
full parameter vector ``pi`` (:mod:`manipdyn.parameters`) only through
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

import numpy as np

from ..parameters import parameter_names

__all__ = ["BaseParameters", "base_parameters", "stacked_regressor"]

#: default rank tolerance, relative to the largest pivot (see the module docstring)
RTOL = 1e-8


def stacked_regressor(arm, samples: int = 200, seed: int = 0, armature=False, friction=False,
                      engine: str = "lagrange") -> np.ndarray:
    """The regressor over ``samples`` seeded random states, stacked: (samples n, p)."""
    rng = np.random.default_rng(seed)
    q = arm.random_state(rng, samples)
    qd = rng.uniform(-2.0, 2.0, q.shape)
    qdd = rng.uniform(-5.0, 5.0, q.shape)
    Y = getattr(arm, engine).regressor(q, qd, qdd, armature=armature, friction=friction)
    return Y.reshape(-1, Y.shape[-1])


@dataclass(frozen=True)
class BaseParameters:
    """The base parameters of an arm.

    Attributes
    ----------
    count : int
        Number r of base parameters.
    names : list of str
        The p full parameter names (:func:`manipdyn.parameters.parameter_names`).
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
        The regressor's ``friction=`` (:func:`manipdyn.friction.friction_spec`).
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
    from ._deps import require

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
