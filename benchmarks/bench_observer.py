"""Benchmark of collision detection (issue 39) on the UR5 and the Panda at 1 kHz.

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m benchmarks.bench_observer [--arms ur5 panda]
        [--minutes 10] [--contacts 20] [--seed 0] [--rounds 15] [--velocity-cutoff HZ] [--qd-noise RAD_S]
        [--json FILE]

Two parts:

1. **Detection on synthetic logs.**  Per arm, three seeded multi-sine trajectories within the joint
   limits (up to about 1 rad/s), torques from the model with noise as ``synthesize`` adds it (1 % of each
   joint's peak torque, white):

   * a calibration run (``--minutes`` / 2, contact-free): the thresholds for 1 false event per hour
     (:func:`manipdyn.control.collision.calibrate_thresholds`);
   * a contact-free run of ``--minutes``: every event there is false;
   * a run with ``--contacts`` contacts at the tool, 0.3 s each, 4 s apart, magnitudes uniform in
     5..40 N, directions uniform on the sphere (base frame), torques ``tau_model - J^T f``.

   A contact is *detectable* when its external torque ``J^T f`` at onset reaches twice the threshold on
   some joint (the observer's first-order rise crosses one threshold in ``ln 2 / K``, 7 ms at K = 100);
   its ``detectable force`` is the magnitude at which that happens in its direction.  A contact is
   *found* by the first event whose onset lies in ``[t0 - 50 ms, t1]``; the delay is the event's
   detection time (the crossing has lasted ``min_duration``) minus ``t0``; the force error is
   ``|f_hat - f| / |f|`` of the event's tool force (``pinv(J^T) r`` over the event's plateau).
   Targets: every detectable contact found within 20 ms; 0 false events; force within 10 % for
   contacts of 20 N and more.
2. **The online observer's cost**: ``MomentumObserver.update`` against one ``arm.inverse_dynamics``
   call on the same state, interleaved rounds (:func:`benchmarks.timing.interleaved`), the median of
   per-round ratios and the ratio of the best rounds.  Target: <= 3.  Its answer is checked first
   against the offline observer on the contact run's first second.

``--velocity-cutoff HZ``: the observer's velocity filter (:mod:`manipdyn.control.collision.observer`; 0:
none; default: the library's).  ``--qd-noise RAD_S``: white noise of that standard deviation added to the
logged velocities (the synthetic velocity is otherwise exact, where a real arm's is not).

The BLAS/OpenMP pools are printed with the results.  Nothing is asserted about time.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings

import numpy as np

import manipdyn as md
from benchmarks.report import format_pools
from manipdyn.control.collision import MomentumObserver, calibrate_thresholds, momentum_residual, observe

from .timing import blas_config, interleaved, paired_ratio

RATE = 1000.0
TARGET_DELAY = 0.020
TARGET_FORCE = 0.10
TARGET_COST = 3.0


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


def multisine(arm, seconds: float, seed: int, rate: float = RATE):
    """``(t, q, qd, qdd)``: per joint a sum of 4 sines (0.05..0.5 Hz) about the middle of the joint's
    limits, amplitude within 40 % of the range and speeds up to about 1 rad/s."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * rate))) / rate
    lo, hi = np.asarray(arm.qlim, dtype=float).T if np.ndim(arm.qlim) == 2 else (-np.pi * np.ones(arm.n),
                                                                                np.pi * np.ones(arm.n))
    mid, half = (lo + hi) / 2, np.minimum((hi - lo) / 2, np.pi) * 0.4
    q, qd, qdd = (np.zeros((len(t), arm.n)) for _ in range(3))
    for j in range(arm.n):
        w = 2 * np.pi * rng.uniform(0.05, 0.5, 4)
        a = rng.uniform(0.2, 1.0, 4)
        a *= min(half[j] / a.sum(), 1.0 / float(np.sum(a * w)))       # range and speed <= ~1 rad/s
        ph = rng.uniform(0, 2 * np.pi, 4)
        arg = np.outer(t, w) + ph
        q[:, j] = mid[j] + np.sin(arg) @ a
        qd[:, j] = np.cos(arg) @ (a * w)
        qdd[:, j] = -np.sin(arg) @ (a * w * w)
    return t, q, qd, qdd


def _logs(arm, seconds, seed, contacts=(), qd_noise=0.0):
    """The runs of ``seconds`` (a list) as consecutive windows of one multi-sine trajectory, its torques
    synthesized once (``synthesize``'s noise: 1 % of each joint's peak over the whole trajectory, so every
    window has the same sensor noise); ``contacts`` ``(t0, t1, f)`` in the last window's time."""
    from manipdyn.identification.experiments.synthesize import Contact, contact_torques, synthesize

    t, q, qd, qdd = multisine(arm, sum(seconds), seed)
    tau = synthesize(arm, q, qd, qdd, noise=0.01, seed=seed)
    edges = np.concatenate([[0], np.cumsum([int(round(s * RATE)) for s in seconds])])
    if qd_noise:
        qd = qd + qd_noise * np.random.default_rng(seed + 7).standard_normal(qd.shape)
    out = []
    for a, b in zip(edges[:-1], edges[1:]):
        out.append({"t": t[a:b] - t[a], "q": q[a:b], "qd": qd[a:b], "qdd": qdd[a:b], "tau": tau[a:b].copy()})
    last = out[-1]
    cs = [Contact(t0, t1, tuple(f)) for t0, t1, f in contacts]
    last["tau"] -= contact_torques(arm, last["t"], last["q"], cs)
    return out


def detection(arm, minutes: float, n_contacts: int, seed: int, velocity_cutoff=None, qd_noise=0.0) -> dict:
    rng = np.random.default_rng(seed + 3)
    contacts = []
    for k in range(n_contacts):
        u = rng.standard_normal(3)
        f = rng.uniform(5, 40) * u / np.linalg.norm(u)
        t0 = 2.0 + 4.0 * k
        contacts.append((t0, t0 + 0.3, f))
    cal, free, push = _logs(arm, [30 * minutes, 60 * minutes, 4.0 + 4.0 * n_contacts], seed, contacts, qd_noise)
    thr = calibrate_thresholds(arm, cal, false_alarms=1.0, velocity_cutoff=velocity_cutoff)
    fc = thr.velocity_cutoff
    res_free = observe(arm, free, threshold=thr.threshold, wrench=False, direct=False, velocity_cutoff=fc)
    res = observe(arm, push, threshold=thr.threshold, direct=False, velocity_cutoff=fc)
    events = res.events
    rows, used = [], set()
    for t0, t1, f in contacts:
        k0 = int(round(t0 * RATE))
        tau_ext = arm.jacobian(push["q"][k0])[:3].T @ f
        ratio = np.max(np.abs(tau_ext) / thr.threshold)
        F = float(np.linalg.norm(f))
        f_det = 2.0 * F / ratio
        hit = next((i for i, e in enumerate(events) if i not in used and t0 - 0.05 <= e.onset <= t1), None)
        row = {"t0": t0, "force": [float(x) for x in f], "magnitude": F, "detectable_force": f_det,
               "detectable": bool(F >= f_det), "found": hit is not None}
        if hit is not None:
            used.add(hit)
            e = events[hit]
            row.update(delay=e.detected - t0, force_error=float(np.linalg.norm(e.wrench[:3] - f) / F),
                       point_force_error=float(np.linalg.norm(e.point_force - f) / F),
                       force_bound=float(np.linalg.norm(e.wrench_uncertainty[:3]) / F),
                       force_within_bound=bool(np.all(np.abs(e.wrench[:3] - f) <= e.wrench_uncertainty[:3])),
                       estimate=[float(x) for x in e.wrench[:3]], link=e.link)
        rows.append(row)
    extra = len(events) - len(used)
    return {"threshold": [float(x) for x in thr.threshold], "velocity_cutoff": fc, "calibration_minutes": 0.5 * minutes,
            "free_minutes": minutes, "false_events_free": len(res_free.events), "unmatched_events": extra,
            "contacts": rows}


def cost(arm, rounds: int, push, velocity_cutoff=None) -> dict:
    from manipdyn.control.collision.observer import DEFAULT_VELOCITY_CUTOFF

    fc = DEFAULT_VELOCITY_CUTOFF if velocity_cutoff is None else velocity_cutoff
    n = arm.n
    obs = MomentumObserver(arm, 1.0 / RATE, velocity_cutoff=fc)
    N = int(RATE)
    on = np.array([obs.update(push["q"][k], push["qd"][k], push["tau"][k]).copy() for k in range(N)])
    off = momentum_residual(arm, push["q"][:N], push["qd"][:N], push["tau"][:N], 1.0 / RATE, velocity_cutoff=fc)
    agree = float(np.max(np.abs(on - off)))
    q, qd, tau = (np.ascontiguousarray(push[k][N // 2]) for k in ("q", "qd", "tau"))
    qdd = np.ascontiguousarray(push["qdd"][N // 2])
    arm.inverse_dynamics(q, qd, qdd)
    s = interleaved({"update": lambda: obs.update(q, qd, tau), "id": lambda: arm.inverse_dynamics(q, qd, qdd)},
                    rounds, 0.02)
    best = float(np.min(s["update"].times) / np.min(s["id"].times))
    return {"n": n, "update_us": 1e6 * float(np.median(s["update"].times)),
            "inverse_dynamics_us": 1e6 * float(np.median(s["id"].times)),
            "ratio": paired_ratio(s["update"], s["id"]), "best": best, "online_vs_offline_max_nm": agree}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.bench_observer", description=__doc__.split("\n")[0])
    ap.add_argument("--arms", nargs="+", default=["ur5", "panda"])
    ap.add_argument("--minutes", type=float, default=10.0, help="contact-free minutes (default 10)")
    ap.add_argument("--contacts", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--velocity-cutoff", type=float, default=None, metavar="HZ",
                    help="the observer's velocity filter, Hz (0: none; default: the library's)")
    ap.add_argument("--qd-noise", type=float, default=0.0, metavar="RAD_S",
                    help="white noise added to the logged velocities, rad/s (default 0)")
    ap.add_argument("--json", default=None, metavar="FILE", help="also write the results as JSON")
    args = ap.parse_args(argv)
    pools = blas_config()
    print(f"BLAS/OpenMP pools: {format_pools(pools) or 'none loaded'}")
    out = {"blas": pools, "arms": {}}
    for name in args.arms:
        arm = _load(name)
        det = detection(arm, args.minutes, args.contacts, args.seed, args.velocity_cutoff, args.qd_noise)
        c = det["contacts"]
        push = _logs(arm, [2.0], args.seed + 5, [(0.5, 0.8, np.array([10.0, -10.0, 15.0]))])[0]
        cst = cost(arm, args.rounds, push, args.velocity_cutoff)
        out["arms"][name] = {"detection": det, "cost": cst}
        detectable = [x for x in c if x["detectable"]]
        found = [x for x in detectable if x["found"]]
        delays = [x["delay"] for x in found]
        big = [x for x in c if x["found"] and x["magnitude"] >= 20]
        print(f"\n{name}: thresholds (N m, 1 false event/h; velocity filter {det['velocity_cutoff']:g} Hz, 0: none) "
              + " ".join(f"{x:.3g}" for x in det["threshold"]))
        print(f"  {'t0 s':>6s} {'|f| N':>6s} {'det. N':>7s} {'found':>5s} {'delay ms':>8s} {'f err %':>7s} {'pt err %':>8s} {'f bound %':>9s} link")
        for x in c:
            print(f"  {x['t0']:6.1f} {x['magnitude']:6.1f} {x['detectable_force']:7.2f} {str(x['found']):>5s} "
                  + (f"{1e3 * x['delay']:8.1f} {100 * x['force_error']:7.1f} {100 * x['point_force_error']:8.1f} "
                     f"{100 * x['force_bound']:8.0f}{'' if x['force_within_bound'] else '!'} {x['link']}" if x["found"] else ""))
        print(f"  detectable contacts found {len(found)}/{len(detectable)}; delay max "
              f"{1e3 * max(delays, default=math.nan):.1f} ms (target <= {1e3 * TARGET_DELAY:g}); force error max for "
              f">= 20 N {100 * max((x['force_error'] for x in big), default=math.nan):.1f} % (point force "
              f"{100 * max((x['point_force_error'] for x in big), default=math.nan):.1f} %; target <= "
              f"{100 * TARGET_FORCE:g}); false events in {args.minutes:g} contact-free min: {det['false_events_free']}, "
              f"unmatched in the contact run: {det['unmatched_events']}; the wrench's force within its stated "
              f"uncertainty on {sum(x['force_within_bound'] for x in c if x['found'])}/{sum(x['found'] for x in c)} "
              f"contacts (! where not)")
        print(f"  MomentumObserver.update {cst['update_us']:.2f} us, arm.inverse_dynamics "
              f"{cst['inverse_dynamics_us']:.2f} us: ratio {cst['ratio']:.2f} (best rounds {cst['best']:.2f}; "
              f"target <= {TARGET_COST:g}); online vs offline observer max {cst['online_vs_offline_max_nm']:.2g} N m")
    if args.json:
        from .timing import write_atomic

        write_atomic(args.json, json.dumps(out, indent=2, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
