"""How well a model predicts motion: the arm simulated forward from states of a real log.

Layer 6 (control).  ``md.replay(models, logs, horizons=(0.01, 0.05, 0.2))`` and
``manipdyn replay MODEL... LOG``.

From the log's state ``(q_k, qd_k)`` at every ``every``-th sample, each model's forward dynamics
are integrated over the horizon ``H`` with the logged torque, and the simulated ``q`` and ``qd``
at ``t_k + H`` are compared with the log's: the multi-step prediction error that
simulation-based identification minimizes, where ``validate`` scores the one-step torque.

The replay.  The log is read as ``validate`` reads it (:func:`manipdyn.identification.read_log`:
resampled to a uniform grid, zero-phase filtered, ``qd`` filtered or measured).  Between two log
samples ``j`` and ``j + 1`` the torque is held at the mean of the two samples (the interval's
mean for a torque linear in time), over the ``m`` Runge-Kutta steps of the interval: both
simulators receive the same torque, whatever ``m``.  ``m`` is what the model needs along the log
(:func:`manipdyn.control.stiffness.rk4_substeps`: a smoothed Coulomb sign on a light wrist is
stiff).  ``simulator="manipdyn"``: classical RK4 on the model's forward dynamics (Pinocchio's
ABA, friction included), all start states stepped together as one batch;
``simulator="mujoco"``: MuJoCo's RK4 on the model's MJCF, the torque as ``qfrc_applied`` (no
actuator range clamps it), with ``mujoco_plant="model"`` (default) the plant manipdyn simulates
(constraints off, the whole friction law at every stage, :mod:`manipdyn.control.mjsim`) or
``"file"`` the MJCF as MuJoCo loads it.  The two simulators differ by how each evaluates the
dynamics, within RK4's own error at this step (tests/test_replay.py).

The scores.  Per model, horizon and joint: the RMS over the start states of ``q_sim - q_log``
(rad, m) and of ``qd_sim - qd_log`` (rad/s, m/s); "pooled": the RMS over joints too.  A start
state whose replay leaves the divergence bounds of :func:`manipdyn.simulate` (or goes non-finite)
is counted as diverged and left out of the RMS.  The row ``constant velocity`` is the guess
``q_k + H qd_k`` without any model: a model that does not beat it predicts nothing at that
horizon.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from .._support import limits
from .._support.errors import ModelError
from .._support.jsonsafe import finite_or_null
from .replay_page import BASELINE, figure, write_page
from .mjsim import MUJOCO_PLANTS, SIMULATORS
from .replay_run import plan, run_manipdyn, run_mujoco

__all__ = ["replay", "ReplayResult", "DEFAULT_HORIZONS", "DEFAULT_EVERY", "BASELINE"]

#: the horizons compared by default, s
DEFAULT_HORIZONS = (0.01, 0.05, 0.2)
#: a start state every this many log samples by default
DEFAULT_EVERY = 10


@dataclass
class ReplayResult:
    """What :func:`replay` returns.

    Attributes
    ----------
    labels : list of str
        The models, in the order given.
    horizons : tuple of float
        s, as asked.
    steps : tuple of int
        Log samples per horizon (the horizon actually simulated is ``steps * dt``).
    dt : float
        The log's sample period after reading, s.
    starts : int
        Start states replayed per model (pooled over the logs).
    q_rms, qd_rms : dict
        ``label -> (H, n)`` arrays: RMS over the start states of ``q_sim - q_log`` (rad or m) and
        ``qd_sim - qd_log`` (rad/s or m/s) at each horizon; also under :data:`BASELINE`.
    diverged : dict
        ``label -> (H,)`` start states whose replay diverged before each horizon.
    substeps : dict
        ``label -> m``, integrator steps per log sample.
    integrators : dict
        ``label -> "rk4" | "rosenbrock"``: who stepped the model (:mod:`manipdyn.control.implicit`:
        a model too stiff for RK4 gets the Rosenbrock step with its friction implicit).
    simulator, mujoco_plant : str
    joint_types : tuple of str
    notes : list of str
        What reading the logs did, and what the replay noticed.
    logs : list of str
    """

    labels: list
    horizons: tuple
    steps: tuple
    dt: float
    starts: int
    q_rms: dict
    qd_rms: dict
    diverged: dict
    substeps: dict
    simulator: str = "manipdyn"
    mujoco_plant: str = "model"
    joint_types: tuple = ()
    notes: list = field(default_factory=list)
    logs: list = field(default_factory=list)
    every: int = DEFAULT_EVERY
    integrators: dict = field(default_factory=dict)

    def pooled(self, label: str, what: str = "q") -> np.ndarray:
        """(H,): the RMS over joints of ``label``'s per-joint RMS (``what`` ``"q"`` or ``"qd"``)."""
        table = (self.q_rms if what == "q" else self.qd_rms)[label]
        return np.sqrt(np.mean(table**2, axis=1))

    def _units(self, what: str) -> str:
        prismatic = any(t == "prismatic" for t in self.joint_types)
        base = "rad" + (" or m" if prismatic else "")
        return base if what == "q" else base.replace("rad", "rad/s").replace(" m", " m/s")

    def table(self, what: str = "q") -> str:
        """Per horizon, one row per model (and the constant-velocity guess): the RMS error per
        joint and pooled; ``*`` marks the best model per joint (the guess is not ranked)."""
        data = self.q_rms if what == "q" else self.qd_rms
        n = len(self.joint_types)
        rows = []
        width = max(len(x) for x in [*self.labels, BASELINE]) + 2
        for h, (H, k) in enumerate(zip(self.horizons, self.steps)):
            unit = self._units(what)
            rows.append(f"{what} error at {H * 1e3:g} ms ({k} samples), RMS over {self.starts} starts, {unit}")
            rows.append(f"  {'model':<{width}}" + "".join(f"{'j' + str(j + 1):>11}" for j in range(n))
                        + f"{'pooled':>11}")
            best = [min(self.labels, key=lambda lab: data[lab][h, j]) if len(self.labels) > 1 else None
                    for j in range(n)]
            for lab in [*self.labels, BASELINE]:
                cells = "".join(f"{data[lab][h, j]:10.3e}" + ("*" if best[j] == lab else " ") for j in range(n))
                extra = ""
                if lab != BASELINE and self.diverged[lab][h]:
                    extra = f"  ({int(self.diverged[lab][h])} diverged, left out)"
                rows.append(f"  {lab:<{width}}{cells}{self.pooled(lab, what)[h]:10.3e}{extra}")
        return "\n".join(rows)

    def verdict(self, horizon: float = 0.05) -> str:
        """One sentence per model on its pooled ``q`` error at the horizon nearest ``horizon``,
        against the first model's and the constant-velocity guess's."""
        h = int(np.argmin([abs(H - horizon) for H in self.horizons]))
        H = self.horizons[h]
        base = self.pooled(BASELINE)[h]
        out = []
        first = self.labels[0]
        for lab in self.labels:
            e = self.pooled(lab)[h]
            s = f"{lab}: pooled q error at {H * 1e3:g} ms {e:.3g} {self._units('q')}"
            if lab != first:
                e0 = self.pooled(first)[h]
                s += f" ({'better than' if e < e0 else 'worse than' if e > e0 else 'equal to'} {first}'s {e0:.3g})"
            if e >= base:
                s += f"; no better than the constant-velocity guess ({base:.3g})"
            out.append(s)
        return "\n".join(out)

    def format(self) -> str:
        """The whole text report: what was replayed, the q and qd tables, the verdict, the notes."""
        who = ("MuJoCo on each model's MJCF (" + self.mujoco_plant + " plant)" if self.simulator == "mujoco"
               else "manipdyn (Pinocchio's ABA)")
        head = (f"replay of {', '.join(self.logs)}: {self.starts} start states (every {self.every} samples of "
                f"{self.dt * 1e3:.4g} ms), the logged torque, {who}; " + "; ".join(self.steppers()))
        notes = "".join(f"\n  note: {x}" for x in self.notes)
        return f"{head}\n{self.table('q')}\n{self.table('qd')}\n{self.verdict()}{notes}"

    __str__ = format

    def steppers(self) -> list:
        """Per model, ``"label: RK4, m steps per sample"`` (or the Rosenbrock step's phrase)."""
        from .implicit import describe

        out = []
        for lab, m in self.substeps.items():
            kind = self.integrators.get(lab, "rk4")
            if self.simulator == "mujoco" and kind == "rosenbrock":
                out.append(f"{lab}: MuJoCo's implicitfast (the friction's slope as damping), {m} steps per sample")
            else:
                out.append(f"{lab}: " + describe(kind, m, "sample"))
        return out

    def to_dict(self) -> dict:
        """JSON-ready: per model and horizon, the per-joint and pooled RMS errors."""
        def per(lab):
            return {f"{H:g}": {"q_rms": self.q_rms[lab][h].tolist(), "qd_rms": self.qd_rms[lab][h].tolist(),
                               "q_pooled": float(self.pooled(lab)[h]), "qd_pooled": float(self.pooled(lab, "qd")[h]),
                               **({} if lab == BASELINE else {"diverged": int(self.diverged[lab][h])})}
                    for h, H in enumerate(self.horizons)}
        return finite_or_null({"logs": list(self.logs), "simulator": self.simulator,
                **({"mujoco_plant": self.mujoco_plant} if self.simulator == "mujoco" else {}),
                "dt": self.dt, "every": self.every, "starts": self.starts, "horizons": list(self.horizons),
                "horizon_samples": list(self.steps), "substeps": dict(self.substeps),
                "integrators": {lab: self.integrators.get(lab, "rk4") for lab in self.labels},
                "models": {lab: per(lab) for lab in self.labels}, "baseline": {BASELINE: per(BASELINE)},
                "notes": list(self.notes)})

    def plot(self, path) -> None:
        """Draw the pooled and per-joint q error against the horizon, one line per model (needs
        matplotlib); written atomically to ``path``."""
        from .._support.figures import save_figure

        save_figure(self._figure(), os.fspath(path))

    def _figure(self):
        return figure(self)

    def report_html(self, path, command: str | None = None) -> str:
        """Write one self-contained HTML page to ``path`` (atomically): what was replayed, the
        verdict, the q and qd tables per horizon, the figure (:mod:`.replay_page`).  Returns the path."""
        return write_page(self, path, command)


def _load_model(spec, tip):
    """An arm (forward dynamics needed) and its label."""
    if not isinstance(spec, (str, os.PathLike)):
        if not hasattr(spec, "forward_dynamics") or not hasattr(spec, "n"):
            raise ModelError(f"models: expected arms or model files, got {type(spec).__name__}")
        return spec, getattr(spec, "name", None) or "model"
    s = os.fspath(spec)
    if s.lower().endswith(".json"):
        raise ModelError(f"{s}: a base model JSON holds base parameters, not an arm to simulate; give the "
                         "model file identify wrote beside it (-o X.toml)")
    from ..formats.loading import load_with_notes

    arm, _ = load_with_notes(s, tip=tip)
    return arm, arm.name or os.path.basename(s)


def _check_horizons(horizons) -> tuple:
    try:
        hs = tuple(float(h) for h in np.atleast_1d(np.asarray(horizons, dtype=np.float64)))
    except (TypeError, ValueError):
        raise ModelError(f"horizons: expected positive numbers of seconds, got {horizons!r:.60}") from None
    if not hs or not all(math.isfinite(h) and h > 0 for h in hs):
        raise ModelError(f"horizons: expected positive finite numbers of seconds, got {list(hs)}")
    return tuple(sorted(set(hs)))


def replay(models, logs, horizons=DEFAULT_HORIZONS, every: int = DEFAULT_EVERY, simulator: str = "manipdyn",
           mujoco_plant: str = "model", tip=None, substeps=None, integrator=None, **log_options) -> ReplayResult:
    """Simulate each model forward from states along real logs with the logged torque; score q and
    qd at each horizon against the log (module docstring).

    Parameters
    ----------
    models : arm, model file or bundled name, or a sequence of them
        Side by side, as ``validate`` puts them (the identified against the published).
    logs : path or sequence of paths
        Logs as :func:`manipdyn.identification.read_log` reads them (``t, q1..qn, tau1..taun``,
        optionally ``qd``); each is replayed on its own and the start states are pooled.
    horizons : sequence of float
        s; default 10, 50 and 200 ms.  Each is rounded to a whole number of log samples.
    every : int
        A start state every ``every`` log samples (the last ones only where the longest horizon
        still fits in the log).
    simulator : "manipdyn" | "mujoco"
    mujoco_plant : "model" | "file"
        With MuJoCo (module docstring).
    tip : str, optional
        The tip link of a tree URDF given as a model.
    substeps : int, optional
        Integrator steps per log sample; default what each model needs along the log.
    integrator : None | "rk4" | "rosenbrock"
        Default: RK4, or the Rosenbrock step (friction implicit) for a model too stiff for RK4
        (:func:`manipdyn.control.implicit.integration_plan`); given, insisted on.  In MuJoCo the
        Rosenbrock choice steps ``implicitfast`` with the friction's slope as damping.
    **log_options
        Passed to ``read_log`` (``t_range=(10, 21)``, ``columns``, ``deg``, ``rate``, ``cutoff``, ...).

    Returns
    -------
    ReplayResult
    """
    from ..formats.logs.read import model_joint_names, read_log

    if simulator not in SIMULATORS:
        raise ModelError(f"simulator: expected 'manipdyn' or 'mujoco', got {simulator!r:.40}")
    if mujoco_plant not in MUJOCO_PLANTS:
        raise ModelError(f"mujoco_plant: expected 'model' or 'file', got {mujoco_plant!r:.40}")
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ModelError(f"every: expected an integer >= 1 (log samples), got {every!r:.40}")
    if every > limits.MAX_DATA_BYTES:       # no log has more samples than bytes: one start state per log
        shown = f"{every}" if every < 10**30 else f"an integer of {len(str(every))} digits"
        raise ModelError(f"every: expected an integer from 1 to {limits.MAX_DATA_BYTES} (log samples; no log "
                         f"holds more), got {shown}")
    if substeps is not None and (isinstance(substeps, bool) or not isinstance(substeps, (int, np.integer))
                                 or substeps < 1):
        raise ModelError(f"substeps: expected an integer >= 1, got {substeps!r:.40}")
    if integrator is not None and integrator not in ("rk4", "rosenbrock"):
        raise ModelError(f"integrator: expected 'rk4' or 'rosenbrock', got {integrator!r:.40}")
    hs = _check_horizons(horizons)
    if isinstance(models, (str, os.PathLike)) or hasattr(models, "forward_dynamics"):
        models = [models]
    if isinstance(logs, (str, os.PathLike)):
        logs = [logs]
    arms = [_load_model(m, tip) for m in models]
    if not arms or not logs:
        raise ModelError("replay: give at least one model and one log")
    n = arms[0][0].n
    for arm, lab in arms:
        if arm.n != n or tuple(arm.joint_types) != tuple(arms[0][0].joint_types):
            raise ModelError(f"{lab}: has joints {list(arm.joint_types)}, {arms[0][1]} {list(arms[0][0].joint_types)}")
    labels = _unique([lab for _, lab in arms])
    if simulator == "mujoco":
        from ..engines.mujoco.deps import mujoco_module

        mujoco_module()
    datas, notes = [], []
    if log_options.get("joint_names") is None:          # a ROS bag maps its joints by the model's names
        names = model_joint_names(arms[0][0])
        log_options["joint_names"] = names if names is not None and len(names) == n else None
    for path in logs:
        m = read_log(path, n, transmission=getattr(arms[0][0], "transmission", None), **log_options)
        datas.append(m)
        notes += [f"{os.path.basename(os.fspath(path))}: {x}" for x in m.notes]
    notes[:0] = _fit_data_notes(arms, labels, logs, datas)     # first: what the figures are
    dts = [float(np.median(np.diff(m.t))) for m in datas]
    if max(dts) - min(dts) > 1e-9 * max(dts):
        raise ModelError(f"logs: read at different sample periods ({', '.join(f'{d:.6g}' for d in dts)} s); "
                         "give --resample HZ so that they share one")
    dt = dts[0]
    steps = tuple(max(1, int(round(h / dt))) for h in hs)
    kmax = steps[-1]
    if kmax >= max(len(m.t) for m in datas):
        raise ModelError(f"logs: shorter than the longest horizon ({hs[-1]:g} s = {kmax} samples) plus one; "
                         "give a shorter --horizon or a longer log")
    starts = [np.arange(0, len(m.t) - kmax, every) for m in datas]
    total = sum(len(s) for s in starts)
    if total == 0:
        raise ModelError(f"logs: shorter than the longest horizon ({hs[-1]:g} s = {kmax} samples) plus one; "
                         "give a shorter --horizon or a longer log")
    q_rms, qd_rms, div, subs, kinds = {}, {}, {}, {}, {}
    for (arm, _), lab in zip(arms, labels):
        if substeps is not None and integrator is not None:
            kind, m_sub = integrator, substeps                  # both given: no plan, no cap (a reference)
        else:
            kind, m_sub = plan(arm, datas, dt, integrator)
            m_sub = substeps if substeps is not None else m_sub
        subs[lab], kinds[lab] = int(m_sub), kind
    limits.check_count(total * kmax * sum(subs.values()), "replay", "the integration steps (start states x "
                       "samples to the longest horizon x substeps, the models together)", "MAX_REPLAY_STEPS")
    for (arm, _), lab in zip(arms, labels):
        m_sub, kind = subs[lab], kinds[lab]
        eq, eqd, bad = [], [], []
        for m, st in zip(datas, starts):
            if simulator == "mujoco":
                Q, V = run_mujoco(arm, m, st, steps, dt, m_sub, mujoco_plant, kind)
            else:
                Q, V = run_manipdyn(arm, m, st, steps, dt, m_sub, kind)
            idx = st[None, :] + np.array(steps)[:, None]          # (H, W)
            eq.append(Q - m.q[idx])
            eqd.append(V - m.qd[idx])
        eq, eqd = np.concatenate(eq, axis=1), np.concatenate(eqd, axis=1)     # (H, W, n)
        ok = np.isfinite(eq).all(axis=2) & np.isfinite(eqd).all(axis=2)
        div[lab] = (~ok).sum(axis=1)
        q_rms[lab] = np.array([_rms(eq[h][ok[h]]) for h in range(len(hs))])
        qd_rms[lab] = np.array([_rms(eqd[h][ok[h]]) for h in range(len(hs))])
    gq, gqd = [], []
    for m, st in zip(datas, starts):
        idx = st[None, :] + np.array(steps)[:, None]
        gq.append(m.q[st][None] + (np.array(steps) * dt)[:, None, None] * m.qd[st][None] - m.q[idx])
        gqd.append(m.qd[st][None] - m.qd[idx])
    gq, gqd = np.concatenate(gq, axis=1), np.concatenate(gqd, axis=1)
    q_rms[BASELINE] = np.array([_rms(x) for x in gq])
    qd_rms[BASELINE] = np.array([_rms(x) for x in gqd])
    for h, k in zip(hs, steps):
        if abs(k * dt - h) > 0.05 * h:
            notes.append(f"horizon {h:g} s is {k} samples of {dt:.6g} s = {k * dt:.6g} s")
    return ReplayResult(labels, hs, steps, dt, int(total), q_rms, qd_rms, div, subs, simulator, mujoco_plant,
                        tuple(arms[0][0].joint_types), notes, [os.fspath(p) for p in logs], int(every), kinds)


def _fit_data_notes(arms, labels, logs, datas) -> list:
    """One line per model replayed on a log it was fitted on (:func:`~manipdyn.identification.results.heldout.fit_data_note`)."""
    from ..identification.results.heldout import fit_data_note

    out = []
    for (arm, _), lab in zip(arms, labels):
        hits = [p for p, m in zip(logs, datas) if fit_data_note(arm, [p], (float(m.t[0]), float(m.t[-1])))]
        line = fit_data_note(arm, hits, None, lab, "its drift figures") if hits else None
        if line:
            out.append(line)
    return out


def _unique(labels):
    out = []
    for lab in labels:
        k, new = 2, lab
        while new in out or new == BASELINE:
            new, k = f"{lab} ({k})", k + 1
        out.append(new)
    return out


def _rms(x) -> np.ndarray:
    """Per-joint RMS over the rows of ``x`` (W, n); NaN where there are none."""
    if len(x) == 0:
        return np.full(x.shape[-1], np.nan)
    return np.sqrt(np.mean(x**2, axis=0))
