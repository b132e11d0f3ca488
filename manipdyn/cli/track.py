"""``manipdyn track``: run a tracking controller on the standard demo path.

Layer: CLI.

    manipdyn track MODEL [--controller pd|pdg|ct|adaptive|lqr] [--payload KG]
                         [--duration S] [--plot out.png] [--compare]

The controller is built on the arm as described (MODEL); with ``--payload``
the simulated plant carries an extra mass on its last link that the
controller does not know about.  Prints RMS and max tracking error and peak
torque per joint; ``--plot`` writes a figure (matplotlib, the ``plot`` extra),
atomically.  Exit codes: 0 the run(s) finished, 1 a controller drove the arm
unstable (reported, the other runs of ``--compare`` still shown), 2 bad input.
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np

from ..control.demo import CONTROLLERS, DEFAULT_BANDWIDTH, DEFAULT_GAMMA, DEFAULT_PAYLOAD_COM, demo_path, make_controller
from ..control.plant import with_payload
from ..control.plots import PLOT_INSTALL, plot_compare, plot_single
from ..control.simulate import SimulationDiverged, simulate
from ..errors import ModelError
from .common import TIP_HELP, Progress, add_progress_options, check_outputs, load_arm, progress_wanted

__all__ = ["register", "run"]


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


def check_options(args) -> None:
    """Refuse every bad numeric option, and an unwritable --plot target, before any work."""
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
    # fail before a long run, not after it
    check_outputs([("--plot", args.plot)], [("MODEL", args.model)], plots=("--plot",))


def run(args) -> int:
    check_options(args)
    arm, notes = load_arm(args.model, args.tip)
    plant = arm
    if args.payload > 0:
        plant = with_payload(arm, args.payload, com=DEFAULT_PAYLOAD_COM)
    path = demo_path(arm, args.duration)
    kinds = list(CONTROLLERS) if args.compare else [args.controller]
    show_progress = progress_wanted(args)
    final = max(0.0, args.duration - 1.0)
    logs, rc = {}, 0
    head = (f"manipdyn track {arm.name}: demo path {args.duration:g} s, {1 / args.dt:g} Hz RK4 "
            f"(torque held over each step), bandwidth {args.bandwidth:g} rad/s")
    if args.payload > 0:
        head += (f"; plant carries {args.payload:g} kg at {list(DEFAULT_PAYLOAD_COM)} m in the last "
                 "link's frame, unknown to the controllers")
    say = (lambda *a, **k: None) if args.json else print     # --json: one document, nothing else
    say(head)
    for n in notes:
        say(f"  note: {n}")
    for kind in kinds:
        ctrl = make_controller(kind, arm, args.bandwidth, args.gamma, path=path, dt=args.dt)
        label = CONTROLLERS[kind]
        try:
            log = simulate(arm, ctrl, path, args.duration, dt=args.dt, plant=plant,
                           progress=Progress(label[:16], show_progress, unit="steps"))
        except SimulationDiverged as exc:
            logs[label] = f"DIVERGED at t = {exc.t:.3g} s"
            say(f"\n{label}: {exc}")
            rc = 1
            continue
        logs[label] = log
        say()
        say(log.summary())
        say(f"  RMS error over the final second (t >= {final:g} s): "
            + " ".join(f"{x:.3e}" for x in log.rms_error(since=final)))
    if args.compare:
        say()
        say(_compare_table(logs, final))
    if args.json:
        print(json.dumps(_json_doc(args, arm, notes, logs, final), indent=2))
    if args.plot:
        return write_figure(args, arm, logs, kinds, rc)
    return rc


def _floats(x) -> list:
    return [float(v) for v in np.asarray(x).reshape(-1)]


def _json_doc(args, arm, notes, logs: dict, final: float) -> dict:
    """``track --json``: the run's settings and, per controller, its errors (rad or m) and
    torques (N m or N) per joint, or ``"diverged"`` with the time; strict JSON (finite numbers)."""
    runs = {}
    for label, log in logs.items():
        if isinstance(log, str):
            runs[label] = {"diverged": True, "message": log}
            continue
        runs[label] = {"diverged": False, "rms_error": _floats(log.rms_error()),
                       "max_error": _floats(log.max_error()),
                       "rms_error_final_second": _floats(log.rms_error(since=final)),
                       "peak_torque": _floats(log.peak_torque())}
    return {"model": args.model, "name": arm.name, "n": arm.n, "duration": args.duration, "dt": args.dt,
            "bandwidth": args.bandwidth, "gamma": args.gamma, "payload": args.payload,
            "notes": list(notes), "controllers": runs}


def write_figure(args, arm, logs: dict, kinds: list, rc: int) -> int:
    """The --plot figure of the run(s): all controllers with --compare, else the one."""
    title = f"{arm.name}: demo path, {args.duration:g} s at {1 / args.dt:g} Hz" + \
        (f", +{args.payload:g} kg payload unknown to the controller" if args.payload > 0 else "")
    if args.compare:
        plot_compare(logs, arm, title, args.plot)
    else:
        only = logs[CONTROLLERS[kinds[0]]]
        if isinstance(only, str):
            print(f"no figure: the run {only.lower()}", file=sys.stderr)   # stderr: --json stays one document
            return rc
        plot_single(only, arm, f"{title}\n{CONTROLLERS[kinds[0]]}", args.plot)
    if not args.json:
        print(f"\nfigure written to {args.plot}")
    return rc


def register(subparsers) -> None:
    """Add ``manipdyn track`` to the ``manipdyn`` command line."""
    p = subparsers.add_parser(
        "track", help="simulate a tracking controller on a demo path",
        description="Simulate a joint-space tracking controller on the standard demo path "
                    "(fixed-step RK4, zero-order hold) and report tracking errors and torques. "
                    "Exit codes: 0 finished, 1 a controller diverged, 2 bad input.")
    p.add_argument("model", metavar="MODEL_OR_FILE", help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd)")
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("--controller", type=str.lower, choices=list(CONTROLLERS), default="ct",
                   help="pd, pdg (PD + gravity), ct (computed torque, default), adaptive (Slotine-Li), "
                        "lqr (time-varying LQR along the path, the gains on the --dt grid); any case")
    p.add_argument("--payload", type=float, default=0.0, metavar="KG",
                   help="extra mass on the last link of the simulated arm, unknown to the controller")
    p.add_argument("--duration", type=float, default=8.0, metavar="S", help="seconds (default 8)")
    p.add_argument("--dt", type=float, default=1e-3, metavar="S",
                   help="step and controller period (default 0.001)")
    p.add_argument("--bandwidth", type=float, default=DEFAULT_BANDWIDTH, metavar="RAD_S",
                   help=f"closed-loop bandwidth of the controllers (default {DEFAULT_BANDWIDTH:g})")
    p.add_argument("--gamma", type=float, default=DEFAULT_GAMMA,
                   help=f"adaptation gain of the adaptive controller (default {DEFAULT_GAMMA:g})")
    p.add_argument("--plot", metavar="OUT.png", default=None,
                   help=f"write a figure (needs matplotlib: {PLOT_INSTALL})")
    p.add_argument("--compare", action="store_true", help="run all five controllers and compare them")
    p.add_argument("--json", action="store_true", help="print one JSON document instead of tables")
    add_progress_options(p, "a progress bar per run")
    p.set_defaults(func=run)
