"""``manipdyn synthesize MODEL TRAJ.csv -o DATA.csv``: a measurement log without a robot.

Layer 7 (CLI, the top).

Reads the trajectory ``manipdyn excite`` wrote, computes the joint torques of
MODEL along it (``--perturb``: of the demo's "true" arm around MODEL, with
masses, centres of mass and friction off), adds seeded noise, and writes
``t,q1..qn,tau1..taun`` (``--derivatives``: with ``qd``, ``qdd``), the log
``manipdyn identify`` reads; ``--truth FILE.toml`` also writes the arm ``--perturb`` drew,
as a model file (``md.load`` reads it back), so an identification can be checked against it.
Exit codes: 0 written, 2 usage, model or data error.
"""

from __future__ import annotations

import json
import os

from .._support.errors import ModelError
from . import synthesize_static
from .common import EXIT_OK, TIP_HELP, check_outputs, load_arm

__all__ = ["register", "run"]


def run(args) -> int:
    from ..formats.logs.data import write_measurements_csv
    from ..model.arm import Manipulator
    from ..identification.experiments.demo import true_arm
    from ..identification.experiments.synthesize import check_contacts_act, contact_torques, parse_contact, read_trajectory, synthesize

    if not (args.noise >= 0 and args.noise < float("inf")):
        raise ModelError(f"--noise: expected a finite fraction >= 0 of each joint's peak torque, got {args.noise}")
    if args.seed < 0:
        raise ModelError(f"--seed: expected an integer >= 0, got {args.seed}")
    if args.truth is not None and not args.perturb:
        raise ModelError("--truth: only with --perturb (without it the log is MODEL's own, and MODEL is the truth)")
    if args.truth is not None and not str(args.truth).endswith(".toml"):
        raise ModelError(f"--truth: expected a model file name ending in .toml (what md.load reads), "
                         f"got {args.truth!r}")
    sidecar = None
    if args.contact:
        sidecar = (args.output[:-4] if args.output.lower().endswith(".csv") else args.output) + ".contacts.json"
    check_outputs([("-o", args.output), ("--truth", args.truth), ("--contact", sidecar)],
                  [("MODEL", args.model), ("TRAJ.csv", args.trajectory)])
    arm, _notes = load_arm(args.model, args.tip)
    if args.perturb and not isinstance(arm, Manipulator):
        raise ModelError(f"--perturb: only for DH models (a bundled name or a .toml file), not {args.model!r}")
    robot = synthesize_static.apply(args, true_arm(arm, args.seed) if args.perturb else arm)
    traj = read_trajectory(args.trajectory, arm.n)
    contacts = [parse_contact(c, robot) for c in (args.contact or [])]
    check_contacts_act(contacts, traj.t)
    tau = synthesize(robot, traj.q, traj.qd, traj.qdd, noise=args.noise, seed=args.seed,
                     static_friction=args.static_friction is not None)
    if contacts:
        tau = tau - contact_torques(robot, traj.t, traj.q, contacts)   # the drives give J^T f less
    derivatives = (traj.qd, traj.qdd) if args.derivatives else ()
    extras = [path for path in (args.truth, sidecar) if path is not None]
    if not extras:
        write_measurements_csv(args.output, traj.t, traj.q, tau, *derivatives)
    else:      # all or nothing: the truth and the contacts are written once the log is on disk, before its rename
        from .._support.files import atomic_write_text
        from ..formats.save import save

        def write_extras():
            if args.truth is not None:
                save(Manipulator(robot.links, convention=robot.convention, gravity=robot.gravity, name=robot.name,
                                 source=robot.source, sources=robot.sources, base=robot.base, tool=robot.tool,
                                 friction=robot.friction_model if args.static_friction is not None else None,
                                 description=f"the true arm that manipdyn synthesize --perturb --seed {args.seed} "
                                             f"drew around {args.model} (masses, centres of mass and friction off), "
                                             f"whose torques it logged to {args.output}" + synthesize_static.describe(args)), args.truth)
            if sidecar is not None:
                atomic_write_text(sidecar, json.dumps(
                    {"log": args.output, "contacts": [c.to_dict() for c in contacts],
                     "note": "forces the environment applies to the arm; the logged torque is the model's minus "
                             "J^T f"}, indent=2) + "\n")

        new = [path for path in extras if not os.path.lexists(path)]
        try:
            write_measurements_csv(args.output, traj.t, traj.q, tau, *derivatives, then=write_extras)
        except BaseException:
            for path in new:                     # the log's rename failed after the extras were written
                if os.path.lexists(path):
                    os.unlink(path)
            raise
    out = {"model": args.model, "robot": robot.name, "trajectory": args.trajectory, "output": args.output,
           "truth": args.truth, "contacts": sidecar,
           "samples": int(len(traj.t)), "noise": args.noise, "seed": args.seed,
           "static_friction": synthesize_static.report(args, robot),
           "peak_torque": [float(x) for x in abs(tau).max(axis=0)]}
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        print(f"wrote {args.output}: {out['samples']} samples of {robot.name!r} along {args.trajectory}, "
              f"torque noise {args.noise:g} of each joint's peak (seed {args.seed})"
              + (f"; the true arm written to {args.truth}" if args.truth else "")
              + (f"; {len(contacts)} contact(s), their truth in {sidecar}" if contacts else "")
              + (f"; static friction {args.static_friction:g} x Coulomb, Stribeck velocity {args.stribeck_velocity:g}"
                 if args.static_friction is not None else ""))
    return EXIT_OK


def register(sub) -> None:
    """Add ``manipdyn synthesize``."""
    p = sub.add_parser(
        "synthesize", help="synthesise a measurement log from a model (identification without a robot)",
        description="Compute the joint torques of MODEL along TRAJ.csv (as written by 'manipdyn excite'), "
                    "add seeded Gaussian noise of --noise times each joint's peak torque, and write "
                    "DATA.csv (t,q1..qn,tau1..taun) for 'manipdyn identify'. With --perturb the torques "
                    "are those of an arm around MODEL (masses +-20 %, centres of mass moved up to 2 cm, "
                    "friction added; seeded by --seed), so that identify has something to find. "
                    "Exit codes: 0 written, 2 usage, model or data error.")
    p.add_argument("model", metavar="MODEL",
                   help="bundled model name, .toml model file, .urdf file or erd:NAME (manipdyn models --erd)")
    p.add_argument("trajectory", metavar="TRAJ.csv", help="trajectory written by manipdyn excite")
    p.add_argument("-o", "--output", required=True, metavar="DATA.csv", help="CSV log to write")
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("--noise", type=float, default=0.01, metavar="FRACTION",
                   help="torque noise, standard deviation as a fraction of each joint's peak torque "
                        "(default 0.01)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the noise and of --perturb (default 0)")
    p.add_argument("--perturb", action="store_true",
                   help="log the demo's perturbed 'true' arm instead of MODEL itself (DH models only)")
    p.add_argument("--truth", default=None, metavar="FILE.toml",
                   help="with --perturb: also write the true arm it drew, as a model file (md.load and every "
                        "command read it), to check an identification against (default: not written)")
    p.add_argument("--derivatives", action="store_true",
                   help="also write qd and qdd (exact); by default identify derives them from q")
    p.add_argument("--contact", action="append", default=None, metavar="T0:T1:FX,FY,FZ[@LINK]",
                   help="a force in N (base frame) applied to the arm from T0 to T1 s of the file's time, at the "
                        "tool unless a link (1..n or its name) is named; the drives' logged torque lacks J^T f. "
                        "Repeatable; the truth goes to DATA.contacts.json beside the log")
    synthesize_static.add_options(p)
    p.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    p.set_defaults(func=run)
