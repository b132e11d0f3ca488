"""The bounds of the consistent fit: plausible masses, centres of mass, total mass, gyration floors.

Layer 5 (identification).  Used by :mod:`.sdp` (which re-exports :class:`Bounds`) and the options.

The consistent fit (:mod:`.sdp`) constrains every body to be physical (``J_i >= 0``); a
:class:`Bounds` adds what is plausible around the prior, in the URDF link frames and SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._support.errors import ModelError
from ...model.plausible import gyration_floor, smallest_gyration

__all__ = ["Bounds", "PLAUSIBLE_MASS", "PLAUSIBLE_COM", "PLAUSIBLE_TOTAL", "PLAUSIBLE_GYRATION", "FLOOR_RTOL"]

#: defaults of :meth:`Bounds.plausible`: link mass factor, COM box (m), total mass fraction
PLAUSIBLE_MASS = 0.5
PLAUSIBLE_COM = 0.1
PLAUSIBLE_TOTAL = 0.25
PLAUSIBLE_GYRATION = 0.01


#: a body whose smallest radius of gyration is within this fraction above its floor sits on it
FLOOR_RTOL = 0.02


@dataclass(frozen=True)
class Bounds:
    """Optional bounds of the consistent fit (URDF link frames, SI units).

    Attributes
    ----------
    mass : (n, 2) array or None
        ``lo_i <= m_i <= hi_i`` (kg).
    com : (n, 2, 3) array or None
        The centre of mass inside the box ``[lo, hi]`` (m): ``m lo <= m c <= m hi``.
    gyration : (n,) array or None
        Floor ``r_i`` (m) of the radii of gyration about the COM: ``J_i - r_i^2 m_i diag(1, 1, 1, 0) >= 0``
        (linear in J), every principal second moment about the COM at least ``m_i r_i^2``.
    """

    mass: np.ndarray | None = None
    com: np.ndarray | None = None
    total_mass: tuple | None = None
    gyration: np.ndarray | None = None

    def __post_init__(self):
        for name in ("mass", "com", "total_mass", "gyration"):
            v = getattr(self, name)
            if v is None:
                continue
            if isinstance(v, np.ma.MaskedArray):
                if np.ma.getmaskarray(v).any():
                    raise ModelError(f"Bounds.{name}: a masked array with masked entries (the mask "
                                     "would be dropped); pass v.filled(value)")
                v = np.ma.getdata(v)
            try:
                a = np.asarray(v)
                if a.dtype.kind == "O" and not isinstance(v, np.ndarray):
                    a = np.array(v, dtype=np.float64)   # nested Python numbers
                    if any(isinstance(x, (bool, np.bool_)) for x in np.ravel(np.asarray(v, dtype=object))):
                        raise TypeError("a bool")
            except (TypeError, ValueError, OverflowError) as exc:
                raise ModelError(f"Bounds.{name}: expected real numbers, got {v!r:.60} ({exc})") from None
            if a.dtype.kind not in "fiu":
                raise ModelError(f"Bounds.{name}: expected real numbers, got dtype {a.dtype} "
                                 f"({ {'b': 'bool', 'c': 'complex', 'O': 'object', 'U': 'string', 'S': 'bytes', 'M': 'datetime64', 'm': 'timedelta64'}.get(a.dtype.kind, a.dtype.kind)})")
            a = np.array(a, dtype=np.float64)   # native byte order, a copy we own
            if not np.all(np.isfinite(a)):
                raise ModelError(f"Bounds.{name}: must be finite, got {a.tolist()}")
            want = {"mass": (None, 2), "com": (None, 2, 3), "total_mass": (2,), "gyration": (None,)}[name]
            if a.ndim != len(want) or any(w is not None and w != s for w, s in zip(want, a.shape)):
                raise ModelError(f"Bounds.{name}: expected shape {tuple('n' if w is None else w for w in want)}, "
                                 f"got {a.shape}")
            lo, hi = ((a[..., 0, :], a[..., 1, :]) if name == "com" else (0 * a, a) if name == "gyration"
                      else (a[..., 0], a[..., 1]))
            if np.any(lo > hi):
                raise ModelError(f"Bounds.{name}: a lower bound exceeds its upper bound")
            if name in ("mass", "total_mass", "gyration") and np.any(lo < 0):
                raise ModelError(f"Bounds.{name}: masses must be >= 0")
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @classmethod
    def plausible(cls, arm, mass: float | None = PLAUSIBLE_MASS, com: float | None = PLAUSIBLE_COM,
                  total: float | None = PLAUSIBLE_TOTAL, gyration: float | None = PLAUSIBLE_GYRATION) -> "Bounds":
        """The default bounds of ``identify --method consistent``: plausible around the prior.

        * each link's mass within ``+-mass`` (fraction) of the prior's ``m``: ``[m (1 - mass),
          m (1 + mass)]`` (default 0.5; a massless prior link may take up to ``mass`` times a
          tenth of the heaviest prior link's mass);
        * each centre of mass within ``+-com`` m of the prior's, per axis of the URDF link
          frame (default 0.1 m: a centre of mass stays on its link);
        * the total mass within ``+-total`` (fraction) of the prior's (default 0.25);
        * every radius of gyration about a body's COM at least ``gyration`` (default 0.01) of the
          arm's size (joint offsets and tool summed), or half the prior body's own if less; from the
          geometry alone where the prior body is degenerate (massless, a rod or a plate): never 0 m
          (:func:`manipdyn.model.completion.gyration_floor`).  Else, where the data do not decide a
          body's shape, the fit ends on ``J_i >= 0`` (issue 30).

        A bound given as None is left out.  Why: ten seconds of data rarely pin down every
        parameter direction, and an unbounded physically consistent fit can put a 79 kg
        Panda (the real one is 18 kg) on a face of the feasible set that fits the noise.
        """
        joints, _ = arm.chain()
        m = np.array([j.body.mass for j in joints])
        c = np.array([j.body.com for j in joints])
        kw = {}
        if mass is not None:
            if not 0 <= mass < float("inf"):
                raise ModelError(f"mass: expected a finite fraction >= 0, got {mass}")
            hi = np.where(m > 0, m * (1 + mass), mass * max(float(m.max()), 0.0) / 10)
            kw["mass"] = np.stack([m * max(0.0, 1 - mass), hi], axis=1)
        if com is not None:
            if not 0 <= com < float("inf"):
                raise ModelError(f"com: expected a finite distance >= 0 m, got {com}")
            kw["com"] = np.stack([c - com, c + com], axis=1)
        if total is not None:
            if not 0 <= total < 1:
                raise ModelError(f"total: expected a fraction in [0, 1), got {total}")
            kw["total_mass"] = (float(m.sum()) * (1 - total), float(m.sum()) * (1 + total))
        if gyration:       # never above half a prior body's own (a flat link stays feasible), never 0 m
            kw["gyration"] = gyration_floor(arm, gyration)
        return cls(**kw)

    def scaled(self, factor: float) -> "Bounds":
        """The same bounds for parameters multiplied by ``factor`` (masses scaled, COM boxes kept)."""
        return Bounds(mass=None if self.mass is None else self.mass * factor, com=self.com,
                      total_mass=None if self.total_mass is None else self.total_mass * factor, gyration=self.gyration)

    def check(self, n: int) -> None:
        """Raise :class:`ModelError` unless these bounds are for an arm of ``n`` links."""
        for name in ("mass", "com"):
            a = getattr(self, name)
            if a is not None and a.shape[0] != n:
                raise ModelError(f"Bounds.{name}: {a.shape[0]} rows for an arm of {n} links")

    def satisfied(self, pi, n: int, rtol: float = 1e-9) -> bool:
        """Whether the full parameters ``pi`` satisfy every bound (to ``rtol`` of the bound)."""
        pi = np.asarray(pi, dtype=np.float64)
        m = pi[10 * np.arange(n)]
        if self.mass is not None:
            tol = rtol * np.maximum(self.mass[:, 1], 1e-12)
            if np.any(m < self.mass[:, 0] - tol) or np.any(m > self.mass[:, 1] + tol):
                return False
        if self.com is not None:
            mc = pi[(10 * np.arange(n))[:, None] + np.arange(1, 4)]
            tol = rtol * np.maximum(np.abs(self.com).max(), 1.0) * np.maximum(np.abs(m), 1e-12)[:, None]
            if np.any(mc < m[:, None] * self.com[:, 0] - tol) or np.any(mc > m[:, None] * self.com[:, 1] + tol):
                return False
        if self.total_mass is not None:
            tot, (lo, hi) = float(m.sum()), self.total_mass
            if tot < lo - rtol * hi or tot > hi + rtol * hi:
                return False
        return True       # the gyration floor is a plausibility floor, best effort: active() names it

    def active(self, pi, n: int, rtol: float = 1e-4) -> list[str]:
        """The bounds that the full parameters ``pi`` sit on (within ``rtol``), as readable strings."""
        pi = np.asarray(pi, dtype=np.float64)
        m = pi[10 * np.arange(n)]
        out = []
        if self.mass is not None:
            for i in range(n):
                lo, hi = self.mass[i]
                tol = rtol * max(hi, 1e-9)
                if m[i] <= lo + tol or m[i] >= hi - tol:
                    which = "lower" if m[i] <= lo + tol else "upper"
                    out.append(f"link {i + 1} mass at its {which} bound {m[i]:.4g} kg")
        if self.com is not None:
            for i in range(n):
                if m[i] <= 0:
                    continue
                ci = pi[10 * i + 1:10 * i + 4] / m[i]
                for ax, name in enumerate("xyz"):
                    lo, hi = self.com[i, 0, ax], self.com[i, 1, ax]
                    tol = rtol * max(abs(hi - lo), 1e-9)
                    if ci[ax] <= lo + tol or ci[ax] >= hi - tol:
                        out.append(f"link {i + 1} centre of mass {name} = {ci[ax]:.4g} m at its bound")
        if self.total_mass is not None:
            lo, hi = self.total_mass
            tot = float(m.sum())
            if tot <= lo + rtol * hi or tot >= hi - rtol * hi:
                out.append(f"total mass {tot:.4g} kg at its bound [{lo:.4g}, {hi:.4g}] kg")
        if self.gyration is not None:      # the body's own radius, as the model on disk has it (issue 38)
            rg = smallest_gyration(pi, n)
            out += [f"link {i + 1} radius of gyration {rg[i]:.3g} m at its floor {self.gyration[i]:.3g} m"
                    if rg[i] >= self.gyration[i] * (1 - FLOOR_RTOL) else
                    f"link {i + 1} radius of gyration {rg[i]:.3g} m below its floor {self.gyration[i]:.3g} m: the "
                    "floor does not hold on this body"
                    for i in range(n) if m[i] > 0 and rg[i] <= self.gyration[i] * (1 + FLOOR_RTOL)]
        return out

    @classmethod
    def around(cls, arm, mass: float = 0.5, com: float = 0.1) -> "Bounds":
        """Masses within ``+-mass`` (fraction) of the prior's, COMs within ``+-com`` m of them."""
        joints, _ = arm.chain()
        m = np.array([j.body.mass for j in joints])
        c = np.array([j.body.com for j in joints])
        return cls(mass=np.stack([m * (1 - mass), m * (1 + mass)], axis=1),
                   com=np.stack([c - com, c + com], axis=1))
