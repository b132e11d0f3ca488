"""When forward dynamics can be compared to the cross-check's tolerance at all.

Layer 4 (checks).  :func:`qdd_not_comparable` says why two engines' forward dynamics cannot be
held to :data:`TOLERANCE` at given states (an impossible or ill-conditioned mass matrix),
so that :mod:`manipdyn.check.crosscheck` reports it instead of a false disagreement.
"""

from __future__ import annotations

import numpy as np

from .._support.errors import SingularMassMatrixError

__all__ = ["qdd_not_comparable", "TOLERANCE", "MAX_COND"]

#: the cross-check's relative tolerance (:mod:`manipdyn.check.crosscheck`'s docstring says why)
TOLERANCE = 1e-9
#: largest cond(D) at which forward dynamics is compared: solving with D loses
#: about log10(cond D) of float64's 16 digits, so 1e7 leaves 1e-9 (observed: the
#: bundled arms <= 2.4e4, Tiago cut at its arm 4.7e6 with qdd error 1.3e-10)
MAX_COND = 1e7


def qdd_not_comparable(D, dD, dh, dg, qdd) -> str:
    """Why forward dynamics cannot be compared to :data:`TOLERANCE` at these states, or "".

    ``D`` (B, n, n) is the reference mass matrix; ``dD``, ``dh``, ``dg`` the
    other engine's differences from the reference (each within TOLERANCE);
    ``qdd`` (B, n) the accelerations.  Forward dynamics solves ``D qdd = tau
    - h - g``: to first order the engines' qdd then differ by up to
    ``(|dD| |qdd| + |dh| + |dg|) / lambda_min(D)`` (max-norms), even with two
    exact solvers.  When that exceeds TOLERANCE (relative to ``max(1,
    |qdd|)``), a disagreement in qdd would say nothing about the solvers, so
    qdd is not compared and the reason is reported:

    * D not positive definite (a physically impossible inertia: no physical
      forward dynamics, and ABA and a linear solve then differ);
    * D numerically singular (a joint that moves no mass);
    * cond(D) over :data:`MAX_COND`, or the first-order bound above over
      TOLERANCE (float64 cannot give qdd to TOLERANCE at these states).
    """
    w = np.linalg.eigvalsh(D)                       # ascending, (B, n)
    hi = np.maximum(np.abs(w).max(axis=1), 1e-300)
    lo = w[:, 0]
    if np.any(lo < -1e-12 * hi):
        return (f"the mass matrix D(q) is not positive definite (eigenvalue {float(lo.min()):.3g}): some "
                "link's inertia is physically impossible, and forward dynamics has no physical meaning "
                "(ABA and a linear solve then differ); see the physical-consistency warnings")
    singular = lo <= 1e-15 * hi                     # numerically singular (or a zero row)
    if np.any(singular):
        return str(SingularMassMatrixError.for_mass_matrix(D[singular]))
    cond = hi / lo
    if np.any(~(cond <= MAX_COND)):
        return (f"the mass matrix D(q) is ill-conditioned (cond(D) = {float(np.max(cond)):.3g} > "
                f"{MAX_COND:g}): float64 cannot give the forward dynamics to {TOLERANCE:g}; check the "
                "model's inertias")
    B = len(D)
    amax = np.abs(qdd).reshape(B, -1).max(axis=1)
    spread = (np.abs(dD).reshape(B, -1).max(axis=1) * amax + np.abs(dh).reshape(B, -1).max(axis=1)
              + np.abs(dg).reshape(B, -1).max(axis=1)) / lo / np.maximum(1.0, amax)
    if np.any(~(spread <= TOLERANCE)):
        return (f"the engines' D, h, g agree (within {TOLERANCE:g}) but forward dynamics divides their "
                f"differences by lambda_min(D) = {float(lo[np.argmax(spread)]):.3g}: the qdd can differ by "
                f"{float(np.max(spread)):.3g} relative, beyond {TOLERANCE:g}, whatever the solvers (lengths "
                "or joint ranges far from the arm's scale?)")
    return ""
