"""What the data never saw: the range of states a fit used, and how far new data leaves it.

Layer 5 (identification).

A model identified from a log is a statement about the states of that log.  Outside them
it extrapolates: a gravity term or a friction offset that the fit learnt over
``q2 in [-1.55, 0.31]`` rad is carried to ``q2 = 1.18`` rad with nothing to check it
against (the Panda of the project's README).  So ``identify`` records, per joint, the
interval ``[min, max]`` of the fitted samples of

* ``q`` (rad, or m for a prismatic joint),
* ``qd`` (rad/s or m/s),
* ``tau``, the measured joint torque (N m or N),

(:class:`StateRange`, :func:`fitted_range`), and ``validate`` reports per joint the
fraction of its samples whose ``q_j``, ``qd_j`` or ``tau_j`` lies outside that interval
(:meth:`StateRange.outside`, :class:`Extrapolation`).  A joint is flagged (it
*extrapolates*) when more than :data:`FLAG_FRACTION` of its samples lie beyond the fitted
interval by more than :data:`FLAG_MARGIN` of the interval's width: samples a hair beyond the
fitted extremes are the same states (the extremes of a smooth trajectory are touched
briefly), a twentieth of the data well beyond them is a region the fit never saw.

The per-joint view is a simplification: joint j's torque depends on every joint's
position, so an extrapolating joint also moves the others' predictions.  The report
therefore names the quantity and the joint; the flag is the user's cue to read the
other joints' numbers with care too.

The intervals travel with the model: in a model file's ``[sources]`` table as the string
``fitted_range`` (:meth:`StateRange.to_text`, bounds rounded outwards to 1e-4 so no fitted
sample falls outside), and in a base model JSON's ``provenance`` as an object
(:meth:`StateRange.to_dict`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError

__all__ = ["StateRange", "Extrapolation", "fitted_range", "FLAG_FRACTION", "FLAG_MARGIN", "QUANTITIES"]

#: a joint extrapolates when more than this fraction of its samples is beyond the fitted range ...
FLAG_FRACTION = 0.05
#: ... by more than this fraction of the range's width (q, qd or tau)
FLAG_MARGIN = 0.1
#: the recorded quantities, in order, with their units (revolute; a prismatic joint's are m, m/s, N)
QUANTITIES = (("q", "rad"), ("qd", "rad/s"), ("tau", "N m"))
_DIGITS = 4          # decimals of the recorded bounds (rounded outwards)


def _outward(lo: float, hi: float) -> tuple[float, float]:
    s = 10.0 ** _DIGITS
    return math.floor(lo * s) / s, math.ceil(hi * s) / s


@dataclass(frozen=True)
class StateRange:
    """Per-joint intervals of the fitted states: ``q``, ``qd``, ``tau``, each (n, 2) ``[min, max]``, SI."""

    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray

    def __post_init__(self):
        shapes = {k: np.shape(getattr(self, k)) for k, _ in QUANTITIES}
        n = shapes["q"][0] if len(shapes["q"]) == 2 else -1
        for k, shape in shapes.items():
            a = np.asarray(getattr(self, k), dtype=np.float64)
            if shape != (n, 2) or not np.all(np.isfinite(a)) or np.any(a[:, 0] > a[:, 1]):
                raise ModelError(f"fitted range: {k}: expected {max(n, 0)} finite [min, max] pairs with "
                                 f"min <= max, got shape {shape}")
            if a.size and not float(np.max(np.abs(a))) <= limits.MAX_SIGNAL:
                # no fit saw a state beyond what a log may hold (1e308 overflowed its rounding)
                raise ModelError(f"fitted range: {k}: a bound of magnitude {float(np.max(np.abs(a))):.3g}, over "
                                 f"{limits.MAX_SIGNAL:g} (manipdyn.limits.MAX_SIGNAL, the largest logged signal)")
            a.setflags(write=False)
            object.__setattr__(self, k, a)

    @property
    def n(self) -> int:
        return self.q.shape[0]

    def to_dict(self) -> dict:
        """JSON-ready: ``{"q": [[min, max], ...], "qd": ..., "tau": ...}`` (bounds rounded outwards)."""
        return {k: [list(_outward(*row)) for row in getattr(self, k)] for k, _ in QUANTITIES}

    @classmethod
    def from_dict(cls, value, n: int, where: str) -> "StateRange":
        """Read :meth:`to_dict`'s object back; errors name ``where``."""
        if not isinstance(value, dict):
            raise ModelError(f"{where}: expected an object with keys q, qd, tau")
        arrays = {}
        for k, _ in QUANTITIES:
            try:
                a = np.array(value[k], dtype=np.float64)
            except (KeyError, TypeError, ValueError, OverflowError):
                raise ModelError(f"{where}: key {k!r}: expected {n} [min, max] pairs of numbers") from None
            if a.shape != (n, 2):
                raise ModelError(f"{where}: key {k!r}: expected {n} [min, max] pairs, got shape {a.shape}")
            arrays[k] = a
        try:
            return cls(**arrays)
        except ModelError as exc:
            raise ModelError(f"{where}: {exc}") from None

    def to_text(self) -> str:
        """One line for a model file's ``[sources]`` (:meth:`from_text` reads it back)."""
        parts = [f"{k} ({unit}) " + " ".join(f"[{lo:.{_DIGITS}f}, {hi:.{_DIGITS}f}]"
                                              for lo, hi in (_outward(*row) for row in getattr(self, k)))
                 for k, unit in QUANTITIES]
        return "states the fit saw, [min, max] per joint: " + "; ".join(parts)

    @classmethod
    def from_text(cls, text: str, n: int, where: str) -> "StateRange":
        """Read :meth:`to_text`'s line back; errors name ``where``."""
        body = text.split(":", 1)[-1]
        arrays = {}
        for part in body.split(";"):
            m = re.match(r"\s*(\w+)\s*\([^)]*\)\s*(.*)$", part)
            if m is None or m.group(1) not in dict(QUANTITIES):
                raise ModelError(f"{where}: expected 'q (unit) [min, max] ...; qd (unit) ...; tau (unit) ...', "
                                 f"got {part.strip()[:60]!r}")
            pairs = re.findall(r"\[\s*([^,\]]+),\s*([^\]]+)\]", m.group(2))
            try:
                arrays[m.group(1)] = np.array([[float(a), float(b)] for a, b in pairs], dtype=np.float64)
            except ValueError:
                raise ModelError(f"{where}: {m.group(1)}: the bounds are not numbers") from None
        missing = [k for k, _ in QUANTITIES if k not in arrays]
        if missing:
            raise ModelError(f"{where}: missing {', '.join(missing)}")
        return cls.from_dict({k: v.tolist() for k, v in arrays.items()}, n, where)

    def outside(self, data, flag_fraction: float = FLAG_FRACTION, margin: float = FLAG_MARGIN) -> "Extrapolation":
        """How ``data`` (``q``, ``qd``, ``tau`` (N, n)) leaves the fitted range, per joint."""
        if data.q.shape[1] != self.n:
            raise ModelError(f"data: {data.q.shape[1]} joints, but the fitted range has {self.n}")
        frac, span, any_out = {}, {}, np.zeros(data.q.shape, dtype=bool)
        far = np.zeros(data.q.shape, dtype=bool)
        for k, _ in QUANTITIES:
            x, box = np.asarray(getattr(data, k), dtype=np.float64), getattr(self, k)
            out = (x < box[:, 0]) | (x > box[:, 1])
            pad = margin * (box[:, 1] - box[:, 0])
            far |= (x < box[:, 0] - pad) | (x > box[:, 1] + pad)
            frac[k] = np.mean(out, axis=0)
            span[k] = np.stack([np.min(x, axis=0), np.max(x, axis=0)], axis=1)
            any_out |= out
        return Extrapolation(fraction=np.mean(any_out, axis=0), by_quantity=frac, data_range=span,
                             fitted=self, far_fraction=np.mean(far, axis=0), flag_fraction=float(flag_fraction),
                             margin=float(margin))


    def far_samples(self, data, margin: float = FLAG_MARGIN) -> np.ndarray:
        """(N, n) bool: the sample's own ``q_j`` or ``qd_j`` lies beyond the fitted interval by more than
        ``margin`` of its width (what is known before the torque is measured; module docstring)."""
        far = np.zeros(np.shape(data.q), dtype=bool)
        for k in ("q", "qd"):
            x, box = np.asarray(getattr(data, k), dtype=np.float64), getattr(self, k)
            pad = margin * (box[:, 1] - box[:, 0])
            far |= (x < box[:, 0] - pad) | (x > box[:, 1] + pad)
        return far


def fitted_range(q, qd, tau) -> StateRange:
    """The :class:`StateRange` of the fitted samples ``q``, ``qd``, ``tau`` (N, n), SI."""
    arrays = {}
    for k, x in (("q", q), ("qd", qd), ("tau", tau)):
        x = np.asarray(x, dtype=np.float64)
        if x.ndim != 2 or len(x) == 0:
            raise ModelError(f"{k}: expected (N, n) samples with N >= 1, got shape {x.shape}")
        arrays[k] = np.stack([np.min(x, axis=0), np.max(x, axis=0)], axis=1)
    return StateRange(**arrays)


@dataclass
class Extrapolation:
    """Per joint, how new data leaves a :class:`StateRange`.

    ``fraction`` (n,): samples with ``q_j``, ``qd_j`` or ``tau_j`` outside the fitted interval;
    ``by_quantity``: the same per quantity (``{"q": (n,), "qd": ..., "tau": ...}``);
    ``data_range``: the new data's ``[min, max]`` per quantity, (n, 2); ``far_fraction`` (n,):
    samples beyond the interval by more than ``margin`` of its width; ``flagged`` (n,) bool:
    ``far_fraction > flag_fraction`` (the joint extrapolates).
    """

    fraction: np.ndarray
    by_quantity: dict
    data_range: dict
    fitted: StateRange
    far_fraction: np.ndarray
    flag_fraction: float = FLAG_FRACTION
    margin: float = FLAG_MARGIN
    beyond: np.ndarray | None = None        # (N, n) bool: the sample's leverage beyond the fit's (.leverage)
    leverage_ratio: np.ndarray | None = None  # (N, n): leverage over the fit samples' mean (.leverage)
    flags: np.ndarray | None = None         # (N, n) bool: the sample's flag, before its torque is seen

    @property
    def range_flagged(self) -> np.ndarray:
        """(n,) bool: the joint's own q, qd or tau leaves the fitted interval (module docstring)."""
        return self.far_fraction > self.flag_fraction

    @property
    def beyond_fraction(self) -> np.ndarray | None:
        """(n,): the fraction of samples whose leverage is beyond the fit's (None without a leverage reference)."""
        return None if self.beyond is None else np.mean(self.beyond, axis=0)

    @property
    def leverage_flagged(self) -> np.ndarray:
        """(n,) bool: over :data:`FLAG_FRACTION` of the samples beyond the fit by the leverage of the joint's row,
        the whole state its torque depends on (:mod:`.leverage`)."""
        b = self.beyond_fraction
        return np.zeros(len(self.fraction), dtype=bool) if b is None else b > self.flag_fraction

    @property
    def flagged_fraction(self) -> np.ndarray | None:
        """(n,): the fraction of samples flagged (``flags``), None without per-sample flags."""
        return None if self.flags is None else np.mean(self.flags, axis=0)

    @property
    def flagged(self) -> np.ndarray:
        """(n,) bool: the joint extrapolates, by its own range (q, qd or tau), by its regressor row's leverage, or
        by over ``flag_fraction`` of its samples flagged (the ``x{i}`` columns): the verdict and the
        per-sample flags say the same thing."""
        out = self.range_flagged | self.leverage_flagged
        if self.flags is not None:
            out = out | (self.flagged_fraction > self.flag_fraction)
        return out

    def to_list(self) -> list:
        """JSON-ready, one object per joint."""
        out = []
        for j in range(len(self.fraction)):
            row = {"joint": j + 1, "outside_fraction": float(self.fraction[j]),
                   "far_outside_fraction": float(self.far_fraction[j]), "extrapolates": bool(self.flagged[j]),
                   "range_extrapolates": bool(self.range_flagged[j]),
                   "leverage_extrapolates": bool(self.leverage_flagged[j])}
            if self.flags is not None:
                row["flagged_fraction"] = float(self.flagged_fraction[j])
            if self.beyond is not None:
                row["beyond_fit_fraction"] = float(self.beyond_fraction[j])
                u = self.leverage_ratio[:, j]
                row["leverage_ratio"] = {"median": float(np.median(u)), "p95": float(np.quantile(u, 0.95)),
                                         "max": float(np.max(u))}
            for k, _ in QUANTITIES:
                row[k] = {"outside_fraction": float(self.by_quantity[k][j]),
                          "fitted": [float(x) for x in self.fitted.to_dict()[k][j]],
                          "data": [float(x) for x in self.data_range[k][j]]}
            out.append(row)
        return out

    def summary(self) -> str:
        """One line: the fractions outside per joint and the joints that extrapolate."""
        flagged = [str(j + 1) for j in np.flatnonzero(self.flagged)]
        return ("samples outside the fitted range: " + ", ".join(
            f"j{j + 1} {100 * f:.1f} %" for j, f in enumerate(self.fraction))
            + ("; extrapolates on joint(s) " + ", ".join(flagged) if flagged else "; no joint extrapolates"))

    def format(self, units=None) -> str:
        """Lines for the text report: the fractions per joint, then one line per flagged joint."""
        n = len(self.fraction)
        lines = ["samples outside the fitted range (q, qd or tau): " + ", ".join(
            f"j{j + 1} {100 * self.fraction[j]:.1f} %" for j in range(n))]
        if self.beyond is not None:
            lines.append("samples beyond the fit by the leverage of the joint's regressor row (every joint's state): "
                         + ", ".join(f"j{j + 1} {100 * f:.1f} %" for j, f in enumerate(self.beyond_fraction)))
            for j in np.flatnonzero(self.leverage_flagged & ~self.range_flagged):
                lines.append(f"EXTRAPOLATES joint {j + 1}: its own q, qd and tau stay near the fitted range, but "
                             f"{100 * self.beyond_fraction[j]:.0f} % of its samples lie beyond the fit by "
                             "the leverage of its regressor row, farther than the held-out data the band was checked on (the other joints' states its torque depends on; "
                             f"up to {np.max(self.leverage_ratio[:, j]):.3g} times the fit's mean): trust this joint's "
                             "prediction less")
        if self.flags is not None:
            lines.append("samples flagged before their torque is seen (x columns: own q or qd beyond the fitted range, "
                         "leverage beyond the held-out data's, or near rest where the fit never rested): " + ", ".join(
                             f"j{j + 1} {100 * f:.1f} %" for j, f in enumerate(self.flagged_fraction)))
            for j in np.flatnonzero(self.flagged & ~self.leverage_flagged & ~self.range_flagged):
                lines.append(f"EXTRAPOLATES joint {j + 1}: {100 * self.flagged_fraction[j]:.0f} % of its samples are "
                             "flagged (its q or qd beyond the fitted range, or near rest where the fit data never "
                             "rested): trust this joint's prediction less there")
        for j in np.flatnonzero(self.range_flagged):
            revolute = units is None or units[j] != "N"
            why = []
            for k, unit in QUANTITIES:
                f = self.by_quantity[k][j]
                if f > 0:
                    unit = unit if revolute else {"rad": "m", "rad/s": "m/s", "N m": "N"}[unit]
                    lo, hi = self.fitted.to_dict()[k][j]
                    dlo, dhi = self.data_range[k][j]
                    why.append(f"{k}{j + 1} in [{dlo:.3g}, {dhi:.3g}] {unit}, fitted [{lo:.3g}, {hi:.3g}] "
                               f"({100 * f:.0f} % outside)")
            lines.append(f"EXTRAPOLATES joint {j + 1}: " + "; ".join(why)
                         + f"; {100 * self.far_fraction[j]:.0f} % beyond it by over {100 * self.margin:g} % of its "
                           "width: the fit never saw these states, so trust this joint's prediction less"
                         + (f" ({100 * self.beyond_fraction[j]:.0f} % beyond the fit by leverage)"
                            if self.beyond is not None else ""))
        return "\n".join(lines)
