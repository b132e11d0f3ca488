"""A prediction band as a record: its half-widths, how it was calibrated, and its forms on disk.

Layer 5 (identification), room ``uncertainty``.  :mod:`.bands` calibrates a band from the hold-outs
of the fit data (its module docstring says how and why); this module holds what such a band **is**
once calibrated: :class:`PredictionBand`, its half-width at a sample's leverage ratio, the line it
prints of itself, and its forms in a model's trust record (``prediction_band``,
:meth:`PredictionBand.to_dict`) and in a model file's ``[sources]`` (:meth:`PredictionBand.to_text`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..._support.errors import ModelError

__all__ = ["PredictionBand", "WITHIN_ONE_TRAJECTORY"]

#: what a band calibrated on one trajectory says of itself (validate and identify print it)
WITHIN_ONE_TRAJECTORY = ("the band is calibrated within one trajectory (its posture regions and blocks in time held "
                         "out, of one run or of runs repeating it): it has not seen how another trajectory differs; log "
                         "at least two different trajectories to calibrate it on held-out runs")


@dataclass(frozen=True)
class PredictionBand:
    """A per-joint band ``pred +- half_width`` (module docstring).

    ``level``: the nominal coverage (0.95); ``half_width`` (n,), N m (N for a prismatic joint);
    ``folds``: the number of blocks; ``samples``: held-out residuals it was computed from;
    ``held_out_rms`` (n,): their RMS per joint; ``leverage_gain`` (n,) or None: ``g_j`` of
    ``c_j sqrt(1 + g_j u)`` (module docstring; None or 0: constant); ``trajectories``: the distinct
    trajectories held out (1: the band is within one trajectory, from the blocks alone);
    ``flag_leverage`` (n,) or None: the leverage ratio past which a sample is flagged (module docstring);
    ``regions``: the posture regions held out within one trajectory (0: none, the blocks alone);
    ``slow_speed``, ``slow_half_width`` (n,) or None: the speed class of a fit with a rest threshold
    (:mod:`.conformal`): a sample slower than ``slow_speed_j`` gets at least ``slow_half_width_j``.
    """

    level: float
    half_width: np.ndarray
    folds: int
    samples: int
    held_out_rms: np.ndarray
    leverage_gain: np.ndarray | None = None
    trajectories: int = 1
    flag_leverage: np.ndarray | None = None
    regions: int = 0
    slow_speed: np.ndarray | None = None
    slow_half_width: np.ndarray | None = None

    def __post_init__(self):
        for k in ("half_width", "held_out_rms", "leverage_gain", "flag_leverage", "slow_speed", "slow_half_width"):
            if getattr(self, k) is None:
                continue
            a = np.asarray(getattr(self, k), dtype=np.float64).reshape(-1)
            if not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ModelError(f"prediction band: {k}: expected finite numbers >= 0, got {a.tolist()}")
            a.setflags(write=False)
            object.__setattr__(self, k, a)
        if not 0 < float(self.level) < 1:
            raise ModelError(f"prediction band: level: expected a fraction in (0, 1), got {self.level}")
        if len(self.held_out_rms) != len(self.half_width):
            raise ModelError("prediction band: held_out_rms and half_width differ in length")
        if self.leverage_gain is not None and len(self.leverage_gain) != len(self.half_width):
            raise ModelError("prediction band: leverage_gain and half_width differ in length")
        for k in ("flag_leverage", "slow_speed", "slow_half_width"):
            if getattr(self, k) is not None and len(getattr(self, k)) != len(self.half_width):
                raise ModelError(f"prediction band: {k} and half_width differ in length")
        if (self.slow_speed is None) != (self.slow_half_width is None):
            raise ModelError("prediction band: slow_speed and slow_half_width go together")
        if int(self.trajectories) != self.trajectories or self.trajectories < 1:
            raise ModelError(f"prediction band: trajectories: expected an integer >= 1, got {self.trajectories!r}")
        object.__setattr__(self, "trajectories", int(self.trajectories))
        if int(self.regions) != self.regions or self.regions < 0:
            raise ModelError(f"prediction band: regions: expected an integer >= 0, got {self.regions!r}")
        object.__setattr__(self, "regions", int(self.regions))

    @property
    def within_one_trajectory(self) -> bool:
        """Whether the band saw a single trajectory (module docstring)."""
        return self.trajectories < 2

    @property
    def n(self) -> int:
        return len(self.half_width)

    @property
    def grows(self) -> bool:
        """Whether the half-width grows with the leverage on some joint."""
        return self.leverage_gain is not None and bool(np.any(self.leverage_gain > 0))

    def widths(self, u=None) -> np.ndarray:
        """Half-width per sample and joint (N, n) at leverage ratios ``u`` (N, n); ``u`` None: at ``u = 1``."""
        if u is None or not self.grows:
            return np.broadcast_to(self.half_width, (1, self.n) if u is None else np.shape(u))
        g = self.leverage_gain
        return self.half_width * np.sqrt((1.0 + g * np.asarray(u, dtype=np.float64)) / (1.0 + g))

    def sample_widths(self, u, qd, rest=None) -> np.ndarray:
        """Half-widths (N, n) at the leverage ratios ``u`` (N, n) or None and velocities ``qd`` (N, n): at least
        ``slow_half_width_j`` where ``|qd_j| < slow_speed_j`` (:mod:`.conformal`), except at rest on a joint whose
        static level was measured (``rest``, the :class:`~manipdyn.model.friction_rest.StaticFriction`, which
        then adds that level: what the fit's own rests held), and the static band at rest (``rest``)."""
        qd = np.atleast_2d(np.asarray(qd, dtype=np.float64))
        w = np.array(np.broadcast_to(self.widths(u), qd.shape))
        if self.slow_speed is not None:
            slow = np.abs(qd) < self.slow_speed
            if rest is not None:
                slow &= ~(rest.rest(qd) & rest.measured)
            w = np.where(slow, np.maximum(w, self.slow_half_width), w)
        return w if rest is None else rest.widths(qd, w)

    def interval(self, predicted, u=None) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)`` around ``predicted`` (N, n), at the leverage ratios ``u`` (N, n) when the band grows."""
        p = np.asarray(predicted, dtype=np.float64)
        w = self.widths(u) if u is not None else self.half_width
        return p - w, p + w

    def describe(self) -> str:
        grows = ", growing with the leverage on joint(s) " + ", ".join(
            str(j + 1) for j in np.flatnonzero(self.leverage_gain > 0)) if self.grows else ""
        if not self.within_one_trajectory:
            return (f"held-out trajectories ({self.trajectories} distinct, each predicted by a fit on the others, "
                    f"{self.samples} held-out samples), at least the {self.folds} blocks' within-run band: model "
                    "error between runs and correlated noise")
        if self.regions:
            return (f"held-out posture regions ({self.regions}, each predicted by a fit on the others), at least the "
                    f"{self.folds} blocks' band ({self.samples} held-out samples), within one trajectory: model error "
                    "where the fit must reach postures it did not see, and correlated noise")
        return (f"blocked hold-outs of the fit data ({self.folds} blocks, {self.samples} held-out samples), within "
                f"one trajectory: model error and correlated noise{grows}")

    def to_dict(self) -> dict:
        out = {"method": "blocked hold-out" if self.within_one_trajectory else "held-out trajectories",
               "trajectories": int(self.trajectories), "level": float(self.level), "folds": int(self.folds),
               "samples": int(self.samples), "half_width": [float(x) for x in self.half_width],
               "held_out_rms": [float(x) for x in self.held_out_rms]}
        if self.leverage_gain is not None:
            out["leverage_gain"] = [float(x) for x in self.leverage_gain]
        if self.flag_leverage is not None:
            out["flag_leverage"] = [float(x) for x in self.flag_leverage]
        if self.regions:
            out["regions"] = int(self.regions)
        if self.slow_speed is not None:
            out["slow_speed"] = [float(x) for x in self.slow_speed]
            out["slow_half_width"] = [float(x) for x in self.slow_half_width]
        return out

    @classmethod
    def from_dict(cls, value, n: int, where: str) -> "PredictionBand":
        if not isinstance(value, dict):
            raise ModelError(f"{where}: expected an object with level, folds, samples, half_width, held_out_rms")
        try:
            band = cls(level=float(value["level"]), half_width=np.array(value["half_width"], dtype=np.float64),
                       folds=int(value["folds"]), samples=int(value["samples"]),
                       held_out_rms=np.array(value["held_out_rms"], dtype=np.float64),
                       leverage_gain=(None if value.get("leverage_gain") is None
                                      else np.array(value["leverage_gain"], dtype=np.float64)),
                       trajectories=int(value.get("trajectories", 1)), regions=int(value.get("regions", 0)),
                       flag_leverage=(None if value.get("flag_leverage") is None
                                      else np.array(value["flag_leverage"], dtype=np.float64)),
                       **{k: np.array(value[k], dtype=np.float64) for k in ("slow_speed", "slow_half_width")
                          if value.get(k) is not None})
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            raise ModelError(f"{where}: malformed prediction band ({exc})") from None
        if band.n != n:
            raise ModelError(f"{where}: half_width: expected {n} numbers, got {band.n}")
        return band

    def to_text(self) -> str:
        """One line for a model file's ``[sources]`` (:meth:`from_text` reads it back)."""
        def nums(a):
            return "[" + ", ".join(f"{x:.6g}" for x in a) + "]"

        how = ("" if self.within_one_trajectory else
               f" (at least; {self.trajectories} held-out trajectories set it where wider)")
        if self.within_one_trajectory and self.regions:
            how = f" (at least; {self.regions} held-out posture regions set it where wider)"
        return (f"{100 * self.level:g} % band half-width per joint{how} from {self.folds} blocked hold-outs of "
                f"{self.samples} samples of the fit data: {nums(self.half_width)}; held-out RMS "
                f"{nums(self.held_out_rms)}" + (f"; growing as sqrt(1 + g u) with the leverage ratio u, g "
                                                f"{nums(self.leverage_gain)}" if self.grows else ""))

    @classmethod
    def from_text(cls, text: str, n: int, where: str) -> "PredictionBand":
        m = re.match(r"\s*([0-9.eE+-]+) % band half-width per joint(?: \([^)]*\))? from (\d+) blocked hold-outs of (\d+) "
                     r"samples[^:]*:\s*\[([^\]]*)\];\s*held-out RMS\s*\[([^\]]*)\]", text)
        if m is None:
            raise ModelError(f"{where}: expected '95 % band half-width per joint from K blocked hold-outs of "
                             f"N samples ...: [...]; held-out RMS [...]', got {text[:60]!r}")
        held = re.search(r"\(at least; (\d+) held-out (trajectories|posture regions)", text)
        extra = {} if held is None else ({"trajectories": int(held.group(1))} if held.group(2) == "trajectories"
                                         else {"regions": int(held.group(1))})
        try:
            return cls.from_dict({"level": float(m.group(1)) / 100, "folds": m.group(2), "samples": m.group(3),
                                  "half_width": [float(x) for x in m.group(4).split(",")],
                                  "held_out_rms": [float(x) for x in m.group(5).split(",")], **extra}, n, where)
        except ValueError:
            raise ModelError(f"{where}: the band's numbers are not numbers") from None
