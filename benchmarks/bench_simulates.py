"""A model that simulates: replay and validate of the default identification against the published models.

    python -m benchmarks.bench_simulates [--case panda|lwr4_12|lwr4_23|all] [--weight W]

Each case runs the README's command (``friction_terms="viscous,coulomb,offset"``, nothing hand-set, so the
prior weight is chosen on the hold-outs by torque and acceleration error), then on data the fit never saw:

* ``replay``: the position error at 10, 50 and 200 ms, RMS over the start states, per joint and pooled, for
  the identified model, the published one and the constant-velocity guess;
* ``validate``: the torque RMS per joint (N m), the acceleration error per joint (rad/s^2, ``M^-1`` of the torque
  error on each model's own ``M``, as ``validate`` gives it) and the 95 % band's coverage.

Cases (the real logs beside the project, ``$MANIPDYN_REALDATA``; never copied into it):

* ``panda``: fit on 0 to 10 s of the Panda log, scored on 10 to 21 s, against the bundled ``panda``;
* ``lwr4_12``: the LWR4+ fit on runs 1 and 2, scored on run 3, against ``kuka_lwr4_gaz.urdf``;
* ``lwr4_23``: fit on runs 2 and 3, scored on run 1.

``--weight W`` fixes the prior weight instead (0: the data alone, today's former default).  CPU seconds of the
identification are printed; nothing here is checked by the tests' clocks.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.realdata import lwr4_dir, panda_log

CASES = ("panda", "lwr4_12", "lwr4_23")


def _case(name):
    """``(prior, fit_logs, fit_options, test_log, test_options, published)`` or None when the data are absent."""
    if name == "panda":
        log = panda_log()
        if not log.is_file():
            return None
        return "panda", [str(log)], {"t_range": (0, 10)}, str(log), {"t_range": (10, 21)}, "panda"
    d = lwr4_dir()
    urdf = d / "kuka_lwr4_gaz.urdf"
    runs = {k: d / f"run{k}.csv" for k in (1, 2, 3)}
    if not urdf.is_file() or not all(r.is_file() for r in runs.values()):
        return None
    fit, test = ((1, 2), 3) if name == "lwr4_12" else ((2, 3), 1)
    return str(urdf), [str(runs[k]) for k in fit], {}, str(runs[test]), {}, str(urdf)


def run_case(name, weight=None, out=print) -> dict | None:
    import manipdyn as md
    from manipdyn.identification import identify, read_log
    from manipdyn.identification.results.validation import validate

    case = _case(name)
    if case is None:
        out(f"{name}: skipped, the real logs are not where benchmarks/realdata.py looks ($MANIPDYN_REALDATA)")
        return None
    prior, fit_logs, fit_opts, test_log, test_opts, published = case
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / f"{name}_id.toml")
        cpu = time.process_time()
        r = identify(prior, fit_logs, friction_terms="viscous,coulomb,offset", prior_weight=weight, output=path,
                     **fit_opts)
        cpu = time.process_time() - cpu
        w = r.provenance["options"].get("prior_weight", 0.0)
        out(f"{name}: identify {cpu:.1f} s CPU, prior weight {w:g} ({'given' if weight is not None else 'chosen'})")
        rp = md.replay([path, published], test_log, **test_opts)
        for h in range(len(rp.horizons)):
            out(f"  q error at {1e3 * rp.horizons[h]:g} ms (rad): "
                + "; ".join(f"{lab} " + " ".join(f"{x:.3g}" for x in rp.q_rms[lab][h])
                            + f" pooled {rp.pooled(lab)[h]:.3g}" for lab in rp.labels))
        data = read_log(test_log, md.load(published).n, **test_opts)
        ident, pub = md.load(path), md.load(published)
        for lab, model in (("identified", ident), ("published", pub)):
            v = validate(model, data)
            a = v.accel_rms                        # validate's acceleration error, on the model's own D
            cover = v.coverage if lab == "identified" else None
            out(f"  {lab}: torque RMS " + " ".join(f"{x:.3g}" for x in v.rms) + " N m; acceleration error "
                + " ".join(f"{x:.3g}" for x in a) + " rad/s^2"
                + (f"; band {100 * float(np.mean(cover)):.1f} %" if cover is not None else ""))
    return {"weight": w, "cpu": cpu}


def main(argv=None) -> int:
    import warnings

    warnings.simplefilter("ignore")        # the published LWR4 URDF's bodies: identify's notes say it once
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--case", default="all", choices=CASES + ("all",))
    p.add_argument("--weight", type=float, default=None, help="a fixed prior weight (default: chosen)")
    args = p.parse_args(argv)
    for name in (CASES if args.case == "all" else (args.case,)):
        run_case(name, args.weight)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
