"""Many runs of one controller stepped together: :func:`manipdyn.simulate`'s arithmetic, batched.

Layer 6 (control: montecarlo).

A chunk of a study simulates the same path with the same controller on K
plants.  :func:`simulate_lockstep` steps them together: each run's controller
and forward dynamics are called exactly as :func:`manipdyn.simulate` calls
them (``controller.step`` with the precomputed reference, the plant's
unchecked ABA, the checked ``controller(t, q, qd)`` for the last sample), and
the Runge-Kutta arithmetic is done once for all K runs on ``(K, n)`` arrays,
and so are the plants' friction torques and the control laws of PD, PD +
gravity and computed torque (the formulas of their ``step`` and of the
unchecked calls, term by term, in the same order; the model calls stay one
per run).
Elementwise IEEE arithmetic does not depend on the shape of the array it runs
on, so every run's log is bit for bit the one ``md.simulate`` returns when the
run is replayed alone (tests/test_montecarlo.py replays them).

Divergence is decided as ``md.simulate`` decides it: a torque that is not
finite ends a run at that step; a state with a non-finite entry or an entry
beyond the bounds ends it at the next one.  A run that ended keeps its log up
to then and is no longer stepped.
"""

from __future__ import annotations

import copy

import numpy as np
import pinocchio as pin

from ..controllers import PD, ComputedTorque, PDGravity
from ..simulate import DEFAULT_MAX_POSITION, DEFAULT_MAX_VELOCITY, SimulationLog

__all__ = ["simulate_lockstep"]


def simulate_lockstep(setups, max_position: float = DEFAULT_MAX_POSITION,
                      max_velocity: float = DEFAULT_MAX_VELOCITY) -> list:
    """Simulate the runs ``setups`` (:class:`RunSetup`, one path, duration and dt) together.

    Controllers may be shared between setups when they keep no state
    (:meth:`Controller.step` of PD, PD + gravity and computed torque); a
    controller that does (the adaptive one) is copied per run and reset.
    Runs step together when they take the same number of Runge-Kutta steps per
    period (``RunSetup.substeps``, their own plant's: :mod:`manipdyn.control.stiffness`),
    so a run's arithmetic never depends on the others in its chunk.
    Returns ``[(log, diverged), ...]`` in the order of ``setups``, each log a
    :class:`SimulationLog` cut where the run ended.
    """
    groups = {}
    for i, s in enumerate(setups):
        groups.setdefault(int(getattr(s, "substeps", 1)), []).append(i)
    out = [None] * len(setups)
    for m, idx in groups.items():
        for i, r in zip(idx, _lockstep([setups[i] for i in idx], m, max_position, max_velocity)):
            out[i] = r
    return out


def _lockstep(setups, m, max_position, max_velocity) -> list:
    """:func:`simulate_lockstep` for runs that all take ``m`` Runge-Kutta steps per period."""
    first = setups[0]
    path, dt, duration = first.trajectory, first.dt, first.duration
    K, n = len(setups), first.arm.n
    N = max(1, int(round(duration / dt)))
    t = np.arange(N + 1) * dt
    q_d, qd_d, qdd_d = (np.asarray(r, dtype=np.float64) for r in path(t))
    r0, r1, r2 = list(q_d), list(qd_d), list(qdd_d)
    ctrls = []
    for s in setups:
        c = s.controller
        inner = getattr(c, "inner", None)        # a TorqueNoise wrapper
        if inner is not None and hasattr(inner, "pi_hat"):
            c = copy.copy(c)
            c.inner = copy.copy(inner)            # an adaptive estimate of its own per run
        elif hasattr(c, "pi_hat"):
            c = copy.copy(c)
        c.reset(path)
        ctrls.append(c)
    steps = [c.step for c in ctrls]
    law = _batched_law(ctrls)
    engines = [s.plant.pinocchio for s in setups]
    models, datas = [e.model for e in engines], [e.data for e in engines]
    has_fr = [e.friction is not None for e in engines]
    FV = np.array([e.friction[0] if e.friction is not None else np.zeros(n) for e in engines])
    FC = np.array([e.friction[1] if e.friction is not None else np.zeros(n) for e in engines])
    aba, sign = pin.aba, np.sign

    q = np.array([np.array(s.q0, dtype=np.float64) for s in setups])
    qd = np.tile(qd_d[0], (K, 1))
    Q, V, TAU = np.empty((K, N + 1, n)), np.empty((K, N + 1, n)), np.empty((K, N + 1, n))
    T, X, V2, V3, V4, A1, A2, A3, A4, S, W, TE, F = (np.empty((K, n)) for _ in range(13))
    # per-run row views of the buffers, for the per-run Pinocchio calls
    qr, qdr, Tr, Xr, V2r, V3r, V4r, TEr = (list(buf) for buf in (q, qd, T, X, V2, V3, V4, TE))
    # the torque each plant's ABA receives: tau - (Fv v + Fc sign(v)) with friction
    # (PinocchioEngine.unchecked.forward_dynamics), tau itself without
    tin = [TEr[i] if has_fr[i] else Tr[i] for i in range(K)]
    any_fr = any(has_fr)
    add, mul = np.add, np.multiply

    def less_friction(vel):
        if any_fr:
            np.subtract(T, add(mul(FV, vel, out=F), mul(FC, sign(vel), out=TE), out=F), out=TE)

    stop = [N + 1] * K                         # samples kept per run
    active = list(range(K))
    h = dt / m                                 # as md.simulate: m == 1 gives exactly dt
    h2, h6 = 0.5 * h, h / 6.0

    def end(i, k):
        # the run's log stops at sample k; its rows are zeroed so that stepping
        # them along with the others stays finite (and costs no check)
        stop[i] = k
        active.remove(i)
        for buf in (q, qd, T, A1, A2, A3, A4):
            buf[i] = 0.0

    def state_ok():
        return (np.isfinite(q).all() and np.isfinite(qd).all()
                and np.abs(q).max() <= max_position and np.abs(qd).max() <= max_velocity)

    def stage(c, a_prev, v_prev, v_out, v_rows, a_out):
        # one Runge-Kutta stage: v = qd + c a_prev, evaluated at q + c v_prev
        add(qd, mul(c, a_prev, out=W), out=v_out)
        add(q, mul(c, v_prev, out=W), out=X)
        less_friction(v_out)
        for i in active:
            a_out[i] = aba(models[i], datas[i], Xr[i], v_rows[i], tin[i])

    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(N):
            if not active:
                break
            Q[:, k] = q
            V[:, k] = qd
            tk, a, b, c = k * dt, r0[k], r1[k], r2[k]
            if law is not None:
                law(T, k, tk, q, qd, qr, qdr, a, b, c, active)
            else:
                for i in active:
                    T[i] = steps[i](tk, qr[i], qdr[i], a, b, c)
            if not np.isfinite(T).all():
                for i in [i for i in active if not np.isfinite(T[i]).all()]:
                    end(i, k)
            TAU[:, k] = T
            for _ in range(m):                             # T held over the whole period
                less_friction(qd)
                for i in active:
                    A1[i] = aba(models[i], datas[i], qr[i], qdr[i], tin[i])
                stage(h2, A1, qd, V2, V2r, A2)             # v2 = qd + h2 a1 at q + h2 qd
                stage(h2, A2, V2, V3, V3r, A3)             # v3 = qd + h2 a2 at q + h2 v2
                stage(h, A3, V3, V4, V4r, A4)              # v4 = qd + h a3  at q + h v3
                # q + h6 (qd + 2 (v2 + v3) + v4), and qd + h6 (a1 + 2 (a2 + a3) + a4), in that order
                add(add(qd, mul(2.0, add(V2, V3, out=S), out=S), out=S), V4, out=S)
                add(add(A1, mul(2.0, add(A2, A3, out=W), out=W), out=W), A4, out=W)
                add(q, mul(h6, S, out=S), out=q)
                add(qd, mul(h6, W, out=W), out=qd)
            if not state_ok():
                for i in [i for i in active if not (np.isfinite(qr[i]).all() and np.isfinite(qdr[i]).all()
                                                     and np.all(np.abs(qr[i]) <= max_position)
                                                     and np.all(np.abs(qdr[i]) <= max_velocity))]:
                    end(i, k + 1)
        Q[:, N] = q
        V[:, N] = qd
        for i in list(active):
            tau = np.asarray(ctrls[i](N * dt, qr[i], qdr[i]), dtype=np.float64)
            TAU[i, N] = tau
            if not np.isfinite(tau).all():
                end(i, N)
    out = []
    for i, s in enumerate(setups):
        k = stop[i]
        log = SimulationLog(t[:k], Q[i, :k], V[i, :k], q_d[:k], qd_d[:k], qdd_d[:k], TAU[i, :k], dt,
                            ctrls[i].name, s.plant.name, tuple(s.plant.joint_types), substeps=m)
        out.append((log, k <= N))
    return out


def _batched_law(ctrls):
    """``law(T, k, t, q, qd, q_rows, qd_rows, q_d, qd_d, qdd_d, active)`` filling T (K, n), or None.

    For PD, PD + gravity and computed torque shared by every run (the study's
    controllers), optionally inside :class:`TorqueNoise`: their ``step``
    formulas on all runs at once.  Anything else (the adaptive controller,
    which keeps a state per run, and the LQR, shared but stepped alone: its
    gains are read, never written) returns None: one ``step`` per run.
    """
    inners = [getattr(c, "inner", c) for c in ctrls]
    inner = inners[0]
    if type(inner) not in (PD, PDGravity, ComputedTorque) or any(x is not inner for x in inners):
        return None
    noisy = [getattr(c, "inner", None) is not None for c in ctrls]
    if any(noisy) and not all(noisy):
        return None
    noise = np.stack([c.noise for c in ctrls]) if noisy[0] else None     # (K, N+1, n)
    dt = ctrls[0].dt if noisy[0] else None
    kp, kd, lim = inner.kp, inner.kd, inner.tau_max
    kind = type(inner)
    unchecked = inner.arm.pinocchio.unchecked
    model_call = unchecked.gravity_torque if kind is PDGravity else unchecked.inverse_dynamics

    def law(T, k, t, q, qd, qr, qdr, q_d, qd_d, qdd_d, active):
        if kind is ComputedTorque:
            v = qdd_d + kd * (qd_d - qd) + kp * (q_d - q)
            for i in active:
                T[i] = model_call(qr[i], qdr[i], v[i])
        elif kind is PDGravity:
            pd = kp * (q_d - q) + kd * (qd_d - qd)
            for i in active:
                T[i] = pd[i] + model_call(qr[i])
        else:
            T[...] = kp * (q_d - q) + kd * (qd_d - qd)
        if lim is not None:
            np.minimum(np.maximum(T, -lim), lim, out=T)
        if noise is not None:
            T += noise[:, min(int(round(t / dt)), noise.shape[1] - 1)]

    return law
