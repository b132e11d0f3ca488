"""What :func:`manipdyn.observe` returns: residuals, thresholds and events, as text, JSON, CSV, figure, HTML.

Layer 6 (control: collision).
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass

import numpy as np

from .events import WRENCH_CONDITION

__all__ = ["ObserveResult"]


def _vec(x, fmt=".3g") -> str:
    return "[" + ", ".join(format(float(v), fmt) for v in x) + "]"


def _force_text(e) -> str:
    """An event's force as far as it is determined: the point force (a push at the tool's point, no moment),
    and the 6-D wrench only where the tool's Jacobian is well conditioned (events.WRENCH_CONDITION)."""
    if e.point_force is None:
        return ""
    f = e.point_force
    s = f"; force at the tool's point {_vec(f)} N (base frame, no moment assumed), |f| {np.linalg.norm(f):.3g} N"
    if e.wrench is None:
        return s
    w, u = e.wrench, e.wrench_uncertainty
    if e.wrench_determined:
        return s + (f"; tool wrench: force {_vec(w[:3])} N +- {_vec(u[:3], '.2g')}, moment {_vec(w[3:])} N m "
                    f"+- {_vec(u[3:], '.2g')} (cond(J) {e.condition:.3g})")
    return s + (f"; the 6-D tool wrench is not determined here (cond(J) {e.condition:.3g} > "
                f"{WRENCH_CONDITION:g}: force and moment trade off)")


@dataclass
class ObserveResult:
    """The answer of :func:`manipdyn.observe`.

    ``thresholds``: :class:`~manipdyn.identification.uncertainty.thresholds.CollisionThresholds`;
    ``runs``: per log ``(observed, residual, direct, events)``: the log (``t``, ``q``, ``qd``, ``tau``),
    the momentum observer's residual (N, n) N m, the direct residual (N, n) or None, and the
    :class:`~manipdyn.control.collision.events.Event` list; ``levels``: per log the thresholds in effect, (n,)
    or, where they grow with the leverage ratio (:mod:`~manipdyn.control.collision.extrapolation`), (N, n)
    per sample (None: the thresholds' own, every log).
    """

    arm: object
    thresholds: object
    runs: list
    levels: list | None = None

    def thresholds_of(self, run: int) -> np.ndarray:
        """The thresholds in effect on log ``run``, (N, n) N m, one row per sample."""
        T = np.asarray(self.thresholds.threshold if self.levels is None else self.levels[run], dtype=np.float64)
        return np.broadcast_to(T, (len(self.runs[run][0].t), self.thresholds.n))

    @property
    def events(self) -> list:
        """Every event of every log, in order."""
        return [e for run in self.runs for e in run[3]]

    @property
    def residuals(self) -> list:
        """The momentum observer's residual (N, n) of each log, N m."""
        return [run[1] for run in self.runs]

    def to_dict(self) -> dict:
        thr = self.thresholds
        return {"model": getattr(self.arm, "name", ""), "gain": thr.gain, "velocity_cutoff": thr.velocity_cutoff,
                "false_alarms_per_hour": thr.false_alarms_per_hour, "min_duration": thr.min_duration,
                "hysteresis": thr.hysteresis, "threshold": [float(x) for x in thr.threshold],
                "threshold_source": thr.source,
                **({} if thr.leverage_gain is None else {"leverage_gain": [float(x) for x in thr.leverage_gain]}),
                "logs": [{"log": obs.label, "samples": int(len(obs.t)), "duration": float(obs.t[-1] - obs.t[0]),
                          "rate": 1.0 / obs.dt,
                          "peak_residual": [float(x) for x in np.abs(r).max(axis=0)],
                          "threshold_range": [[float(a), float(b)] for a, b in
                                              zip(self.thresholds_of(i).min(axis=0), self.thresholds_of(i).max(axis=0))],
                          "peak_direct": None if d is None else [float(x) for x in np.abs(d).max(axis=0)],
                          "events": [e.to_dict() for e in ev], "notes": list(obs.notes)}
                         for i, (obs, r, d, ev) in enumerate(self.runs)]}

    def format(self) -> str:
        thr = self.thresholds
        vel = f", low-passed at {thr.velocity_cutoff:g} Hz" if thr.velocity_cutoff > 0 else ""
        lines = [f"collision thresholds, N m (momentum observer, gain {thr.gain:g} 1/s{vel}; {thr.false_alarms_per_hour:g} "
                 f"false events/h; events last >= {1e3 * thr.min_duration:g} ms; {thr.source}):",
                 "  " + "  ".join(f"j{j + 1} {x:.3g}" for j, x in enumerate(thr.threshold))]
        if thresholds_warning(thr):
            lines.append("warning: " + thresholds_warning(thr))
        if thr.leverage_gain is not None:
            lines.append("  each threshold x sqrt((1 + g u) / (1 + g)), u the sample's leverage ratio against the fit data (1 on a "
                         "typical fitted sample): g " + " ".join(f"j{j + 1} {x:g}" for j, x in enumerate(thr.leverage_gain)))
        for i, (obs, r, d, ev) in enumerate(self.runs):
            T = self.thresholds_of(i)
            span = ("" if thr.leverage_gain is None else "; thresholds here (median, max), N m: " + " ".join(
                f"{a:.3g}/{b:.3g}" for a, b in zip(np.median(T, axis=0), T.max(axis=0))))
            lines.append(f"{obs.label}: {len(obs.t)} samples, {obs.t[-1] - obs.t[0]:.3g} s at {1 / obs.dt:.4g} Hz; "
                         f"peak |r| / threshold " + " ".join(f"{x:.2f}" for x in (np.abs(r) / T).max(axis=0))
                         + f"{span}; {len(ev)} event(s)")
            for k, e in enumerate(ev):
                s = (f"  event {k + 1}: {e.onset:.4f} to {e.end:.4f} s (detected {e.detected:.4f} s), peak at "
                     f"{e.peak_time:.4f} s, {e.peak_ratio:.2f} x threshold; joints "
                     f"{','.join(map(str, e.joints))}; last link touched <= {e.link}")
                lines.append(s + _force_text(e))
        return "\n".join(lines)

    def write_predictions(self, path) -> None:
        """CSV per sample: ``log, t, r1..rn`` (momentum residual), ``d1..dn`` (direct, empty without qdd),
        ``T1..Tn`` (thresholds), ``event`` (1 inside an event), written atomically."""
        from ..._support.files import atomic_write_text

        n = self.thresholds.n
        buf = io.StringIO()
        buf.write(",".join(["log", "t"] + [f"r{j + 1}" for j in range(n)] + [f"d{j + 1}" for j in range(n)]
                           + [f"T{j + 1}" for j in range(n)] + ["event"]) + "\n")
        for i, (obs, r, d, ev) in enumerate(self.runs):
            Ts = self.thresholds_of(i)
            inside = np.zeros(len(obs.t), dtype=int)
            for e in ev:
                inside[e.samples[0]:e.samples[1]] = 1
            label = obs.label.replace(",", "_")
            for k in range(len(obs.t)):
                dd = ",".join(repr(float(x)) for x in d[k]) if d is not None else "," * (n - 1)
                T = ",".join(repr(float(x)) for x in Ts[k])
                buf.write(f"{label},{float(obs.t[k])!r},{','.join(repr(float(x)) for x in r[k])},{dd},{T},{inside[k]}\n")
        atomic_write_text(os.fspath(path), buf.getvalue())

    def figure(self, run: int = 0):
        """A matplotlib figure: per joint the residual (and the direct one, light) against +-threshold, the
        events shaded."""
        from ..._support.figures import pyplot

        plt = pyplot()
        obs, r, d, ev = self.runs[run]
        n, T = self.thresholds.n, self.thresholds_of(run)
        fig, axes = plt.subplots(n, 1, figsize=(9, 1.3 * n + 1), sharex=True, squeeze=False)
        for j in range(n):
            ax = axes[j, 0]
            if d is not None:
                ax.plot(obs.t, d[:, j], color="0.75", lw=0.5, label="direct")
            ax.plot(obs.t, r[:, j], color="C0", lw=0.8, label="momentum observer")
            ax.plot(obs.t, T[:, j], color="C3", lw=0.8, ls="--")
            ax.plot(obs.t, -T[:, j], color="C3", lw=0.8, ls="--", label="threshold")
            for e in ev:
                ax.axvspan(e.onset, e.end, color="C1", alpha=0.25, lw=0)
            ax.set_ylabel(f"j{j + 1}, N m", fontsize=8)
            lim = 1.6 * max(float(np.median(T[:, j])), float(np.max(np.abs(r[:, j]))))
            ax.set_ylim(-lim, lim)
        axes[0, 0].legend(loc="upper right", fontsize=7, ncol=3)
        axes[-1, 0].set_xlabel("t, s")
        fig.suptitle(f"{obs.label}: residual against thresholds ({self.thresholds.false_alarms_per_hour:g} false "
                     f"events/h), {len(ev)} event(s) shaded", fontsize=9)
        fig.tight_layout()
        return fig

    def plot(self, path) -> None:
        """:meth:`figure` of the first log, saved to ``path`` (PNG) atomically."""
        from ..._support.figures import save_figure

        fig = self.figure(0)
        save_figure(fig, os.fspath(path))
        import matplotlib.pyplot as plt

        plt.close(fig)

    def report_html(self, path, command: str = "") -> None:
        """One self-contained HTML page: what was done, thresholds, events, the figure per log."""
        from ..._support import html as H

        thr = self.thresholds
        n = thr.n
        low = (f"its residual low-passed at {thr.velocity_cutoff:g} Hz (the thresholds' own cut-off)"
               if thr.velocity_cutoff > 0 else "no low-pass on its residual (velocity cut-off 0)")
        parts = [H.facts([("command", command or "md.observe"), ("model", getattr(self.arm, "name", "")),
                          ("observer", f"generalized momentum, gain {thr.gain:g} 1/s, {low}"),
                          ("thresholds from", thr.source),
                          ("false events per hour asked", f"{thr.false_alarms_per_hour:g}"),
                          ("an event", f"a crossing lasting >= {1e3 * thr.min_duration:g} ms; ends below "
                                       f"{thr.hysteresis:g} x threshold")])]
        warn = thresholds_warning(thr)
        if warn:
            parts.append(H.verdict(warn, "warn"))
        total = len(self.events)
        parts.append(H.verdict(f"{total} event(s) in {len(self.runs)} log(s)", "ok" if total == 0 else "warn"))
        given = getattr(thr, "given", False)
        g = thr.leverage_gain
        parts.append(H.section("Thresholds", H.table(
            ["joint", "threshold, N m"] + ([] if given else ["highest level seen in calibration, N m"])
            + ([] if g is None else ["leverage gain g (threshold x sqrt((1 + g u) / (1 + g)))"]),
            [[f"j{j + 1}", float(thr.threshold[j])] + ([] if given else [float(thr.observed_max[j])])
             + ([] if g is None else [float(g[j])]) for j in range(n)], name="thresholds"),
            H.paragraph("The highest level seen: the largest residual, sustained over the event's minimum "
                        "duration, that the collision-free calibration data reached on the joint; a threshold "
                        "is never below it.") if not given else H.paragraph("Thresholds given as numbers.")))
        for i, (obs, r, d, ev) in enumerate(self.runs):
            rows = []
            for k, e in enumerate(ev):
                f = e.point_force
                rows.append([k + 1, e.onset, e.detected, e.end, e.peak_ratio, ",".join(map(str, e.joints)),
                             f"<= {e.link}", "" if f is None else _vec(f), "" if f is None else float(np.linalg.norm(f)),
                             "" if e.wrench is None else (f"{_vec(e.wrench[:3])} N, {_vec(e.wrench[3:])} N m"
                                                          if e.wrench_determined else "not determined"),
                             "" if e.condition is None else float(e.condition)])
            blocks = [H.table(["event", "onset, s", "detected, s", "end, s", "peak / threshold", "joints",
                               "last link touched", "force at the tool's point (base), N", "|f|, N",
                               "6-D tool wrench", "cond(J)"], rows, name=f"events-{i + 1}")
                      if rows else H.paragraph("no events")]
            if rows:
                blocks.append(H.paragraph("Last link touched: a force on link k moves joints 1..k only, so the link is "
                                          "at most the last joint crossing. The point force assumes a push at the "
                                          f"tool's point; the 6-D wrench is given where cond(J) <= {WRENCH_CONDITION:g}."))
            try:
                blocks.append(H.figure(self.figure(i), alt=f"residuals of {obs.label} against thresholds"))
            except Exception as exc:          # no matplotlib: the page without the figure, said so
                blocks.append(H.paragraph(f"figure not drawn: {exc}"))
            if obs.notes:
                blocks.append(H.bullets(obs.notes))
            parts.append(H.section(f"{obs.label}", *blocks))
        H.write_page(path, H.page("Collision detection", f"{getattr(self.arm, 'name', '')}: manipdyn observe",
                                  parts, generator=f"manipdyn {H.version()}"))


def thresholds_warning(thr) -> str:
    """A warning when the thresholds were read off one trajectory only (its blocks, or one calibration log):
    the model's error on another motion may be larger than what one motion showed; else ''."""
    src = str(thr.source or "")
    if "blocked hold-outs" in src and "held-out trajectories" not in src:
        return ("thresholds from one trajectory (blocks of the fit data): on other motions the model's error may be "
                "larger; calibrate on a collision-free log of another motion (--calibrate) to check")
    if src.startswith("calibration logs ") and "," not in src:
        return ("thresholds from one calibration log: on other motions the model's error may be larger; "
                "calibrate on several collision-free motions to check")
    return ""
