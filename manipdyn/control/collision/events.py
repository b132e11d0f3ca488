"""Collision events in a residual: detection, isolation and the wrench at the tool.

Layer 6 (control: collision).

In the terms of Haddadin, De Luca and Albu-Schaeffer's survey ("Robot Collisions", IEEE T-RO 2017):

* **detection**: an event starts (``detected``) when some joint's ``|r_j| > T_j`` has lasted
  ``min_duration``; its ``onset`` is when that crossing began; it ends when every joint is
  below ``hysteresis * T_j`` (:mod:`manipdyn.identification.uncertainty.thresholds`);
* **isolation**: a force on link k gives torques on joints 1..k only, so the last joint whose
  residual crosses names the last link that can be touched (``link``, 1..n; a force whose line
  passes through joint k's axis gives it no torque, so the true link may lie beyond);
* **identification**: for a contact at the tool, the wrench ``f = pinv(J^T) r`` with ``J`` the
  tool's Jacobian in world axes at the tool's origin (``arm.jacobian(q)``): force (N) and moment
  (N m) in the base frame, one wrench held over the event's samples whose largest ``|r_j| / T_j`` is
  at least :data:`PLATEAU` of its peak (after the observer's rise), the least-squares solution of
  ``J_k^T w = r_k`` over all of them together, each ``J_k`` at the pose the residual trails by
  (``lag``: the observer's ``1/K``, plus its low-pass's ``1/(2 pi f_c)``).  On the benchmark's 20
  contacts a mean of per-sample ``pinv(J_k^T) r_k`` at the sample's own pose left the UR5's 6-D
  wrench up to 36.7 % off (samples near a singular pose dominated); the lag alone brought it to
  19.9 %, the least squares to 6.3 %.  Its uncertainty per component is
  ``sum_j |pinv(J^T)_ij| T_j`` at the peak's pose: what a residual error as large as the thresholds
  (the model's error on collision-free data) can make of the wrench.  A 6-joint arm's ``J^T`` is
  square; a 7-joint arm's least-squares wrench ignores the part of ``r`` no tool wrench explains.
  Near a singular pose the wrench's force and moment trade off (its uncertainty says so); a push at
  the tool's point carries no moment, and ``point_force``, ``pinv(J_v^T) r`` with the Jacobian's
  three linear rows (the mean over the plateau of each sample's), is the force under that assumption,
  well conditioned wherever the tool can move in three directions.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...identification.uncertainty.thresholds import sustained

__all__ = ["Event", "detect_events", "PLATEAU", "WRENCH_CONDITION"]

#: the wrench is averaged where the residual is at least this fraction of the event's peak
PLATEAU = 0.8
#: above this condition number of the tool's Jacobian at the peak, the 6-D wrench is not determined (force and
#: moment trade off): the text gives the point force alone and says so.  On the guide's UR5 push cond(J) was
#: 450 and the wrench's force (-58.1, -5.78, -20.4) N against a true (0, 0, -30) N, the point force -28.3 N;
#: on 2,000 random postures (q in [-2, 2] rad) the median cond(J) is 20 (UR5) and 19 (Panda), the 90th percentile 138 and 118
WRENCH_CONDITION = 50.0


@dataclass
class Event:
    """One collision event (module docstring).  Times in s of the log; ``peak_residual`` (n,) N m;
    ``joints`` crossing (1-based); ``link`` the last link touched (1-based); ``wrench`` (6,)
    ``[f (N); m (N m)]`` in the base frame at the tool and ``wrench_uncertainty`` (6,), or None;
    ``point_force`` (3,) N, base frame: the force of a push at the tool's point (no moment), or None."""

    onset: float
    detected: float
    end: float
    peak_time: float
    peak_residual: np.ndarray
    peak_ratio: float
    joints: list
    link: int
    wrench: np.ndarray | None = None
    wrench_uncertainty: np.ndarray | None = None
    point_force: np.ndarray | None = None
    condition: float | None = None
    samples: tuple = field(default=(0, 0), repr=False)

    @property
    def wrench_determined(self) -> bool:
        """Whether the 6-D ``wrench`` is determined: the tool's Jacobian at the peak has a condition number
        at most :data:`WRENCH_CONDITION` (else only ``point_force`` is to be read)."""
        return self.wrench is not None and self.condition is not None and self.condition <= WRENCH_CONDITION

    def to_dict(self) -> dict:
        out = {"onset": self.onset, "detected": self.detected, "end": self.end, "peak_time": self.peak_time,
               "peak_residual": [float(x) for x in self.peak_residual],
               # a threshold so small that the ratio overflows: null (JSON has no infinity)
               "peak_ratio": self.peak_ratio if np.isfinite(self.peak_ratio) else None,
               "joints": list(self.joints), "link": self.link}
        if self.wrench is not None:
            out["force"] = [float(x) for x in self.wrench[:3]]
            out["moment"] = [float(x) for x in self.wrench[3:]]
            out["force_uncertainty"] = [float(x) for x in self.wrench_uncertainty[:3]]
            out["moment_uncertainty"] = [float(x) for x in self.wrench_uncertainty[3:]]
            out["jacobian_condition"] = float(self.condition) if np.isfinite(self.condition) else None
            out["wrench_determined"] = self.wrench_determined
        if self.point_force is not None:
            out["point_force"] = [float(x) for x in self.point_force]
        return out


def _spans(t, r, T, min_duration, hysteresis):
    """``(onset, detected, end)`` sample indices of each event (end exclusive)."""
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    s = sustained(r, dt, min_duration)
    trig = np.any(s > T, axis=1)
    low = np.all(np.abs(r) < hysteresis * T, axis=1)
    above = np.abs(r) > T
    m = max(1, int(min(np.ceil(min(float(min_duration) / dt, 1e15) - 1e-9), len(t))))
    spans, k, N = [], 0, len(t)
    trig_idx, low_idx = np.flatnonzero(trig), np.flatnonzero(low)
    while True:
        i = np.searchsorted(trig_idx, k)
        if i >= len(trig_idx):
            break
        det = int(trig_idx[i])
        onset = max(0, det - m + 1)
        while onset > 0 and np.any(above[onset - 1] & above[det]):      # the crossing began earlier
            onset -= 1
        e = np.searchsorted(low_idx, det)
        end = int(low_idx[e]) if e < len(low_idx) else N
        spans.append((onset, det, end))
        k = end
    return spans


def detect_events(arm, t, q, r, T, min_duration: float, hysteresis: float, wrench: bool = True,
                  lag: float = 0.0) -> list[Event]:
    """The :class:`Event` list of residual ``r`` (N, n) against thresholds ``T`` (n,) or per sample (N, n), N m, at times ``t``
    (N,) s and positions ``q`` (N, n); ``wrench``: estimate the tool wrench (needs ``n >= 6``).  ``lag``, s:
    how far the residual trails the external torque (the observer's ``1/K``, plus ``1/(2 pi f_c)`` with its
    low-pass): each residual sample is mapped through the Jacobian of the pose ``lag`` earlier, where the
    torque it follows was exerted (near a singular pose a Jacobian a few ms off moves a 6-D wrench far)."""
    t, r, T = np.asarray(t, dtype=np.float64), np.asarray(r, dtype=np.float64), np.asarray(T, dtype=np.float64)
    shift = int(round(float(lag) / float(np.median(np.diff(t))))) if len(t) > 1 and lag > 0 else 0
    T_at = (lambda a, b: T[a:b]) if T.ndim == 2 else (lambda a, b: T)     # per sample (N, n), or per joint (n,)
    out = []
    for onset, det, end in _spans(t, r, T, min_duration, hysteresis):
        seg = np.abs(r[onset:end]) / T_at(onset, end)
        ratio = seg.max(axis=1)
        kp = onset + int(np.argmax(ratio))
        joints = [int(j) + 1 for j in np.flatnonzero(np.any(seg > 1.0, axis=0))]
        ev = Event(onset=float(t[onset]), detected=float(t[det]), end=float(t[min(end, len(t) - 1)]),
                   peak_time=float(t[kp]), peak_residual=r[kp].copy(), peak_ratio=float(ratio.max()),
                   joints=joints, link=max(joints) if joints else 0, samples=(onset, end))
        if wrench and arm.n >= 6:
            plateau = onset + np.flatnonzero(ratio >= PLATEAU * ratio.max())
            J = arm.jacobian(q[np.maximum(plateau - shift, 0)])          # (k, 6, n), world axes at the tool
            # one wrench held over the plateau, least squares over all its samples (sum_k J_k J_k^T w =
            # sum_k J_k r_k): a sample at a near-singular pose weighs as little as it tells, where the mean
            # of per-sample pinv(J^T) r let such samples dominate.  Unweighted: the error that matters
            # here is the residual's lag behind the push, which scales with the signal, not with a joint's
            # threshold (weighing by 1/T raised the Panda's error from 3.7 to 11.9 % on the benchmark)
            Jt = np.concatenate(np.swapaxes(J, 1, 2))                       # (k n, 6): the J_k^T stacked
            ev.wrench = np.linalg.lstsq(Jt, r[plateau].reshape(-1), rcond=None)[0]
            Pp = np.linalg.pinv(J[np.searchsorted(plateau, kp)].T)      # the peak is on the plateau
            ev.wrench_uncertainty = np.abs(Pp) @ (T[kp] if T.ndim == 2 else T)
            ev.condition = float(np.linalg.cond(J[np.searchsorted(plateau, kp)]))
            # a force alone, no moment: well conditioned at every sample (the tool moves in three
            # directions), so the mean of the per-sample estimates, each sample weighed alike (the stacked
            # least squares weighs the samples by |J|^2: 10.1 against 5.5 % on the UR5 push of
            # tests/test_collision.py, 3.6 against 2.2 % on the benchmark's Panda)
            Pf = np.linalg.pinv(np.swapaxes(J[:, :3, :], 1, 2))
            ev.point_force = np.mean(np.einsum("kij,kj->ki", Pf, r[plateau]), axis=0)
        out.append(ev)
    return out
