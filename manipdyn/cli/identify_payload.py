"""``manipdyn identify MODEL DATA --payload [--payload-link NAME] [-o OUT.toml|OUT.urdf] [--json] [--report FILE.html]``.

Layer 7 (CLI, the top).

The payload carried by MODEL (taken as known: links, armature, friction), from
logged joint data: :func:`manipdyn.identification.identify_payload`.  Text output:
mass +- standard deviation (kg), centre of mass +- standard deviation (mm, payload
frame), inertia about the centre of mass (kg m^2), the parameters the data do not
determine, and notes; ``--json`` prints :meth:`PayloadResult.as_dict` (an infinite standard
deviation, a parameter the data do not excite, as null); ``-o`` writes
MODEL carrying the payload (:meth:`PayloadResult.arm_with_payload`, a DH model); ``--report``
writes the page of :mod:`manipdyn.identification.results.payload_html` (its tables hold the
numbers of ``--json``).

Exit codes: 0 payload identified (and written); 2 usage, model or data error.
"""

from __future__ import annotations

import json

import numpy as np

from .._support.errors import ModelError
from ..formats.save import save, write_urdf
from .common import EXIT_OK, load_arm, usage_error
from .logopts import log_options_from_args, model_joint_names

__all__ = ["run_payload", "format_payload"]

#: options of the full identification that mean nothing for a payload
_NOT_WITH_PAYLOAD = (("--method", "method", "consistent"), ("--friction", "friction", False),
                     ("--friction-terms", "friction_terms", None), ("--armature", "armature", False),
                     ("--mass-bound", "mass_bound", None), ("--com-bound", "com_bound", None),
                     ("--total-mass-bound", "total_mass_bound", None), ("--no-bounds", "no_bounds", False),
                     ("--prior-weight", "prior_weight", None), ("--base-json", "base_json", None),
                     ("--smoothing", "smoothing", None), ("--bootstrap", "bootstrap", 0),
                     ("--scheduler", "scheduler", None), ("--logs", "logs", None),
                     ("--identify-torque-constants", "identify_torque_constants", False))


def format_payload(res, name: str = "") -> str:
    """The readable summary of a :class:`PayloadResult`: mass, COM (mm), inertia, notes."""
    d = res.as_dict()
    com_mm, std_mm = 1e3 * np.asarray(d["com"]), 1e3 * np.asarray(d["com_std"])
    where = f"link {d['link']}" + (f" ({name})" if name else "")
    lines = [f"payload on {where} (solver {d['solver']}, condition number "
             f"{'infinite' if not np.isfinite(d['condition_number']) else format(d['condition_number'], '.4g')})",
             f"mass   {d['mass']:.4g} +- {d['mass_std']:.2g} kg",
             "COM    " + ", ".join(f"{a} = {c:.2f} +- {s:.2g}" for a, c, s in zip("xyz", com_mm, std_mm))
             + " mm (payload frame)",
             "inertia about the COM, payload-frame axes (kg m^2):"]
    for row in d["inertia"]:
        lines.append("  [" + "  ".join(f"{v:+.4e}" for v in row) + "]")
    lines.append("rms residual per joint (N m or N): " + ", ".join(f"{v:.3g}" for v in d["rms_residual"]))
    if d["poorly_determined"]:
        lines.append(f"poorly determined: {', '.join(d['poorly_determined'])}")
    for note in d["notes"]:
        lines.append(f"note: {note}")
    return "\n".join(lines)


def run_payload(args) -> int:
    """The ``--payload`` branch of ``manipdyn identify``."""
    from ..identification import identify_payload, read_log

    for opt, attr, default in _NOT_WITH_PAYLOAD:
        if getattr(args, attr, default) != default:
            return usage_error("identify", f"{opt}: not with --payload (the arm is taken as known)")
    if len(args.data) != 1:
        return usage_error("identify", f"--payload: expected one log, got {len(args.data)}")
    args.data = args.data[0]
    out = args.output
    if out is not None and not out.lower().endswith((".toml", ".urdf")):
        return usage_error("identify", f"-o: with --payload, expected a file name ending in .toml or .urdf "
                                       f"(the arm carrying the payload), got {out!r}")
    try:
        arm, _ = load_arm(args.model, args.tip)
        data = read_log(args.data, arm.n, transmission=arm.transmission,
                        **log_options_from_args(args, model_joint_names(arm)))
        res = identify_payload(arm, data.q, data.qd, data.qdd, data.tau, link=args.payload_link)
        carrying = res.arm_with_payload() if out is not None else None
    except ModelError as exc:
        return usage_error("identify", str(exc))
    if out is not None:
        try:
            (save if out.lower().endswith(".toml") else write_urdf)(carrying, out)
        except ConnectionError as exc:      # a scheduler that does not answer: not the output's fault
            return usage_error("identify", f"--scheduler: {exc}")
        except OSError as exc:
            return usage_error("identify", f"{exc.filename or out}: cannot write: {exc.strerror or exc}")
    report = getattr(args, "report", None)
    if report:
        from ..identification.results.payload_html import write_payload_report
        from .common import command_line

        try:
            write_payload_report(res, report, data=data, command=command_line(args), model=args.model)
        except OSError as exc:
            return usage_error("identify", f"--report {report}: cannot write: {exc.strerror or exc}")
    if args.json:
        rep = res.as_dict()
        rep.update({"model": args.model, "data": args.data, "output": out,
                    "data_notes": list(getattr(data, "notes", []))})
        print(json.dumps(_strict(rep), indent=2, allow_nan=False))
    else:
        for note in getattr(data, "notes", []):
            print(f"data: {note}")
        print(format_payload(res, args.payload_link or ""))
        if out is not None:
            print(f"wrote {out}")
        if report:
            print(f"wrote {report} (the report)")
    return EXIT_OK


def _strict(x):
    """``x`` with every non-finite float (an unexcited parameter's infinite standard deviation)
    as None: strict JSON has no Infinity."""
    if isinstance(x, dict):
        return {k: _strict(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_strict(v) for v in x]
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x
