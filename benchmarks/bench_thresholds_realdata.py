"""Collision thresholds on the real arms against their published models (issue 39's real targets).

    python -m benchmarks.bench_thresholds_realdata [--arms lwr4 panda] [--gains 100 30] [--json FILE]

Every threshold is for 1 false event per hour, the observer's residual low-passed as the library's
default (20 Hz), and every model is judged by the same procedure:

* **identified**: ``manipdyn identify`` with the README's recommended options writes thresholds from its
  band's own hold-outs (held-out trajectories, else blocks); at another gain, ``observe --fit-data``
  replays them;
* **published**: the same observer with the published model, thresholds from ``--calibrate`` on the
  same fit data (the published model was not fitted on them);
* the held-out data are then watched: the target is 0 events.

Arms (``../shared/realdata``, or ``$MANIPDYN_REALDATA``; absent: said, and skipped):

* **lwr4**: fit on runs 2 and 3 (prior ``kuka_lwr4_gaz.urdf``), run 1 watched.  Published: Gaz's
  inertias (the URDF's rigid part) and FloBaRoID's identification with its viscous and Coulomb
  ``<dynamics>`` tags; one of its Coulomb coefficients is negative, which a friction law may not hold
  (``md.load`` refuses the file), so its friction is subtracted from the measured torque and the
  rigid part observes the rest: the observer is linear in the torque, so this is the same residual.
* **panda**: fit on 0 to 10 s of the log (the bundled model as prior), 10 to 21 s watched.  Published:
  the bundled ``panda`` (Gaz et al.'s parameters and friction).  libfranka's examples set 20, 20, 18,
  18, 16, 14 and 12 N m by hand: the ratio to them is printed too.

Ratios are identified over the better published model per joint; "pooled" is the sum of the
identified thresholds over the sum of the better published ones.  Nothing here is timed.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

from .realdata import lwr4_dir, panda_log

LIBFRANKA = np.array([20.0, 20.0, 18.0, 18.0, 16.0, 14.0, 12.0])
FRICTION = "viscous,coulomb,offset"


def _cli(*args) -> dict:
    """``python -m manipdyn ARGS`` (the command a user types; a benchmark never imports the CLI), its JSON."""
    res = subprocess.run([sys.executable, "-m", "manipdyn", *(str(a) for a in args)], capture_output=True,
                         text=True, check=False)
    if res.returncode not in (0, 1):          # 1: observe saw an event
        raise SystemExit(f"manipdyn {' '.join(map(str, args))}: exit {res.returncode}: {res.stderr[-2000:]}")
    return json.loads(res.stdout)


def _watch(model, logs, extra) -> dict:
    out = _cli("observe", model, *logs, "--json", *extra)
    return {"threshold": out["threshold"], "events": sum(len(x["events"]) for x in out["logs"]),
            "source": out["threshold_source"]}


def _flobaroid(lwr, fit_runs, gain) -> np.ndarray:
    """FloBaRoID's thresholds (module docstring: its friction taken off the torque, its rigid part observing)."""
    from manipdyn.control.collision import calibrate_thresholds
    from manipdyn.control.collision.reading import read_observed
    from manipdyn.formats.urdf.reader import load_urdf

    text = (lwr / "kuka_lwr4_identified.urdf").read_text()
    tags = [(float(a), float(b)) for a, b in re.findall(r'<dynamics damping="([^"]+)" friction="([^"]+)"', text)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rigid = load_urdf(re.sub(r"<dynamics[^>]*/>", "", text))
    damping, coulomb = (np.array(x) for x in zip(*tags))
    logs = []
    for run in fit_runs:
        (o,) = read_observed(rigid, str(lwr / run))
        logs.append({"t": o.t, "q": o.q, "qd": o.qd, "tau": o.tau - (damping * o.qd + coulomb * np.sign(o.qd))})
    return np.asarray(calibrate_thresholds(rigid, logs, gain=gain).threshold)


def lwr4(gains, work: Path) -> dict:
    lwr = lwr4_dir()
    fit = ["run2.csv", "run3.csv"]
    model = work / "lwr_id.toml"
    _cli("identify", lwr / "kuka_lwr4_gaz.urdf", *(lwr / r for r in fit), "--friction-terms", FRICTION,
         "-o", model, "--json", "--no-progress")
    out = {}
    for gain in gains:
        extra = [] if gain == 100 else ["--gain", gain, "--fit-data", *(lwr / r for r in fit)]
        ident = _watch(model, [lwr / "run1.csv"], extra)
        gaz = _watch(lwr / "kuka_lwr4_gaz.urdf", [lwr / "run1.csv"],
                     ["--gain", gain, "--calibrate", *(lwr / r for r in fit)])
        flo = _flobaroid(lwr, fit, gain)
        out[gain] = {"identified": ident, "published": {"gaz": gaz["threshold"], "flobaroid": flo.tolist()},
                     "published_events": {"gaz": gaz["events"]}}
    return out


def panda(gains, work: Path) -> dict:
    log = panda_log()
    model = work / "panda_id.toml"
    _cli("identify", "panda", log, "-o", model, "--t-range", "0:10", "--friction-terms", FRICTION, "--json",
         "--no-progress")
    out = {}
    for gain in gains:
        extra = ["--t-range", "10:21"] + ([] if gain == 100 else ["--gain", gain, "--fit-data", log])
        ident = _watch(model, [log], extra)
        pub = _watch("panda", [log], ["--t-range", "10:21", "--gain", gain, "--calibrate", log,
                                      "--calibrate-t-range", "0:10"])
        out[gain] = {"identified": ident, "published": {"panda": pub["threshold"]},
                     "published_events": {"panda": pub["events"]}}
    return out


def _print(name, res) -> None:
    for gain, r in res.items():
        ident = np.array(r["identified"]["threshold"])
        best = np.min(np.array(list(r["published"].values())), axis=0)
        print(f"\n{name}, gain {gain} 1/s: identified thresholds (N m) " + " ".join(f"{x:.3g}" for x in ident))
        for k, v in r["published"].items():
            print(f"  published {k:10s} " + " ".join(f"{x:.3g}" for x in v))
        print("  identified / better published " + " ".join(f"{x:.2f}" for x in ident / best)
              + f"; pooled {np.sum(ident) / np.sum(best):.2f}")
        if name == "panda":
            print("  libfranka's hand-set / identified " + " ".join(f"{x:.1f}" for x in LIBFRANKA / ident))
        print(f"  events on the held-out data: identified {r['identified']['events']}, published "
              + ", ".join(f"{k} {v}" for k, v in r["published_events"].items()))
        print(f"  identified thresholds from: {r['identified']['source']}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.bench_thresholds_realdata",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--arms", nargs="+", default=["lwr4", "panda"], choices=["lwr4", "panda"])
    ap.add_argument("--gains", nargs="+", type=float, default=[100.0, 30.0])
    ap.add_argument("--json", default=None, metavar="FILE", help="also write the results as JSON")
    args = ap.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory(prefix="manipdyn-thr-") as tmp:
        for name, fn, where in (("lwr4", lwr4, lwr4_dir()), ("panda", panda, panda_log())):
            if name not in args.arms:
                continue
            if not where.exists():
                print(f"{name}: skipped: {where} is absent (set MANIPDYN_REALDATA)", file=sys.stderr)
                continue
            gains = [int(g) if float(g).is_integer() else g for g in args.gains]
            results[name] = fn(gains, Path(tmp))
            _print(name, results[name])
    if args.json:
        from .timing import write_atomic

        write_atomic(args.json, json.dumps(results, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
