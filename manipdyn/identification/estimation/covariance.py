"""Uncertainty of the identified base parameters: their covariance, and how it is read.

Layer 5 (identification).

``wls`` (:mod:`.estimation`) divides joint j's rows by its noise level ``sigma_j``
(estimated from that joint's own OLS residuals), so the weighted equations
``W Y_b beta = W tau`` have, to the extent the model is right and the noise white,
unit-variance independent errors.  The QR reduction ``W Y_b = Q R`` then gives the
textbook covariance of the least-squares estimate::

    cov(beta_hat) = (R^T R)^-1 = ((W Y_b)^T (W Y_b))^-1          (r, r)

and Gautier's relative standard deviation ``100 sqrt(cov_kk) / |beta_k|`` (%).
``tests/test_uncertainty.py`` checks that the reported standard deviations match
the spread of the estimate over seeded noise draws on a perturbed UR5, and that
the nominal 95 % intervals cover the truth about 95 % of the time.

``consistent`` solves the same weighted problem with ``J_i >= 0`` (and the
plausibility bounds) as constraints.  Its covariance is reported as the same
``(R^T R)^-1``, the covariance of the unconstrained (active-set-free) WLS
problem.  Reasoning: when no constraint is active at the answer, the
constrained estimate *is* the WLS estimate near the truth (the constraints do
not bind in a neighbourhood), so its first-order covariance is exactly that
one; when constraints are active, the consistent estimate is (up to its small
pull towards the prior) the projection of the WLS estimate onto the convex
feasible set in the metric ``R^T R`` (``||R b - c||^2 = ||R (b - beta_wls)||^2 +
const``), and such a projection never moves the estimate farther from a truth
inside that set: ``(R^T R)^-1`` is then conservative.  ``report["std_source"]`` says which estimate a report carries
and ``report["active_bounds"]`` which bounds bind; a block bootstrap
(:mod:`.bootstrap`) is the data-driven alternative when the residuals are
correlated in time (then ``(R^T R)^-1``, which assumes white noise, is too
optimistic).
"""

from __future__ import annotations

import numpy as np

__all__ = ["base_covariance", "STD_SOURCE"]

#: what ``report["std_source"]`` says for each method
STD_SOURCE = {
    "wls": "wls covariance (R^T R)^-1 of the weighted base problem",
    "consistent": "wls covariance (R^T R)^-1 of the same weighted base problem without the "
                  "constraints (exact when no constraint is active, conservative otherwise)",
}


def base_covariance(R) -> np.ndarray | None:
    """``(R^T R)^-1`` (r, r) from the R (r, r) of the weighted, QR-reduced base problem
    (module docstring); None when R is singular."""
    R = np.asarray(R, dtype=np.float64)
    try:
        # R^-1 R^-T: better conditioned than inverting R^T R (squares the condition number)
        Rinv = np.linalg.inv(R)
    except np.linalg.LinAlgError:
        return None
    cov = Rinv @ Rinv.T
    return cov if np.all(np.isfinite(cov)) else None
