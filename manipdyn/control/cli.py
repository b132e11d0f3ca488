"""``manipdyn track``: run a tracking controller on a standard demo path.

    manipdyn track MODEL [--controller pd|pdg|ct|adaptive] [--payload KG]
                         [--duration S] [--plot out.png] [--compare]

The controller is built on the arm as described (MODEL); with ``--payload``
the simulated plant carries an extra mass on its last link that the
controller does not know about.  Prints RMS and max tracking error and peak
torque per joint; ``--plot`` writes a figure (matplotlib, the ``plot`` extra),
atomically.  Exit codes: 0 the run(s) finished, 1 a controller drove the arm
unstable (reported, the other runs of ``--compare`` still shown), 2 bad input.
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np

from ..errors import ModelError
from .._files import atomic_write

__all__ = ["register_cli", "demo_path", "make_controller", "CONTROLLERS", "DEFAULT_BANDWIDTH",
           "DEFAULT_GAMMA", "DEFAULT_PAYLOAD_COM"]

#: controller keys, in the order of --compare
CONTROLLERS = {"pd": "PD", "pdg": "PD + gravity", "ct": "computed torque", "adaptive": "adaptive (Slotine-Li)"}

#: closed-loop bandwidth of every demo controller, rad/s (critically damped)
DEFAULT_BANDWIDTH = 10.0
#: adaptation gain of the demo: Gamma = adaptation_gains(arm, DEFAULT_GAMMA), each
#: parameter's gain scaled by the joint inertias it acts on.  Tuned on the
#: bundled arms with a 2 kg payload at 1 kHz (tests/test_control.py): 0 behaves
#: like computed torque with the wrong model; 3 to 30 cut the final-second error
#: 6x (Stanford) to 50x (UR10); 100 still runs; an unscaled Gamma = 1 I
#: diverges on the UR5 and UR10.
DEFAULT_GAMMA = 10.0
#: where --payload puts the mass: 0.1 m along z of the last link's frame
DEFAULT_PAYLOAD_COM = (0.0, 0.0, 0.1)


def demo_path(arm, duration: float, via_step: float = 0.5):
    """The standard demo path: a :class:`ViaPoints` spline over ``duration`` s.

    Around the middle of the joint limits ``qc``, each joint swings as
    ``A_i sin(2 pi t / P_i)`` with its own period ``P_i = 2 + 0.7 i`` s (so the
    joints move out of step: rich excitation for adaptation), amplitude
    ``A_i = min(0.6 rad, range/5)`` (``min(0.1 m, range/5)`` for prismatic
    joints), under an envelope rising over the first second and falling over
    the last, sampled every ``via_step`` s.  It starts and ends at rest at ``qc``.
    """
    from .trajectory import ViaPoints

    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    qc = 0.5 * (lo + hi)
    prismatic = np.array([t == "prismatic" for t in arm.joint_types])
    A = np.minimum(np.where(prismatic, 0.1, 0.6), 0.2 * (hi - lo))
    K = max(2, int(round(duration / via_step)))
    t = np.linspace(0.0, duration, K + 1)
    ramp = min(1.0, duration / 3)
    env = np.clip(np.minimum(t, duration - t) / ramp, 0.0, 1.0)
    env = env * env * (3 - 2 * env)                          # smoothstep, 0 at both ends
    P = 2.0 + 0.7 * np.arange(arm.n)
    pts = qc + env[:, None] * A * np.sin(2 * np.pi * t[:, None] / P)
    return ViaPoints(pts, t)


def make_controller(kind: str, arm, wn: float = DEFAULT_BANDWIDTH, gamma: float = DEFAULT_GAMMA,
                    tau_max=None):
    """The demo controllers, all tuned to the bandwidth ``wn`` (rad/s), critically damped.

    * ``pd``, ``pdg``: ``Kp = wn^2 D_ii``, ``Kd = 2 wn D_ii`` (:func:`pd_gains`);
    * ``ct``: ``Kp = wn^2``, ``Kd = 2 wn``;
    * ``adaptive``: ``Lambda = wn``, ``K_D = wn D_ii``, and
      ``Gamma = adaptation_gains(arm, gamma)``: the poles of
      ``(s + Lambda)(D_ii s + K_D)`` are those of the others.
    ``D_ii`` is the model's mass matrix at the middle of the joint limits.
    """
    from .controllers import PD, ComputedTorque, PDGravity, SlotineLi, adaptation_gains, pd_gains

    kp, kd = pd_gains(arm, wn)
    if kind == "pd":
        return PD(arm, kp, kd, tau_max=tau_max)
    if kind == "pdg":
        return PDGravity(arm, kp, kd, tau_max=tau_max)
    if kind == "ct":
        return ComputedTorque(arm, wn**2, 2 * wn, tau_max=tau_max)
    if kind == "adaptive":
        return SlotineLi(arm, lam=wn, kd=kd / 2, gamma=adaptation_gains(arm, gamma), tau_max=tau_max)
    raise ModelError(f"--controller: expected one of {', '.join(CONTROLLERS)}, got {kind!r}")


# -- figure ------------------------------------------------------------------------
def _pyplot():
    try:
        import matplotlib
    except ImportError:
        raise ModelError("--plot needs matplotlib: install manipdyn[plot] "
                         "(pip install 'manipdyn[plot]')") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save_atomic(fig, path: str) -> None:
    """``fig.savefig`` to ``path`` atomically (no partial figure on failure)."""
    ext = os.path.splitext(os.fspath(path))[1].lstrip(".").lower() or "png"
    atomic_write(path, lambda fh: fig.savefig(fh, format=ext, dpi=120), binary=True)


def _units(arm):
    pr = [t == "prismatic" for t in arm.joint_types]
    return (["m" if p else "rad" for p in pr], ["N" if p else "N m" for p in pr])


def plot_single(log, arm, title: str, path: str) -> None:
    """Per-joint tracking error and torque against time."""
    plt = _pyplot()
    fig, (ax_e, ax_t) = plt.subplots(2, 1, figsize=(10, 7.5), sharex=True)
    eu, tu = _units(arm)
    for i in range(arm.n):
        ax_e.plot(log.t, log.e[:, i], lw=1.2, label=f"joint {i + 1} ({eu[i]})")
        ax_t.plot(log.t, log.tau[:, i], lw=1.2, label=f"joint {i + 1} ({tu[i]})")
    ax_e.set_ylabel("tracking error  q_d - q")
    ax_e.axhline(0.0, color="k", lw=0.5)
    ax_t.set_ylabel("joint torque")
    ax_t.set_xlabel("time (s)")
    for ax in (ax_e, ax_t):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), fontsize=8, ncol=6, frameon=False)
    fig.suptitle(title)
    fig.tight_layout()
    _save_atomic(fig, path)
    plt.close(fig)


def plot_compare(logs: dict, arm, title: str, path: str) -> None:
    """Controllers side by side: |e(t)| over time, RMS error and peak torque per joint."""
    plt = _pyplot()
    fig = plt.figure(figsize=(11, 9))
    gs = fig.add_gridspec(2, 2, height_ratios=[1.2, 1.0])
    ax_n = fig.add_subplot(gs[0, :])
    ax_r = fig.add_subplot(gs[1, 0])
    ax_p = fig.add_subplot(gs[1, 1])
    joints = np.arange(1, arm.n + 1)
    ok = {k: v for k, v in logs.items() if v is not None and not isinstance(v, str)}
    width = 0.8 / max(1, len(ok))
    for c, (label, log) in enumerate(ok.items()):
        norm = np.linalg.norm(log.e, axis=1)
        ax_n.semilogy(log.t, np.maximum(norm, 1e-12), lw=1.2, label=label)
        ax_r.bar(joints + (c - (len(ok) - 1) / 2) * width, log.rms_error(), width, label=label)
        ax_p.bar(joints + (c - (len(ok) - 1) / 2) * width, log.peak_torque(), width, label=label)
    for label, v in logs.items():
        if isinstance(v, str):
            ax_n.plot([], [], " ", label=f"{label}: {v}")
    floors = [np.percentile(np.linalg.norm(lg.e, axis=1)[lg.t >= 0.1 * lg.t[-1]], 1) for lg in ok.values()]
    if floors and min(floors) > 0:   # the error starts at 0: do not spend decades on that
        ax_n.set_ylim(bottom=0.3 * min(floors))
    ax_n.set_ylabel("|q_d - q|  (norm over joints)")
    ax_n.set_xlabel("time (s)")
    ax_n.legend(fontsize=8, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=4, frameon=False)
    ax_r.set_yscale("log")
    ax_r.set_ylabel("RMS tracking error (rad or m)")
    ax_p.set_ylabel("peak |torque| (N m or N)")
    for ax in (ax_r, ax_p):
        ax.set_xlabel("joint")
        ax.set_xticks(joints)
    for ax in (ax_n, ax_r, ax_p):
        ax.grid(True, alpha=0.3, which="both")
    fig.suptitle(title)
    fig.tight_layout()
    _save_atomic(fig, path)
    plt.close(fig)


# -- the command -----------------------------------------------------------------------
def _compare_table(logs: dict, final: float) -> str:
    rows = [f"{'controller':<24} {'RMS error':>11} {'max error':>11} {f'RMS t>={final:g}s':>12} "
            f"{'peak torque':>12}"]
    for label, log in logs.items():
        if isinstance(log, str):
            rows.append(f"{label:<24} {log}")
            continue
        rows.append(f"{label:<24} {np.linalg.norm(log.rms_error()):11.3e} {log.max_error().max():11.3e} "
                    f"{np.linalg.norm(log.rms_error(since=final)):12.3e} {log.peak_torque().max():12.2f}")
    rows.append("  (RMS: norm over joints of the per-joint RMS error; rad and m mixed for "
                "arms with prismatic joints)")
    return "\n".join(rows)


#: bounds on a demo run: the via-point spline of the demo path is solved densely
#: (its cost grows with the square of the duration) and the log is in memory
MAX_DURATION = 300.0
MAX_STEPS = 2e6


def _cmd_track(args) -> int:
    from ..cli import _load_quiet
    from .plant import with_payload
    from .simulate import SimulationDiverged, simulate

    for opt in ("duration", "dt", "payload", "bandwidth", "gamma"):
        if not math.isfinite(getattr(args, opt)):
            raise ModelError(f"--{opt}: must be a finite number, got {getattr(args, opt)}")
    if not (0 < args.duration <= MAX_DURATION):
        raise ModelError(f"--duration: must be > 0 s and at most {MAX_DURATION:g} s, got {args.duration}")
    if not (args.dt > 0) or args.dt > args.duration:
        raise ModelError(f"--dt: must be > 0 s and at most --duration, got {args.dt}")
    if args.duration / args.dt > MAX_STEPS:
        raise ModelError(f"--dt: {args.duration:g} s at dt = {args.dt:g} s is more than {MAX_STEPS:g} steps")
    if not (args.payload >= 0):
        raise ModelError(f"--payload: must be >= 0 kg, got {args.payload}")
    if not (args.bandwidth > 0):
        raise ModelError(f"--bandwidth: must be > 0 rad/s, got {args.bandwidth}")
    if not (args.gamma >= 0):
        raise ModelError(f"--gamma: must be >= 0, got {args.gamma}")
    if args.plot:  # fail before a long run, not after it
        folder = os.path.dirname(os.path.abspath(args.plot))
        if os.path.isdir(args.plot) or not os.path.isdir(folder) or not os.access(folder, os.W_OK):
            raise ModelError(f"--plot {args.plot}: expected a writable file path (its folder must exist)")
        _pyplot()  # matplotlib installed?
    notes: list[str] = []
    arm = _load_quiet(args.model, None, notes)
    plant = arm
    if args.payload > 0:
        plant = with_payload(arm, args.payload, com=DEFAULT_PAYLOAD_COM)
    path = demo_path(arm, args.duration)
    kinds = list(CONTROLLERS) if args.compare else [args.controller]
    final = max(0.0, args.duration - 1.0)
    logs, rc = {}, 0
    head = (f"manipdyn track {arm.name}: demo path {args.duration:g} s, {1 / args.dt:g} Hz RK4 "
            f"(torque held over each step), bandwidth {args.bandwidth:g} rad/s")
    if args.payload > 0:
        head += (f"; plant carries {args.payload:g} kg at {list(DEFAULT_PAYLOAD_COM)} m in the last "
                 "link's frame, unknown to the controllers")
    print(head)
    for n in notes:
        print(f"  note: {n}")
    for kind in kinds:
        ctrl = make_controller(kind, arm, args.bandwidth, args.gamma)
        label = CONTROLLERS[kind]
        try:
            log = simulate(arm, ctrl, path, args.duration, dt=args.dt, plant=plant)
        except SimulationDiverged as exc:
            logs[label] = f"DIVERGED at t = {exc.t:.3g} s"
            print(f"\n{label}: {exc}")
            rc = 1
            continue
        logs[label] = log
        print()
        print(log.summary())
        print(f"  RMS error over the final second (t >= {final:g} s): "
              + " ".join(f"{x:.3e}" for x in log.rms_error(since=final)))
    if args.compare:
        print()
        print(_compare_table(logs, final))
    if args.plot:
        title = f"{arm.name}: demo path, {args.duration:g} s at {1 / args.dt:g} Hz" + \
                (f", +{args.payload:g} kg payload unknown to the controller" if args.payload > 0 else "")
        if args.compare:
            plot_compare(logs, arm, title, args.plot)
        else:
            only = logs[CONTROLLERS[kinds[0]]]
            if isinstance(only, str):
                print(f"no figure: the run {only.lower()}", file=sys.stderr)
                return rc
            plot_single(only, arm, f"{title}\n{CONTROLLERS[kinds[0]]}", args.plot)
        print(f"\nfigure written to {args.plot}")
    return rc


def register_cli(subparsers) -> None:
    """Add ``manipdyn track`` to the ``manipdyn`` command line."""
    p = subparsers.add_parser(
        "track", help="simulate a tracking controller on a demo path",
        description="Simulate a joint-space tracking controller on the standard demo path "
                    "(fixed-step RK4, zero-order hold) and report tracking errors and torques. "
                    "Exit codes: 0 finished, 1 a controller diverged, 2 bad input.")
    p.add_argument("model", metavar="MODEL", help="bundled model name or .toml model file")
    p.add_argument("--controller", choices=list(CONTROLLERS), default="ct",
                   help="pd, pdg (PD + gravity), ct (computed torque, default), adaptive (Slotine-Li)")
    p.add_argument("--payload", type=float, default=0.0, metavar="KG",
                   help="extra mass on the last link of the simulated arm, unknown to the controller")
    p.add_argument("--duration", type=float, default=8.0, metavar="S", help="seconds (default 8)")
    p.add_argument("--dt", type=float, default=1e-3, metavar="S",
                   help="step and controller period (default 0.001)")
    p.add_argument("--bandwidth", type=float, default=DEFAULT_BANDWIDTH, metavar="RAD_S",
                   help=f"closed-loop bandwidth of the controllers (default {DEFAULT_BANDWIDTH:g})")
    p.add_argument("--gamma", type=float, default=DEFAULT_GAMMA,
                   help=f"adaptation gain of the adaptive controller (default {DEFAULT_GAMMA:g})")
    p.add_argument("--plot", metavar="OUT.png", default=None, help="write a figure (needs matplotlib)")
    p.add_argument("--compare", action="store_true", help="run all four controllers and compare them")
    p.set_defaults(func=_cmd_track)
