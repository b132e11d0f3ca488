"""Prediction bands that hold on the next trajectory: blocked hold-outs of the fit data.

Layer 5 (identification).

What a band must cover
----------------------
On a new sample the error is ``tau - f_hat(x) = [f(x) - f_hat(x)] + e``.  The first term is
parameter error (what the base parameters' covariance describes) **plus model error**: a
friction law that is not the arm's, elasticity, cables, thermal drift.  Model error does not
shrink with more data and is not a parameter uncertainty.  ``e`` is the measurement noise,
**coloured** by the drive's controller, by resampling and by the zero-phase filter.

The covariance band ``1.96 sqrt(y_b C y_b^T + sigma_j^2)`` counts only parameter error and
white noise: ``C`` scales with ``sigma^2 (Y^T Y)^-1`` as if every sample were independent,
so correlated residuals make it too narrow, and model error is in it only as far as it
inflates ``sigma`` on the fit data.  On real arms it held 13 to 57 % of the samples.

What is done instead (:func:`calibrate_band`)
---------------------------------------------
The fit data itself is cut into ``folds`` contiguous blocks in time (5 by default).  Each
block is predicted by a fit, with the same method and options, on the other blocks, and
the held-out residuals ``r = tau - f_hat_(-k)(x)`` are collected (:func:`held_out_residuals`).
They contain

* parameter error of a fit on (K-1)/K of the data: a little more than the full fit's, so
  the band errs on the wide side;
* model error where it shows between blocks: each held-out block holds states the
  others reach less well, a small dose of the extrapolation the next trajectory brings;
* the noise as it is, correlations included: contiguous blocks are long against the
  correlation time, so a refit cannot follow the noise of the block it predicts (random
  folds would leave every held-out sample's neighbours in the fit and make the band narrow).

The band's half-width per joint is a split-conformal quantile of these scores,
``c_j = the ceil((m + 1) level)-th smallest |r_j|`` among the ``m`` held-out residuals
(for exchangeable scores this covers at least ``level`` of new samples).  Samples of a time
series are not exchangeable, but the correction is tiny for the thousands of samples of a
log; the risk that remains is new data farther from the fit data than the blocks are from
each other, which :mod:`.coverage` reports.  The band is ``[pred - c_j, pred + c_j]``:

* constant per joint, not scaled by the covariance's ``std(x)``: on real arms the
  model error dominates and does not follow the parameter uncertainty, and n numbers
  travel with any model (model file, URDF comment, base JSON), covariance or not;
* symmetric: a mean error of the fit window (a bias) need not carry to another
  trajectory with its sign, so ``|r|`` covers either.

The numbers travel with the model: a model file's ``[sources]`` string ``prediction_band``
(:meth:`PredictionBand.to_text`), a base model's ``provenance.prediction_band`` object
(:meth:`PredictionBand.to_dict`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..._support.errors import ModelError

__all__ = ["PredictionBand", "calibrate_band", "held_out_residuals", "DEFAULT_FOLDS", "DEFAULT_LEVEL"]

DEFAULT_FOLDS = 5
DEFAULT_LEVEL = 0.95
#: a held-out block shorter than this many samples is too short to say anything
MIN_BLOCK = 20


@dataclass(frozen=True)
class PredictionBand:
    """A per-joint band ``pred +- half_width`` (module docstring).

    ``level``: the nominal coverage (0.95); ``half_width`` (n,), N m (N for a prismatic joint);
    ``folds``: the number of blocks; ``samples``: held-out residuals it was computed from;
    ``held_out_rms`` (n,): their RMS per joint.
    """

    level: float
    half_width: np.ndarray
    folds: int
    samples: int
    held_out_rms: np.ndarray

    def __post_init__(self):
        for k in ("half_width", "held_out_rms"):
            a = np.asarray(getattr(self, k), dtype=np.float64).reshape(-1)
            if not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ModelError(f"prediction band: {k}: expected finite numbers >= 0, got {a.tolist()}")
            a.setflags(write=False)
            object.__setattr__(self, k, a)
        if not 0 < float(self.level) < 1:
            raise ModelError(f"prediction band: level: expected a fraction in (0, 1), got {self.level}")
        if len(self.held_out_rms) != len(self.half_width):
            raise ModelError("prediction band: held_out_rms and half_width differ in length")

    @property
    def n(self) -> int:
        return len(self.half_width)

    def interval(self, predicted) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)`` around ``predicted`` (N, n)."""
        p = np.asarray(predicted, dtype=np.float64)
        return p - self.half_width, p + self.half_width

    def describe(self) -> str:
        return (f"blocked hold-outs of the fit data ({self.folds} blocks, {self.samples} held-out samples): "
                "model error and correlated noise")

    def to_dict(self) -> dict:
        return {"method": "blocked hold-out", "level": float(self.level), "folds": int(self.folds),
                "samples": int(self.samples), "half_width": [float(x) for x in self.half_width],
                "held_out_rms": [float(x) for x in self.held_out_rms]}

    @classmethod
    def from_dict(cls, value, n: int, where: str) -> "PredictionBand":
        if not isinstance(value, dict):
            raise ModelError(f"{where}: expected an object with level, folds, samples, half_width, held_out_rms")
        try:
            band = cls(level=float(value["level"]), half_width=np.array(value["half_width"], dtype=np.float64),
                       folds=int(value["folds"]), samples=int(value["samples"]),
                       held_out_rms=np.array(value["held_out_rms"], dtype=np.float64))
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            raise ModelError(f"{where}: malformed prediction band ({exc})") from None
        if band.n != n:
            raise ModelError(f"{where}: half_width: expected {n} numbers, got {band.n}")
        return band

    def to_text(self) -> str:
        """One line for a model file's ``[sources]`` (:meth:`from_text` reads it back)."""
        def nums(a):
            return "[" + ", ".join(f"{x:.6g}" for x in a) + "]"

        return (f"{100 * self.level:g} % band half-width per joint from {self.folds} blocked hold-outs of "
                f"{self.samples} samples of the fit data: {nums(self.half_width)}; held-out RMS "
                f"{nums(self.held_out_rms)}")

    @classmethod
    def from_text(cls, text: str, n: int, where: str) -> "PredictionBand":
        m = re.match(r"\s*([0-9.eE+-]+) % band half-width per joint from (\d+) blocked hold-outs of (\d+) "
                     r"samples[^:]*:\s*\[([^\]]*)\];\s*held-out RMS\s*\[([^\]]*)\]", text)
        if m is None:
            raise ModelError(f"{where}: expected '95 % band half-width per joint from K blocked hold-outs of "
                             f"N samples ...: [...]; held-out RMS [...]', got {text[:60]!r}")
        try:
            return cls.from_dict({"level": float(m.group(1)) / 100, "folds": m.group(2), "samples": m.group(3),
                                  "half_width": [float(x) for x in m.group(4).split(",")],
                                  "held_out_rms": [float(x) for x in m.group(5).split(",")]}, n, where)
        except ValueError:
            raise ModelError(f"{where}: the band's numbers are not numbers") from None


def _blocks(N: int, folds: int) -> np.ndarray:
    if int(folds) != folds or folds < 2:
        raise ModelError(f"folds: expected an integer >= 2, got {folds!r}")
    edges = np.linspace(0, N, int(folds) + 1).astype(int)
    if np.min(np.diff(edges)) < MIN_BLOCK:
        raise ModelError(f"data: {N} samples are too few for {folds} blocks of at least {MIN_BLOCK}")
    return edges


def _kept_segments(segments, test) -> list | None:
    """The runs' sample counts (``segments``) left after removing the ``test`` samples (empty runs dropped)."""
    if segments is None:
        return None
    edges = np.concatenate([[0], np.cumsum([int(k) for k in segments])])
    if edges[-1] != len(test):
        raise ModelError(f"segments: expected sample counts adding up to the {len(test)} samples, "
                         f"got {list(segments)}")
    kept = [int(np.sum(~test[a:b])) for a, b in zip(edges[:-1], edges[1:])]
    return [k for k in kept if k > 0]


def held_out_residuals(arm, q, qd, qdd, tau, folds: int = DEFAULT_FOLDS, segments=None, **fit_kwargs) -> np.ndarray:
    """Measured minus predicted torque (N, n), each block predicted by a fit on the others.

    ``q, qd, qdd, tau`` (N, n) in time order (one log; several logs: stacked in order, a block
    then may span a boundary, which is harmless: every sample is still predicted by a fit that
    did not see it).  ``segments``: the stacked runs' sample counts, when the fit takes them
    (each refit gets the counts of what it keeps).  ``fit_kwargs`` go to
    :func:`manipdyn.identification.fit` (``method``, ``friction``, ``armature``, ``bounds``,
    ``prior_weight``): the refits are the fit the user asked for, on less data.
    """
    from ..estimation.fitting import fit

    q, qd, qdd, tau = (np.asarray(x, dtype=np.float64) for x in (q, qd, qdd, tau))
    N = len(q)
    edges = _blocks(N, folds)
    res = np.empty_like(tau)
    for k in range(len(edges) - 1):
        test = np.zeros(N, dtype=bool)
        test[edges[k]:edges[k + 1]] = True
        kept = _kept_segments(segments, test)
        extra = {} if kept is None else {"segments": kept}
        r = fit(arm, q[~test], qd[~test], qdd[~test], tau[~test], **fit_kwargs, **extra)
        res[test] = tau[test] - r.predict(q[test], qd[test], qdd[test])
    return res


def conformal_half_width(residuals, level: float = DEFAULT_LEVEL) -> np.ndarray:
    """Per column, the ``ceil((m + 1) level)``-th smallest ``|r|`` of ``m`` residuals (the largest when
    that rank passes ``m``): the split-conformal half-width (module docstring)."""
    r = np.abs(np.asarray(residuals, dtype=np.float64))
    m = len(r)
    rank = min(m, math.ceil((m + 1) * float(level)))
    return np.sort(r, axis=0)[rank - 1]


def calibrate_band(arm, q, qd, qdd, tau, folds: int = DEFAULT_FOLDS, level: float = DEFAULT_LEVEL,
                   **fit_kwargs) -> PredictionBand:
    """The :class:`PredictionBand` of a fit on ``q, qd, qdd, tau`` (N, n) by blocked hold-outs.

    Costs ``folds`` refits.  Raises :class:`ModelError` when the data is too short for the
    blocks or a refit fails (the message says which).
    """
    if not 0 < float(level) < 1:
        raise ModelError(f"level: expected a fraction in (0, 1), got {level}")
    res = held_out_residuals(arm, q, qd, qdd, tau, folds=folds, **fit_kwargs)
    return PredictionBand(level=float(level), half_width=conformal_half_width(res, level), folds=int(folds),
                          samples=len(res), held_out_rms=np.sqrt(np.mean(res**2, axis=0)))
