"""Collision detection from an identified model: residuals, thresholds with a stated false-alarm rate, events.

Layer 6 (control: collision).  May import: everything below control (``identification``, ``check``,
``engines``, ``formats``, ``model``, ``_support``).

* :mod:`manipdyn.control.collision.observer`: the generalized-momentum observer (offline :func:`momentum_residual`, online
  :class:`MomentumObserver`) and the direct residual;
* :mod:`manipdyn.control.collision.events`: crossings that last, with hysteresis; isolation (the last link touched) and the
  wrench at the tool ``f = pinv(J^T) r``;
* :mod:`manipdyn.control.collision.observe`: :func:`observe`, a log's residuals, thresholds and events
  (:class:`ObserveResult`, :mod:`manipdyn.control.collision.report`), and :func:`calibrate_thresholds`;
  :mod:`manipdyn.control.collision.holdouts`: thresholds from the band's hold-outs of the fit data (what
  ``manipdyn identify`` writes by default);
  :mod:`manipdyn.control.collision.reading`: the logs as the observer reads them (the thresholds themselves live in
  :mod:`manipdyn.identification.uncertainty.thresholds`, beside the band they share hold-outs with).
"""

from ...identification.uncertainty.thresholds import CollisionThresholds
from .events import Event, detect_events
from .holdouts import held_out_thresholds, identified_thresholds
from .observe import calibrate_thresholds, carried_thresholds, observe, with_thresholds
from .observer import MomentumObserver, coriolis_transpose_qd, direct_residual, momentum_residual
from .report import ObserveResult

__all__ = ["MomentumObserver", "momentum_residual", "direct_residual", "coriolis_transpose_qd", "observe",
           "calibrate_thresholds", "carried_thresholds", "with_thresholds", "ObserveResult", "Event", "detect_events",
           "CollisionThresholds", "held_out_thresholds", "identified_thresholds"]
