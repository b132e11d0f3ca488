"""``manipdyn identify MODEL DATA -o OUT.toml|OUT.urdf|OUT.json``: identify an arm's parameters.

``--payload [--payload-link NAME]``: identify a payload carried by MODEL instead
(:mod:`.identify_payload`).

Layer 7 (CLI, the top).

MODEL gives the kinematics and the prior; DATA has ``t,q1..qn,tau1..taun`` and
optionally ``qd*``, ``qdd*`` (otherwise derived from q by zero-phase filtering,
:mod:`manipdyn.formats.logs.data`).  The written model loads with ``md.load``
and passes ``manipdyn check``; it says where it came from (data file and its sha256,
method, options, date, prior, residuals: :mod:`manipdyn.identification.provenance`).

``--method consistent`` (the default) stays plausible around the prior unless told
otherwise: link masses within +-50 % of the prior's (``--mass-bound``), centres of
mass within 0.1 m of the prior's (``--com-bound``), total mass within 25 %
(``--total-mass-bound``); ``--no-bounds`` drops them.  Active bounds are reported.

When the identified parameters are no physical arm (``ols``/``wls`` on weak data),
the base parameters with their standard deviations are written to a JSON base model
(``OUT.base.json`` beside ``-o``, or ``-o OUT.json`` to ask for it), which
``manipdyn validate`` scores.

Exit codes: 0 a model written; 1 only the base model could be written (the parameters
are no physical arm); 2 usage, model or data error (one line on stderr).
"""

from __future__ import annotations

import json

import numpy as np
import os
import sys

from .._support.errors import ModelError
from ..model.friction import Friction
from ..formats.save import save, write_urdf
from .common import EXIT_DISAGREE as EXIT_FAILED
from .logopts import DATA_HELP, log_options_from_args, model_joint_names, register_log_options
from .common import EXIT_OK, TIP_HELP, load_arm, usage_error

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add ``manipdyn identify`` to the command line."""
    from ..identification import METHODS

    p = subparsers.add_parser(
        "identify", help="identify inertial parameters from joint data",
        description="Identify the arm's base parameters from logged joint positions and torques "
                    "and write the model whose full parameters reproduce them, closest to the prior. "
                    "Exit codes: 0 model written, 1 only a base model (JSON) written because the "
                    "parameters are no physical arm, 2 usage, model or data error.")
    p.add_argument("model", metavar="MODEL",
                   help="prior: bundled model name, .toml model file (DH arm) or URDF (written back as "
                        "the same URDF with the chain links' <inertial> identified: -o OUT.urdf)")
    p.add_argument("data", metavar="DATA", help=DATA_HELP)
    p.add_argument("-o", "--output", default=None, metavar="OUT.toml|OUT.urdf|OUT.json",
                   help="model file to write (.json: the base model only); required unless --payload")
    p.add_argument("--method", choices=METHODS, default=None,
                   help="ols, wls (weighted by per-joint noise), consistent (J_i >= 0; default)")
    p.add_argument("--payload", action="store_true",
                   help="identify only a rigid payload carried by MODEL (taken as known): its mass, "
                        "centre of mass and inertia with standard deviations; -o writes MODEL "
                        "carrying it (.toml or .urdf)")
    p.add_argument("--payload-link", metavar="NAME", default=None,
                   help="with --payload: the link carrying it, payload frame at that link's frame "
                        "(default: the last link, payload frame at the tool frame)")
    p.add_argument("--tip", default=None, metavar="LINK", help=TIP_HELP)
    p.add_argument("--friction", action="store_true", help="identify viscous and Coulomb friction")
    p.add_argument("--friction-terms", metavar="T1,T2", default=None,
                   help="identify these friction terms instead: some of viscous, coulomb, asymmetric "
                        "(separate + and - Coulomb levels), offset (constant torque per joint), stribeck, "
                        "sigmoid (Gaz et al.'s; the nonlinear shapes of these two are fitted by variable "
                        "projection, manipdyn.identification.varpro)")
    p.add_argument("--friction-side", choices=("joint", "motor"), default=None,
                   help="with --friction(-terms): the law acts on the joint or the motor velocities (default: "
                        "motor when the torques were logged at the motors and the [transmission] couples "
                        "joints, else joint; manipdyn.identification.choices)")
    p.add_argument("--smoothing", type=float, default=None, metavar="V",
                   help="with --friction-terms: Coulomb sign smoothed as tanh(v / V) (default: the velocity's "
                        "noise level measured on the log, said in the notes; 0 = sharp sign)")
    p.add_argument("--stribeck-velocity", type=float, default=None, metavar="V",
                   help="with --friction-terms ...,stribeck: the Stribeck velocity the search starts from, "
                        "rad/s on the law's side (default 0.1 rad/s at the joint: 0.1 |R_kk| at motor k)")
    p.add_argument("--sigmoid-alpha", type=float, default=None, metavar="A",
                   help="with --friction-terms ...,sigmoid: the steepness the search starts from, s/rad "
                        "on the law's side (default 10 s/rad at the joint: 10 / |R_kk| at motor k); "
                        "the shift starts at 0")
    p.add_argument("--armature", action="store_true", help="identify armature (reflected rotor inertia)")
    p.add_argument("--mass-bound", type=float, default=None, metavar="F",
                   help="consistent: each link's mass within +-F (fraction) of the prior's (default 0.5)")
    p.add_argument("--com-bound", type=float, default=None, metavar="M",
                   help="consistent: each COM within +-M metres of the prior's, per axis (default 0.1)")
    p.add_argument("--total-mass-bound", type=float, default=None, metavar="F",
                   help="consistent: total mass within +-F (fraction) of the prior's (default 0.25)")
    p.add_argument("--no-bounds", action="store_true",
                   help="consistent: no plausibility bounds, only J_i >= 0")
    p.add_argument("--prior-weight", default="0", metavar="W|auto",
                   help="consistent: weight of the entropic pull of each body towards the prior's "
                        "(0, the default: the data alone; auto: chosen by 5-fold blocked cross-validation "
                        "inside the data, manipdyn.identification.selection)")
    p.add_argument("--bootstrap", type=int, default=0, metavar="N",
                   help="also refit on N block-resampled copies of the data (blocks in time) and report "
                        "the spread of each base parameter")
    p.add_argument("--scheduler", default=None, metavar="ADDR",
                   help="--bootstrap on Dask: 'local' (a cluster of this machine's cores) or "
                        "tcp://HOST:PORT; default: in this process (same numbers either way)")
    p.add_argument("--base-json", metavar="FILE.json", default=None,
                   help="also write the base model (base parameters, standard deviations) here")
    p.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    register_log_options(p)
    p.set_defaults(func=run)


def _bounds(args, arm):
    from ..identification import Bounds
    from ..identification.sdp import PLAUSIBLE_COM, PLAUSIBLE_MASS, PLAUSIBLE_TOTAL

    given = [o for o, v in (("--mass-bound", args.mass_bound), ("--com-bound", args.com_bound),
                            ("--total-mass-bound", args.total_mass_bound)) if v is not None]
    if args.method != "consistent":
        if given or args.no_bounds:
            raise ModelError(f"{(given or ['--no-bounds'])[0]}: only with --method consistent")
        return None
    if args.no_bounds:
        if given:
            raise ModelError(f"{given[0]}: not with --no-bounds")
        return None
    from .._support import limits

    for opt, v, top in (("--mass-bound", args.mass_bound, 1e6), ("--com-bound", args.com_bound, limits.MAX_LENGTH)):
        if v is not None and not (0 <= v <= top):
            raise ModelError(f"{opt}: expected a number in [0, {top:g}], got {v}")
    if args.total_mass_bound is not None and not 0 <= args.total_mass_bound < 1:
        raise ModelError(f"--total-mass-bound: expected a fraction in [0, 1), got {args.total_mass_bound}")
    return Bounds.plausible(
        arm, mass=PLAUSIBLE_MASS if args.mass_bound is None else args.mass_bound,
        com=PLAUSIBLE_COM if args.com_bound is None else args.com_bound,
        total=PLAUSIBLE_TOTAL if args.total_mass_bound is None else args.total_mass_bound)


#: where variable projection starts the shapes, at the joint (motor k: scaled by |R_kk|)
START_STRIBECK_VELOCITY = 0.1   # rad/s
START_SIGMOID_ALPHA = 10.0      # s/rad
SHAPED = ("stribeck", "sigmoid")


def _friction(args, arm):
    """``--friction`` (True), a FrictionTerms from ``--friction-terms``/``--friction-side``/``--smoothing``,
    or, with a Stribeck or sigmoid term, a Friction holding the shapes' starting values."""
    from ..model.friction import DEFAULT_SMOOTHING, FRICTION_TERMS, FrictionTerms

    shape_opts = [o for o, v in (("--stribeck-velocity", args.stribeck_velocity),
                                 ("--sigmoid-alpha", args.sigmoid_alpha)) if v is not None]
    if args.friction_terms is None:
        if args.smoothing is not None or shape_opts:
            raise ModelError(f"{(shape_opts or ['--smoothing'])[0]}: only with --friction-terms")
        if args.friction_side is not None and not args.friction:
            raise ModelError("--friction-side: only with --friction or --friction-terms")
        if args.friction and args.friction_side == "motor":     # viscous + sharp Coulomb at the motors
            return FrictionTerms(("viscous", "coulomb"), side="motor", smoothing=0.0)
        return bool(args.friction)
    if args.friction:
        raise ModelError("--friction-terms: give either --friction (viscous + sharp Coulomb) or --friction-terms")
    v = DEFAULT_SMOOTHING if args.smoothing is None else args.smoothing
    if not 0 <= v < float("inf"):
        raise ModelError(f"--smoothing: expected a finite velocity >= 0, got {v}")
    terms = tuple(t.strip() for t in args.friction_terms.split(","))
    bad = [t for t in terms if t not in FRICTION_TERMS]
    if not terms or bad:
        raise ModelError(f"--friction-terms: unknown term(s) {bad or [args.friction_terms]}; expected some of "
                         f"{', '.join(FRICTION_TERMS)}, separated by commas")
    twice = sorted({t for t in terms if terms.count(t) > 1})
    if twice:
        raise ModelError(f"--friction-terms: {', '.join(twice)} given twice")
    shaped = [t for t in terms if t in SHAPED]
    for opt, term in (("--stribeck-velocity", "stribeck"), ("--sigmoid-alpha", "sigmoid")):
        if opt in shape_opts and term not in shaped:
            raise ModelError(f"{opt}: only with a {term} term in --friction-terms")
    linear = FrictionTerms(tuple(t for t in terms if t not in SHAPED), side=args.friction_side or "joint",
                           smoothing=v)
    if not shaped:
        return linear
    for opt, x in (("--stribeck-velocity", args.stribeck_velocity), ("--sigmoid-alpha", args.sigmoid_alpha)):
        if x is not None and not 0 < x < float("inf"):
            raise ModelError(f"{opt}: expected a finite number > 0, got {x}")
    scale = np.ones(arm.n)
    if args.friction_side == "motor":
        scale = np.abs(np.diag(np.asarray(arm.transmission.R, dtype=np.float64)))
    shapes = {}
    if "stribeck" in shaped:
        vs = args.stribeck_velocity
        shapes["stribeck_velocity"] = np.full(arm.n, vs) if vs is not None else START_STRIBECK_VELOCITY * scale
    if "sigmoid" in shaped:
        a = args.sigmoid_alpha
        shapes["sigmoid_alpha"] = np.full(arm.n, a) if a is not None else START_SIGMOID_ALPHA / scale
    return linear.as_friction(arm.n, **shapes)


def _check_limits(data, arm, deg: bool) -> None:
    """Refuse positions far outside the model's joint limits (degrees read as radians, another
    model's zero): over 5 % of the samples beyond a limit by more than 10 % of the joint's range."""
    lim = np.asarray(arm.qlim, dtype=np.float64)
    span = lim[:, 1] - lim[:, 0]
    out = (data.q < lim[:, 0] - 0.1 * span) | (data.q > lim[:, 1] + 0.1 * span)
    frac = out.mean(axis=0)
    bad = np.flatnonzero(frac > 0.05)
    if bad.size:
        j = int(bad[0])
        hint = "" if deg else "; positions in degrees? add --deg"
        raise ModelError(f"q{j + 1}: {100 * frac[j]:.0f} % of the samples lie outside the model's joint limits "
                         f"[{lim[j, 0]:g}, {lim[j, 1]:g}] rad (by more than 10 % of the range){hint}")


def _options(args) -> dict:
    keys = ("method", "friction", "friction_terms", "friction_side", "smoothing", "stribeck_velocity",
            "sigmoid_alpha", "armature", "mass_bound", "com_bound", "total_mass_bound", "no_bounds",
            "prior_weight", "bootstrap", "scheduler", "cutoff", "columns", "deg", "rate", "time_scale", "resample", "no_decimate",
            "t_range", "topic", "joint_names", "extra_joints")
    return {k: getattr(args, k) for k in keys if getattr(args, k, None) not in (None, False)}


def run(args) -> int:
    from .preflight import check_identify

    try:
        check_identify(args)        # outputs and unbounded options, before any work
    except ModelError as exc:
        return usage_error("identify", str(exc))
    if args.payload:
        from .identify_payload import run_payload

        return run_payload(args)
    if args.payload_link is not None:
        return usage_error("identify", "--payload-link: only with --payload")
    if args.output is None:
        return usage_error("identify", "-o/--output: required (the model file to write), unless --payload")
    if args.method is None:
        args.method = "consistent"
    from .._support.files import atomic_write_text
    from ..model.arm import Manipulator, URDFArm
    from ..identification import fit, format_report, read_log
    from ..identification.basemodel import prior_text, write_base_model
    from ..identification.provenance import model_metadata, provenance

    out = args.output
    if not out.lower().endswith((".toml", ".urdf", ".json")):
        return usage_error("identify", f"-o: expected a file name ending in .toml, .urdf or .json, got {out!r}")
    if args.prior_weight != "auto":
        try:
            args.prior_weight = float(args.prior_weight)
        except ValueError:
            return usage_error("identify", f"--prior-weight: expected a number >= 0 or 'auto', got {args.prior_weight!r}")
        if not (0 <= args.prior_weight < float("inf")):
            return usage_error("identify", f"--prior-weight: expected a finite number >= 0, got {args.prior_weight}")
    if args.bootstrap and args.bootstrap < 2:
        return usage_error("identify", f"--bootstrap: expected at least 2 replicates (0: none), got {args.bootstrap}")
    if args.scheduler is not None and not args.bootstrap:
        return usage_error("identify", "--scheduler: only with --bootstrap N")
    if args.prior_weight and args.method != "consistent":
        return usage_error("identify", "--prior-weight: only with --method consistent")
    try:
        arm, _ = load_arm(args.model, args.tip)
        bounds = _bounds(args, arm)
        friction = _friction(args, arm)
        if isinstance(arm, URDFArm):
            # a URDF prior is written back as the same URDF with new <inertial>s
            if out.lower().endswith(".toml"):
                raise ModelError(f"-o {out}: a URDF prior ({args.model}) is written back as URDF: "
                                 "-o OUT.urdf (or OUT.json for the base model)")
            base_only = out.lower().endswith(".json")      # no URDF is written: the base model holds them
            if args.armature and not base_only:
                raise ModelError("--armature: a URDF has no rotor inertia; identify a URDF prior without it "
                                 "(or write only the base model, -o OUT.json)")
            if args.friction_terms is not None and not base_only:
                raise ModelError("--friction-terms: a URDF's <dynamics> holds viscous and Coulomb friction "
                                 "only; use --friction (or write only the base model, -o OUT.json)")
        elif not isinstance(arm, Manipulator) and not out.lower().endswith(".json"):
            raise ModelError(f"MODEL {args.model}: identify writes a DH model or a URDF; give a bundled "
                             "model name, a .toml model file or a URDF as the prior")
        data = read_log(args.data, arm.n, transmission=arm.transmission,
                        **log_options_from_args(args, model_joint_names(arm)))
        _check_limits(data, arm, args.deg)
        law_notes = []
        if args.friction or args.friction_terms is not None:   # the side and smoothing not given: from the log
            from ..identification.choices import choose_friction_options

            args.friction_side, args.smoothing, law_notes = choose_friction_options(
                arm.transmission, data, args.friction_side, args.smoothing, smoothed=args.friction_terms is not None)
            friction = _friction(args, arm)
        shapes = None
        if isinstance(friction, Friction) and set(friction.terms) & set(SHAPED):
            # the shapes first (a wls search, varpro's module docstring), then every fit holds them
            from ..identification.varpro import fit_shapes

            friction, shapes = fit_shapes(arm, data, friction, armature=args.armature)
        name = os.path.splitext(os.path.basename(out))[0] or arm.name
        if name.endswith(".base"):
            name = name[:-5]
        selection = None
        if args.prior_weight == "auto":
            from ..identification.selection import choose_prior_weight

            args.prior_weight, selection = choose_prior_weight(
                arm, data.q, data.qd, data.qdd, data.tau, friction=friction, armature=args.armature,
                bounds=bounds)
        opts = _options(args)
        # the provenance's residuals are only known after the fit: fit once, then attach them
        result = fit(arm, data.q, data.qd, data.qdd, data.tau, method=args.method,
                     friction=friction, armature=args.armature, bounds=bounds, name=name,
                     prior_weight=args.prior_weight)
        prov = provenance(args.data, args.method, opts, args.model, result.report["rms_residual"],
                          sha256=getattr(data, "source_sha256", None))   # read_log hashed the bytes it read
        if result.arm is not None:
            from ..identification.model import arm_with_parameters

            result.arm = arm_with_parameters(arm, result.parameters, armature=args.armature,
                                             friction=friction, name=name,
                                             metadata=model_metadata(prov))
        boot = None
        if args.bootstrap:
            from ..identification.bootstrap import bootstrap

            bs = bootstrap(arm, data, args.bootstrap, scheduler=args.scheduler, method=args.method,
                           friction=friction, armature=args.armature, bounds=bounds,
                           prior_weight=args.prior_weight)
            from ..identification.bootstrap import bootstrap_summary

            boot = bootstrap_summary(bs)
    except ModelError as exc:
        return usage_error("identify", str(exc))
    rep = dict(result.report)
    rep["fit_notes"] = law_notes + list(rep.get("fit_notes", []))
    if args.friction_side == "motor" and np.array_equal(np.asarray(arm.transmission.R), np.eye(arm.n)):
        rep["fit_notes"] = list(rep.get("fit_notes", [])) + [
            "--friction-side motor: the model has no transmission (R = I, no gear ratios), so the motor "
            "side is the joint side; give the model a [transmission] for motor-side friction"]
    if selection is not None:
        rep["prior_weight_selection"] = selection
    if boot is not None:
        rep["bootstrap"] = {k: v for k, v in boot.items() if k != "covariance"}   # in the base model
    if shapes is not None:
        rep["friction_shapes"] = shapes
    rep.update({"model": args.model, "data": args.data, "output": None, "base_model": None,
                "derived_derivatives": data.derived, "provenance": prov,
                "data_notes": list(getattr(data, "notes", []))})
    code = EXIT_OK
    want_base = out.lower().endswith(".json")
    base_path = out if want_base else args.base_json
    try:
        if not want_base and result.arm is not None:
            if isinstance(result.arm, URDFArm):
                atomic_write_text(out, result.arm.urdf_text)
            elif out.lower().endswith(".toml"):
                save(result.arm, out)
            else:
                write_urdf(result.arm, out)
            rep["output"] = out
        elif not want_base:
            code = EXIT_FAILED
            base_path = base_path or os.path.splitext(out)[0] + ".base.json"
        if base_path:
            write_base_model(base_path, result, prior_text(arm), prov, bootstrap=boot)
            rep["base_model"] = base_path
    except OSError as exc:
        return usage_error("identify", f"{exc.filename or out}: cannot write: {exc.strerror or exc}")
    if args.json:
        print(json.dumps(rep, indent=2, allow_nan=False, default=str))
    else:
        for note in rep["data_notes"]:
            print(f"data: {note}")
        print(format_report(rep))
        for note in rep.get("fit_notes", []):
            print(f"note: {note}")
        if rep.get("active_bounds"):
            print("active bounds (the fit sits on them; --no-bounds or wider bounds to free it):")
            for b in rep["active_bounds"]:
                print(f"  {b}")
        if selection is not None:
            print("prior weight by 5-fold blocked cross-validation (score: mean log RMS over the joints of the "
                  "held-out blocks, lower is better): " + ", ".join(
                f"{row['prior_weight']:g} (score {row['score']:.4f})" for row in selection)
                  + f" -> {args.prior_weight:g}")
        if shapes is not None:
            print("friction shapes by variable projection (" + ("converged" if shapes["converged"] else
                  "NOT converged: " + shapes["message"]) + f", {shapes['evaluations']} evaluations): "
                  + "; ".join(f"{k} " + " ".join(f"{x:.4g}" for x in v) for k, v in shapes["fitted"].items()))
            if shapes["at_bound"]:
                print(f"  at the search's bound (not determined by the data?): {', '.join(shapes['at_bound'])}")
            if shapes.get("undetermined"):
                print(f"  not determined by the data (the residual does not change with them over the log's "
                      f"speeds; another start?): {', '.join(shapes['undetermined'])}")
        if boot is not None:
            from ..identification.bootstrap import format_bootstrap

            print(format_bootstrap(boot, rep["base_parameters"]))
        if rep["output"]:
            print(f"wrote {out}")
        if rep["base_model"]:
            print(f"wrote {rep['base_model']} (base model: {rep['n_base']} base parameters with their "
                  f"standard deviations; score it with manipdyn validate)")
    if code == EXIT_FAILED:
        print(f"manipdyn identify: the {args.method} parameters are not a physical arm, so no model file "
              f"was written, only the base model {base_path}: {result.arm_error or 'a J_i is not >= 0'}; "
              f"--method consistent always gives a physical arm", file=sys.stderr)
    return code
