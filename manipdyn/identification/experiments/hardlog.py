"""Seeded hard logs with known truth: :func:`hard_log`.

Layer 5 (identification).

A log the way an industrial 6-axis arm writes it, from a model whose every
parameter is known, so that identification can be scored against the truth
(issue 17, item 7).  The arm is the bundled UR5's kinematics with

* **drives**: gear ratios :data:`GEAR_RATIOS` (joint 3's negative: its motor
  turns the other way), and a **coupled wrist**: motor 6 drives joint 6 and
  also joint 5 (``R[6, 5] =`` :data:`WRIST_COUPLING`, 1-based), so
  ``q_m6 = 81 q6 + 32 q5`` and the joint-space rotor inertia
  ``R^T diag(Jm) R`` has an off-diagonal (5, 6) entry;
* **rotor inertias** ``Jm`` and **torque constants** ``k_t`` per motor;
* **motor-side friction** with smoothing :data:`SMOOTHING` (rad/s at the
  motor): viscous, **asymmetric Coulomb** (separate + and - levels) and a
  **Stribeck** term with per-motor velocities, plus a constant **offset**
  torque per joint;
* the **truth** differs from the **prior** as a real arm differs from its
  data sheet: link masses scaled by U(0.8, 1.2), centres of mass moved by
  U(+-2 cm) per axis, rotor inertias by U(0.7, 1.3); the prior has no
  friction.  Both carry the same transmission (gear ratios, coupling, motor
  offsets, torque constants: what a data sheet gets right).

The motion is a random Fourier series (period = the log's duration, 10
harmonics, each joint's peak speed set to U(1, 1.5) rad/s), so the first
``duration - held_out`` seconds and the last ``held_out`` seconds visit
different states: identify on the first, validate on the rest.  It stops
:data:`RESTS` times, for :data:`REST` s each with :data:`RAMP` s ramps in
and out (a smooth time warp, :func:`_warp`): a real identification run
does, and it must, because a constant offset is a shift of both Coulomb
levels everywhere but at rest.  Without the standstills the offsets'
standard deviations were 5 to 15 % of their values (so were the wrist
rotor inertias'), and errors of up to 21 % were what those deviations
allow; with them the offsets' are 0.1 to 4.3 % on seeds 0 to 2 and the
identifiable rotor inertias' 0.7 to 8.3 % (motor 5's on seed 1, the widest).  The log is
sampled the way a host records it:

* time stamps ``k / rate`` jittered by U(+-30 %) of a step (the states are
  those at the stamped times);
* **dropped** samples: a few gaps of 2 to 8 samples, and single samples with
  probability 1 %;
* **duplicated** rows: with probability 2 % a row is logged again with a
  later stamp (half a step on);
* **encoder quantisation** at the motor: ``q_m`` rounded to
  ``2 pi / counts`` rad;
* **1 % noise** on the motor torques: standard deviation ``noise`` times each
  motor's peak torque over the log, then written as currents ``i = tau_m / k_t``.

The CSV has columns ``t, qm1..qm6, i1..i6`` (no velocities).  The joint
torque noise is ``sigma_j = sqrt(sum_k R_kj^2 s_k^2)`` (``s_k`` the motor
torque noise), reported in :attr:`HardLog.sigma`.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from dataclasses import dataclass

import numpy as np

from ..._support.files import atomic_write_text
from ...model.arm import Manipulator
from ...model.drive import Transmission
from ..._support.errors import ModelError, PhysicalConsistencyWarning
from ...model.friction import Friction
from ...formats.save import save
from ...formats.loading import load
from .trajectory import fourier_trajectory

__all__ = ["HardLog", "hard_log", "hard_log_set", "SET_PAYLOAD", "hard_arms", "recovered", "GEAR_RATIOS", "WRIST_COUPLING", "SMOOTHING"]

#: gear ratios of motors 1..6 (joint 3's motor turns the other way)
GEAR_RATIOS = (101.0, 101.0, -101.0, 81.0, 81.0, 81.0)
#: R[6, 5] (1-based): motor 6 turns with joint 5 too
WRIST_COUPLING = 32.0
#: smoothing v_s of the friction law's sign, rad/s at the motor (0.01 to 0.025 rad/s at the joints)
SMOOTHING = 2.0
#: standstills in the motion: how many, each one's length and its ramps in and out (s)
RESTS = 8
REST = 0.5
RAMP = 0.4
#: the truth's Stribeck exponent
STRIBECK_EXPONENT = 2.0


@dataclass(frozen=True)
class HardLog:
    """What :func:`hard_log` made.

    ``truth``, ``prior``: the arms (:class:`~manipdyn.Manipulator`); ``log``,
    ``truth_file``, ``prior_file``: the paths written (None without a directory);
    ``sigma`` (6,): joint torque noise, N m; ``motor_sigma`` (6,): motor torque
    noise, N m at the motor; ``split``: the time (s) from which the log is held
    out; ``t``, ``q``, ``qd``, ``qdd`` (N, 6): the true states at the logged rows
    (duplicates included); ``tau`` (N, 6): the logged joint torques
    ``R^T k_t i``; ``rows``: the CSV text's number of data rows.
    """

    truth: Manipulator
    prior: Manipulator
    log: str | None
    truth_file: str | None
    prior_file: str | None
    sigma: np.ndarray
    motor_sigma: np.ndarray
    split: float
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    rows: int


def hard_arms(seed: int = 0):
    """``(truth, prior)``: the arms of :func:`hard_log` (module docstring)."""
    rng = np.random.default_rng([int(seed), 17])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        base = load("ur5")
    n = base.n
    G = np.array(GEAR_RATIOS)
    Jm = rng.uniform(2e-5, 6e-5, n) * np.array([1, 1, 1, 0.3, 0.3, 0.3])    # kg m^2 at each motor
    kt = rng.uniform(0.08, 0.2, n)                                            # N m/A
    offset_m = rng.uniform(-3.0, 3.0, n)                                      # rad at the motor
    tr = Transmission.from_gear_ratios(G, coupling=[[6, 5, WRIST_COUPLING]], motor_offset=offset_m,
                                       torque_constant=kt)
    fc = rng.uniform(0.03, 0.06, n)                                           # N m at the motor
    law = Friction(viscous=rng.uniform(1.5e-4, 3e-4, n), coulomb_pos=fc, coulomb_neg=fc * rng.uniform(0.7, 0.9, n),
                   offset=rng.choice([-1.0, 1.0], n) * rng.uniform(0.5, 1.5, n),
                   stribeck_level=fc * rng.uniform(0.4, 0.8, n), stribeck_velocity=rng.uniform(5.0, 15.0, n),
                   stribeck_exponent=STRIBECK_EXPONENT, side="motor", smoothing=SMOOTHING)
    true_links, prior_links = [], []
    for i, link in enumerate(base.links):
        common = dict(gear_ratio=G[i], friction_viscous=0.0, friction_coulomb=0.0)
        prior_links.append(dataclasses.replace(link, motor_inertia=Jm[i] * rng.uniform(0.7, 1.3), **common))
        true_links.append(dataclasses.replace(link, mass=link.mass * rng.uniform(0.8, 1.2),
                                              com=link.com + rng.uniform(-0.02, 0.02, 3), motor_inertia=Jm[i],
                                              **common))
    kw = dict(convention=base.convention, gravity=base.gravity, transmission=tr, source=base.source)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        truth = Manipulator(true_links, name=f"ur5_hard{seed}_truth", friction=law,
                            description=f"the truth of manipdyn's hard log, seed {seed}", **kw)
        prior = Manipulator(prior_links, name=f"ur5_hard{seed}_prior",
                            description=f"the prior of manipdyn's hard log, seed {seed}", **kw)
    return truth, prior


def _motion(rng, n, duration, harmonics=10):
    """Fourier coefficients ``(q0, a, b, period)``, each joint's peak speed U(1, 1.5) rad/s."""
    l = np.arange(1, harmonics + 1)
    a = rng.standard_normal((n, harmonics)) / np.sqrt(l)
    b = rng.standard_normal((n, harmonics)) / np.sqrt(l)
    tg = np.linspace(0.0, duration, 4001)
    _, qd, _ = fourier_trajectory(tg, np.zeros(n), a, b, duration)
    s = rng.uniform(1.0, 1.5, n) / np.abs(qd).max(axis=0)
    q0 = rng.uniform(-1.0, 1.0, n)
    return q0, a * s[:, None], b * s[:, None], duration


def _warp(t, duration, rests=RESTS):
    """``(s, s', s'')`` at ``t``: the time warp that stops the motion ``rests`` times (module docstring).

    ``s' = 1 - sum_k w_k(t)``, each ``w_k`` 1 for :data:`REST` s around its centre and falling
    to 0 over :data:`RAMP` s on either side along ``1 - S(u)``, ``S`` the quintic smoothstep
    (so ``s''`` is continuous); ``s`` is its exact integral.
    """
    t = np.asarray(t, dtype=np.float64)
    half = 0.5 * REST
    s, sd, sdd = t.copy(), np.ones_like(t), np.zeros_like(t)

    def area(u):          # integral of 1 - S over [0, u], in units of RAMP
        return u - 2.5 * u**4 + 3.0 * u**5 - u**6

    for c in (np.arange(rests) + 0.5) * duration / rests:
        x = t - c
        u = np.clip((np.abs(x) - half) / RAMP, 0.0, 1.0)
        S = u**3 * (10.0 - 15.0 * u + 6.0 * u**2)
        dS = 30.0 * u**2 * (1.0 - u) ** 2 / RAMP * np.sign(x) * ((np.abs(x) > half) & (np.abs(x) < half + RAMP))
        sd -= 1.0 - S
        sdd += dS
        W = np.where(x < -half, 0.5 * RAMP - RAMP * area(u), 0.5 * RAMP + (x + half))   # left ramp, plateau
        W = np.where(x > half, 0.5 * RAMP + REST + RAMP * area(u), W)                   # right ramp, after
        s -= W
    return s, sd, sdd


def _stamps(rng, duration, rate):
    """Logged times and, per logged row, the index of the sample it repeats (module docstring)."""
    h = 1.0 / rate
    N = int(round(duration * rate))
    t = np.arange(N) * h + rng.uniform(-0.3, 0.3, N) * h
    t[0] = 0.0
    keep = rng.random(N) >= 0.01
    for start in rng.integers(10, N - 20, 4):
        keep[start:start + rng.integers(2, 9)] = False
    keep[[0, -1]] = True
    t = t[keep]
    dup = np.flatnonzero(rng.random(len(t)) < 0.02)
    dup = dup[dup < len(t) - 1]
    src = np.sort(np.concatenate([np.arange(len(t)), dup]))      # row -> sample index
    stamps = t[src].copy()
    again = np.r_[False, src[1:] == src[:-1]]
    stamps[again] += 0.5 * np.diff(t)[src[again]]                # the repeat: half a step later
    return t, src, stamps


def hard_log(seed: int = 0, directory=None, *, duration: float = 40.0, held_out: float = 10.0,
             rate: float = 1000.0, noise: float = 0.01, counts: int = 2**16, motion_seed: int | None = None,
             payload=None, log_name: str = "hard_log.csv") -> HardLog:
    """A seeded hard log with known truth (module docstring).

    Parameters
    ----------
    seed : int
        Seeds the arms, the motion, the time stamps and the noise.
    directory : path, optional
        Where to write ``hard_log.csv``, ``truth.toml`` and ``prior.toml``
        (atomically); nothing is written when None.
    duration, held_out : float
        Length of the log and of its held-out tail, s.
    rate : float
        Nominal sample rate, Hz.
    noise : float
        Motor torque noise, a fraction of each motor's peak torque.
    counts : int
        Encoder counts per motor revolution (quantisation ``2 pi / counts`` rad).
    motion_seed : int, optional
        Seeds the motion, stamps and noise instead of ``seed`` (the arms stay ``seed``'s):
        another run of the same arm.
    payload : :class:`~manipdyn.identification.inputs.runs.Payload`, optional
        A known load at the tool frame, in the logged torques.
    log_name : str
        The log's file name in ``directory``.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ModelError(f"seed: expected an integer >= 0, got {seed!r}")
    if motion_seed is not None and (isinstance(motion_seed, bool) or not isinstance(motion_seed, (int, np.integer))
                                    or motion_seed < 0):
        raise ModelError(f"motion_seed: expected an integer >= 0 or None, got {motion_seed!r}")
    for name, v in (("duration", duration), ("held_out", held_out), ("rate", rate)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ModelError(f"{name}: expected a positive number, got {v!r}")
    if not held_out < duration:
        raise ModelError(f"held_out: expected less than duration ({duration} s), got {held_out}")
    if not (isinstance(noise, (int, float)) and 0 <= noise < 1):
        raise ModelError(f"noise: expected a fraction 0 <= noise < 1, got {noise!r}")
    if isinstance(counts, bool) or not isinstance(counts, (int, np.integer)) or counts < 2:
        raise ModelError(f"counts: expected an integer >= 2 (encoder counts per motor revolution), got {counts!r}")
    truth, prior = hard_arms(seed)
    rng = np.random.default_rng([int(seed if motion_seed is None else motion_seed), 7])
    n, tr = truth.n, truth.transmission
    q0, a, b, period = _motion(rng, n, float(duration))
    t, src, stamps = _stamps(rng, float(duration), float(rate))
    sw, swd, swdd = _warp(t, float(duration))
    f, fd, fdd = fourier_trajectory(sw, q0, a, b, period)
    q, qd, qdd = f, fd * swd[:, None], fdd * swd[:, None] ** 2 + fd * swdd[:, None]
    tau = truth.inverse_dynamics(q, qd, qdd)
    if payload is not None:
        tau = tau + payload.torque(truth, q, qd, qdd)
    tau_m = tr.motor_torques(tau)
    s = noise * np.abs(tau_m).max(axis=0)
    tau_m_meas = tau_m + s * rng.standard_normal(tau_m.shape)
    step = 2.0 * math.pi / counts
    qm = np.round(tr.motor_positions(q) / step) * step
    current = tau_m_meas / tr.torque_constant
    rows = [qm[src], current[src]]
    sigma = np.sqrt((tr.R**2).T @ s**2)
    paths = (None, None, None)
    if directory is not None:
        directory = os.fspath(directory)
        os.makedirs(directory, exist_ok=True)
        paths = tuple(os.path.join(directory, f) for f in (log_name, "truth.toml", "prior.toml"))
        header = ",".join(["t"] + [f"qm{i + 1}" for i in range(n)] + [f"i{i + 1}" for i in range(n)])
        body = np.column_stack([stamps] + rows)
        lines = [header] + [",".join(f"{x:.10g}" for x in row) for row in body]
        atomic_write_text(paths[0], "\n".join(lines) + "\n")
        save(truth, paths[1])
        save(prior, paths[2])
    return HardLog(truth=truth, prior=prior, log=paths[0], truth_file=paths[1], prior_file=paths[2],
                   sigma=sigma, motor_sigma=s, split=float(duration - held_out), t=stamps, q=q[src], qd=qd[src],
                   qdd=qdd[src], tau=tr.joint_torques(tau_m_meas)[src], rows=len(src))


def recovered(result, truth) -> dict:
    """The rotor and friction parameters of a fit against the truth's.

    ``result``: a :class:`~manipdyn.identification.FitResult` with ``armature=True``
    and friction columns of the truth's law's terms (any shapes); ``truth``: the
    arm that made the log.  Returns ``{name: {"true", "identified", "error",
    "identifiable"}}`` in regressor units (:mod:`manipdyn.model.friction`: motor-side
    values reflected, ``jointk.armature = R_kk^2 Jm_k``), ``error`` relative
    (identified / true - 1), for every armature and friction parameter, and
    ``motork.stribeck_velocity`` (rad/s at the motor) when the law has a
    Stribeck term.  ``identifiable`` is False for a parameter the data cannot
    separate from others (it is not a combination of base parameters, e.g.
    motor 1's rotor inertia, grouped with link 1's ``Izz``); its value is then
    the prior's share of the group and says nothing about the fit.
    """
    from ...model.parameters import arm_parameters

    base, n = result.base, truth.n
    law = base.friction
    if not base.armature or not isinstance(law, Friction) or law.terms != truth.friction_model.terms:
        raise ModelError("recovered: the fit must identify the armature and the truth's friction terms "
                         f"({', '.join(truth.friction_model.terms)}) with a Friction spec")
    true_pi = arm_parameters(truth, True, truth.friction_model)
    K = base.K
    inrow = np.diag(np.linalg.pinv(K) @ K)          # 1 where e_p lies in K's row space
    out = {}
    for p in range(10 * n, len(base.names)):
        tv, iv = float(true_pi[p]), float(result.parameters[p])
        out[base.names[p]] = {"true": tv, "identified": iv, "error": iv / tv - 1.0 if tv else math.nan,
                              "identifiable": bool(abs(inrow[p] - 1.0) < 1e-8)}
    if law.stribeck_velocity is not None:
        for k in range(n):
            tv, iv = float(truth.friction_model.stribeck_velocity[k]), float(law.stribeck_velocity[k])
            out[f"motor{k + 1}.stribeck_velocity"] = {"true": tv, "identified": iv, "error": iv / tv - 1.0,
                                                      "identifiable": True}
    return out


#: the known payload of :func:`hard_log_set`'s second run: 2.8 kg, its centre of mass off
#: the tool axis (so that it loads the last wrist motor too), inertia about the COM
SET_PAYLOAD = {"mass": 2.8, "com": [0.06, 0.03, 0.05], "inertia": [0.006, 0.006, 0.004, 0.0, 0.0, 0.0]}


def hard_log_set(seed: int, directory, *, duration: float = 30.0, payload=None) -> dict:
    """Two runs of :func:`hard_log`'s arm ``seed`` written to ``directory``, for torque constants:
    ``run1.csv`` (motion ``seed``) and ``run2.csv`` (another motion, carrying ``payload``,
    default :data:`SET_PAYLOAD`), each ``duration`` s of currents; ``RUNS.toml`` lists them (the
    second with its payload); ``prior.toml`` is the prior WITHOUT torque constants and
    ``prior_kt.toml`` the prior with them.  Returns ``{"runs", "prior", "prior_kt", "truth",
    "torque_constant"}`` (paths, the truth arm and its k_t (6,))."""
    from ...formats.save import to_toml
    from ..inputs.runs import Payload

    spec = dict(SET_PAYLOAD if payload is None else payload)
    load_ = Payload(float(spec["mass"]), tuple(spec["com"]), tuple(spec.get("inertia", [0.0] * 6)))
    directory = os.fspath(directory)
    h1 = hard_log(seed, directory, duration=duration, held_out=duration / 4, log_name="run1.csv")
    hard_log(seed, directory, duration=duration, held_out=duration / 4, motion_seed=10_000 + int(seed),
             payload=load_, log_name="run2.csv")
    tr = h1.prior.transmission
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        no_kt = Manipulator(h1.prior.links, convention=h1.prior.convention, gravity=h1.prior.gravity,
                            name=h1.prior.name, source=h1.prior.source, description=h1.prior.description,
                            transmission=Transmission(tr.R, tr.motor_offset))
    paths = {k: os.path.join(directory, f) for k, f in (("runs", "RUNS.toml"), ("prior", "prior.toml"),
                                                        ("prior_kt", "prior_kt.toml"))}
    os.replace(h1.prior_file, paths["prior_kt"])
    atomic_write_text(paths["prior"], to_toml(no_kt))
    vec = lambda xs: "[" + ", ".join(repr(float(x)) for x in xs) + "]"   # noqa: E731
    atomic_write_text(paths["runs"], (
        '[[log]]\npath = "run1.csv"\n\n[[log]]\npath = "run2.csv"\n'
        f"payload = {{ mass = {load_.mass!r}, com = {vec(load_.com)}, inertia = {vec(load_.inertia)} }}\n"))
    return {**paths, "truth": h1.truth, "torque_constant": np.array(tr.torque_constant)}
