"""``manipdyn identify MODEL DATA.csv -o OUT.toml|OUT.urdf``: identify an arm's parameters.

Layer: CLI.

MODEL gives the kinematics and the prior; DATA.csv has ``t,q1..qn,tau1..taun``
and optionally ``qd*``, ``qdd*`` (otherwise derived from q by zero-phase
filtering, :mod:`manipdyn.identification.data`).  The written model loads
with ``md.load`` and passes ``manipdyn check``.

Exit codes: 0 written; 1 the identified parameters cannot be written as a
model (e.g. a negative mass from ``ols``: use ``--method consistent``);
2 usage, model or data error (one line on stderr).
"""

from __future__ import annotations

import json
import os

from ..errors import ModelError
from ..io import save, write_urdf
from ..loading import load_with_notes
from .common import EXIT_DISAGREE as EXIT_FAILED
from .common import EXIT_OK, usage_error

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add ``manipdyn identify`` to the command line."""
    from ..identification import METHODS

    p = subparsers.add_parser(
        "identify", help="identify inertial parameters from joint data",
        description="Identify the arm's base parameters from logged joint positions and torques "
                    "and write the model whose full parameters reproduce them, closest to the prior. "
                    "Exit codes: 0 written, 1 the result cannot be written as a model, "
                    "2 usage, model or data error.")
    p.add_argument("model", metavar="MODEL", help="prior: bundled model name or .toml model file (DH arm)")
    p.add_argument("data", metavar="DATA.csv", help="header t,q1..qn,tau1..taun (optionally qd*, qdd*)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.toml|OUT.urdf", help="model file to write")
    p.add_argument("--method", choices=METHODS, default="consistent",
                   help="ols, wls (weighted by per-joint noise), consistent (J_i >= 0; default)")
    p.add_argument("--friction", action="store_true", help="identify viscous and Coulomb friction")
    p.add_argument("--armature", action="store_true", help="identify armature (reflected rotor inertia)")
    p.add_argument("--mass-bound", type=float, default=None, metavar="FRAC",
                   help="consistent only: each link's mass within +-FRAC of the prior's (e.g. 0.3)")
    p.add_argument("--com-bound", type=float, default=None, metavar="M",
                   help="consistent only: each COM within +-M metres of the prior's, per axis")
    p.add_argument("--cutoff", type=float, default=None, metavar="HZ",
                   help="low-pass cut-off when qd/qdd are derived from q (default 5 Hz)")
    p.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    p.set_defaults(func=run)



def run(args) -> int:
    from ..arm import Manipulator
    from ..identification import Bounds, fit, format_report, read_measurements

    out = args.output
    if not out.lower().endswith((".toml", ".urdf")):
        return usage_error("identify", f"-o: expected a file name ending in .toml or .urdf, got {out!r}")
    bounds = None
    if args.mass_bound is not None or args.com_bound is not None:
        if args.method != "consistent":
            return usage_error("identify", "--mass-bound/--com-bound: only with --method consistent")
        for opt, v in (("--mass-bound", args.mass_bound), ("--com-bound", args.com_bound)):
            if v is not None and not (0 <= v < float("inf")):
                return usage_error("identify", f"{opt}: expected a finite number >= 0, got {v}")
    try:
        arm, _ = load_with_notes(args.model)
        if not isinstance(arm, Manipulator):
            raise ModelError(f"MODEL {args.model}: identify writes a DH model; give a bundled model "
                             "name or a .toml model file as the prior (URDF priors are not supported)")
        if args.mass_bound is not None or args.com_bound is not None:
            b = Bounds.around(arm, mass=args.mass_bound or 0.0, com=args.com_bound or 0.0)
            bounds = Bounds(mass=None if args.mass_bound is None else b.mass,
                            com=None if args.com_bound is None else b.com)
        data = read_measurements(args.data, arm.n, cutoff=args.cutoff)
        name = os.path.splitext(os.path.basename(out))[0] or arm.name
        result = fit(arm, data.q, data.qd, data.qdd, data.tau, method=args.method,
                     friction=args.friction, armature=args.armature, bounds=bounds, name=name)
    except ModelError as exc:
        return usage_error("identify", str(exc))
    rep = dict(result.report)
    rep.update({"model": args.model, "data": args.data, "output": None,
                "derived_derivatives": data.derived})
    code = EXIT_OK
    if result.arm is None:
        code = EXIT_FAILED
    else:
        try:
            if out.lower().endswith(".toml"):
                save(result.arm, out)
            else:
                write_urdf(result.arm, out)
            rep["output"] = out
        except OSError as exc:
            return usage_error("identify", f"{out}: cannot write: {exc.strerror or exc}")
    if args.json:
        print(json.dumps(rep, indent=2))
    else:
        print(format_report(rep))
        if rep["output"]:
            print(f"wrote {out}")
    if code == EXIT_FAILED:
        import sys

        print(f"manipdyn identify: the {args.method} parameters are not a physical arm, nothing written: "
              f"{result.arm_error}; --method consistent always gives one", file=sys.stderr)
    return code
