"""``manipdyn track``: run a tracking controller on the standard demo path, or on the user's own.

Layer 7 (CLI, the top).

    manipdyn track MODEL [--controller pd|pdg|ct|adaptive|lqr] [--payload KG]
                         [--duration S] [--trajectory FILE.csv] [--plot out.png] [--compare] [--simulator mujoco]

The controller is built on the arm as described (MODEL); with ``--payload``
the simulated plant carries an extra mass on its last link that the
controller does not know about.  Prints RMS and max tracking error and peak
torque per joint; ``--plot`` writes a figure (matplotlib, the ``plot`` extra),
atomically.  Exit codes: 0 the run(s) finished, 1 a controller drove the arm
unstable (reported, the other runs of ``--compare`` still shown), 2 bad input.
"""

from __future__ import annotations

import json
import sys

from ..control.demo import CONTROLLERS, DEFAULT_BANDWIDTH, DEFAULT_GAMMA
from ..control.track import check_track_options, reference_for, track, track_header
from .._support.figures import PLOT_INSTALL
from .common import TIP_HELP, Progress, add_progress_options, check_outputs, load_arm, progress_wanted, usage_error

__all__ = ["register", "run"]


def run(args) -> int:
    if args.simulator != "mujoco" and args.mujoco_plant != "file":
        return usage_error("track", "--mujoco-plant: only with --simulator mujoco")
    check_track_options(duration=args.duration, dt=args.dt, payload=args.payload, bandwidth=args.bandwidth,
                        gamma=args.gamma, prefix="--")
    # fail before a long run, not after it
    inputs = [("MODEL", args.model)] + ([("--trajectory", args.trajectory)] if args.trajectory else [])
    check_outputs([("--plot", args.plot)], inputs,
                  plots=("--plot",))
    arm, notes = load_arm(args.model, args.tip)
    path, duration, reference = reference_for(arm, args.trajectory, args.duration)   # read before any run
    check_track_options(duration=duration, dt=args.dt, payload=args.payload, bandwidth=args.bandwidth,
                        gamma=args.gamma, prefix="--")
    say = (lambda *a, **k: None) if args.json else print     # --json: one document, nothing else
    show = progress_wanted(args)

    def printed(result, label):
        say()
        say(result.run_text(label))

    say(track_header(arm, duration, args.dt, args.bandwidth, args.payload, reference, args.simulator))
    if args.simulator == "mujoco":
        from ..engines.mujoco import mujoco_module
        from ..formats.mjcf import mjcf_losses

        mujoco_module()                     # the extra's install command, before any work
        for line in mjcf_losses(arm):
            if not line.startswith("link ") and args.mujoco_plant == "file":   # refused inertias: set exactly
                say(f"  MuJoCo's plant does not hold: {line}")
    for n in notes:
        say(f"  note: {n}")
    result = track(arm, "all" if args.compare else (args.controller,), payload=args.payload,
                   duration=duration, dt=args.dt, bandwidth=args.bandwidth, gamma=args.gamma,
                   progress=lambda label: Progress(label, show, unit="steps"), on_run=printed, trajectory=path,
                   simulator=args.simulator, mujoco_plant=args.mujoco_plant)
    if args.compare:
        say()
        say(result.compare_table())
    if args.json:
        print(json.dumps(result.to_dict(args.model, notes), indent=2))
    if args.plot:
        why_not = result.plot(args.plot)
        if why_not:
            print(why_not, file=sys.stderr)   # stderr: --json stays one document
        elif not args.json:
            print(f"\nfigure written to {args.plot}")
    return 1 if result.diverged else 0


def register(subparsers) -> None:
    """Add ``manipdyn track`` to the ``manipdyn`` command line."""
    p = subparsers.add_parser(
        "track", help="simulate a tracking controller on a demo path",
        description="Simulate a joint-space tracking controller on the standard demo path (or on your "
                    "own, --trajectory) "
                    "(fixed-step RK4, zero-order hold) and report tracking errors and torques. "
                    "Exit codes: 0 finished, 1 a controller diverged, 2 bad input.")
    p.add_argument("model", metavar="MODEL_OR_FILE", help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd)")
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("--controller", type=str.lower, choices=list(CONTROLLERS), default="ct",
                   help="pd, pdg (PD + gravity), ct (computed torque, default), adaptive (Slotine-Li), "
                        "lqr (time-varying LQR along the path, the gains on the --dt grid); any case")
    p.add_argument("--payload", type=float, default=0.0, metavar="KG",
                   help="extra mass on the last link of the simulated arm, unknown to the controller")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help="seconds (default 8 on the demo path, the --trajectory file's length on it)")
    p.add_argument("--trajectory", default=None, metavar="FILE.csv",
                   help="track your own reference path instead of the demo path: a CSV with the header "
                        "t,q1..qn (s; rad, or m for prismatic joints), or excite's t,q1..qn,qd1..qdn,qdd1..qddn; "
                        "times from the first row, positions within the joint limits (default: the demo path)")
    p.add_argument("--dt", type=float, default=1e-3, metavar="S",
                   help="step and controller period (default 0.001)")
    p.add_argument("--bandwidth", type=float, default=DEFAULT_BANDWIDTH, metavar="RAD_S",
                   help=f"closed-loop bandwidth of the controllers (default {DEFAULT_BANDWIDTH:g})")
    p.add_argument("--gamma", type=float, default=DEFAULT_GAMMA,
                   help=f"adaptation gain of the adaptive controller (default {DEFAULT_GAMMA:g})")
    p.add_argument("--plot", metavar="OUT.png", default=None,
                   help=f"write a figure (needs matplotlib: {PLOT_INSTALL})")
    p.add_argument("--compare", action="store_true", help="run all five controllers and compare them")
    p.add_argument("--simulator", choices=("manipdyn", "mujoco"), default="manipdyn",
                   help="who steps the plant: manipdyn's RK4 (default) or MuJoCo's RK4 on the arm's MJCF, the "
                        "controller's torque as the actuators' control each period (needs the mujoco extra)")
    p.add_argument("--mujoco-plant", choices=("file", "model"), default="file",
                   help="with --simulator mujoco: 'file' (default) the MJCF as MuJoCo loads it (limits and "
                        "frictionloss are MuJoCo's constraints; friction terms MJCF cannot hold are absent), or "
                        "'model' the same plant as manipdyn's own run (constraints off, the whole friction law)")
    p.add_argument("--json", action="store_true", help="print one JSON document instead of tables")
    add_progress_options(p, "a progress bar per run")
    p.set_defaults(func=run)
