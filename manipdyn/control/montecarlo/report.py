"""The result of a study: per-run records aggregated in run order.

Layer 6 (control: montecarlo).

Everything but the ``"timing"`` entry is a function of the per-run records
taken in run order (and, within a run, in the study's controller order), so
the report is bit-identical however the runs were chunked and wherever they
ran.  Statistics are over the runs that did not diverge (a diverged run has
no meaningful error distribution); the diverged ones are counted.
"""

from __future__ import annotations

import json

import numpy as np

from ..._support.jsonsafe import finite_or_null
from ..stiffness import SAMPLED_LIMIT
from .diverged import CAUSES
from .distributions import effect_on_arm
from .identified import plant_source

__all__ = ["StudyReport", "METRICS", "PERCENTILES"]

#: per-run figures: name -> (description, unit)
METRICS = {
    "rms_error": ("RMS over time of the norm of the error vector (all joints)", "rad"),
    "max_error": ("largest error of one joint", "rad"),
    "peak_torque": ("largest torque of one joint", "N m"),
}
PERCENTILES = (50, 90, 99)
#: worst runs listed per controller
WORST = 3
#: diverged runs whose story the text report tells (all are in the JSON and the HTML page)
SHOWN = 10


def _stats(values) -> dict:
    if not values:
        return {f"p{p}": None for p in PERCENTILES} | {"max": None}
    v = np.array(values, dtype=np.float64)
    ps = np.percentile(v, PERCENTILES)
    return {f"p{p}": float(x) for p, x in zip(PERCENTILES, ps)} | {"max": float(v.max())}


class StudyReport:
    """Per-controller distributions, counts and worst runs; the per-run records.

    Attributes
    ----------
    study : Study
    per_run : list of dict
        One record per (run, controller), in run order then controller order:
        ``run, controller, rms_error, max_error, peak_torque, diverged, saturated,
        substeps, integrator, sampled_loop, cause, why`` (errors in rad, or m for prismatic joints; torque in
        N m or N; the figures of a diverged run cover the samples before it diverged; ``substeps``
        the integrator's steps per control period its plant needed,
        :mod:`manipdyn.control.stiffness`, ``integrator`` ``"rk4"`` or ``"rosenbrock"``
        (:mod:`manipdyn.control.implicit`); ``sampled_loop`` its controller's
        ``dt |eig(D_plant^-1 K_d)|``; ``cause`` why a diverged run diverged, a key of
        :data:`.diverged.CAUSES`, None for the others; ``why`` what happened to that run,
        :func:`.diverged.explain`, None for the others).
    timing : dict
        Wall time, workers, chunks and where chunks ran (not reproducible).
    """

    #: the per-run figures, name -> (description, unit)
    metrics = METRICS
    #: the percentiles of each figure's distribution
    percentiles = PERCENTILES

    def __init__(self, study, per_run: list, timing: dict):
        self.study = study
        self.per_run = per_run
        self.timing = timing
        self.controllers = {}
        for key in study.controllers:
            rec = [r for r in per_run if r["controller"] == key]
            ok = [r for r in rec if not r["diverged"]]
            entry = {m: _stats([r[m] for r in ok if r[m] is not None]) for m in METRICS}
            entry["diverged"] = sum(1 for r in rec if r["diverged"])
            causes = [r.get("cause") for r in rec if r["diverged"] and r.get("cause")]
            entry["diverged_because"] = {c: causes.count(c) for c in CAUSES if c in causes}
            entry["saturated"] = sum(1 for r in rec if r["saturated"])
            # worst first: diverged runs (earliest divergence unknown here: by run), then by RMS error
            order = sorted(rec, key=lambda r: (not r["diverged"], -(r["rms_error"] or 0.0), r["run"]))
            entry["worst"] = [{"run": r["run"], "seed": [study.seed, r["run"]], "rms_error": r["rms_error"],
                               "max_error": r["max_error"], "diverged": r["diverged"]}
                              for r in order[:WORST]]
            self.controllers[key] = entry

    def worst(self, controller: str) -> list[int]:
        """Run indices of ``controller``'s worst runs, worst first (replay them with ``study.replay``)."""
        return [w["run"] for w in self.controllers[controller]["worst"]]

    def effect(self) -> dict:
        """What the study's added friction and torque noise do to its arm (:func:`.distributions.effect_on_arm`)."""
        s = self.study
        return effect_on_arm(s.distributions, s.arm, s.bandwidth, s.sizes() if s.distributions.sized else None)

    def report_html(self, path, command: str | None = None, plants_file=None, notes=None) -> str:
        """Write the study as one self-contained HTML page to ``path`` (atomically; what
        ``manipdyn montecarlo --report`` writes, :mod:`manipdyn.control.montecarlo.html`): what was run, the verdict, the
        distributions per controller, divergences and causes, the worst runs, the CDF figure.
        ``command``: the command line to show; ``plants_file``: the identification the plants
        were drawn from (its sha256 is shown); ``notes``: the model's notes (default: the arm's own).
        Returns the path."""
        from .html import write_study_report

        return write_study_report(self, path, command=command, plants_file=plants_file, notes=notes)

    def to_dict(self) -> dict:
        s = self.study
        return {"runs": s.runs, "seed": s.seed, "study": s.to_dict(), "distribution_effect": self.effect(),
                "controllers": self.controllers, "per_run": self.per_run, "timing": self.timing}

    def to_json(self, indent: int | None = 2) -> str:
        """Strict JSON: a non-finite number (a run that blew up) is written ``null``, never
        ``Infinity`` or ``NaN``, which JSON does not have."""
        return json.dumps(finite_or_null(self.to_dict()), indent=indent, allow_nan=False)

    def table(self) -> str:
        from ..demo import CONTROLLERS

        rows = [f"{'controller':<22} {'':<10} {'p50':>10} {'p90':>10} {'p99':>10} {'max':>10}"]
        for key, e in self.controllers.items():
            label = CONTROLLERS.get(key, key)
            for i, (m, (_, unit)) in enumerate(METRICS.items()):
                st = e[m]
                cells = " ".join(f"{st[k]:10.3e}" if st[k] is not None else f"{'-':>10}"
                                 for k in ("p50", "p90", "p99", "max"))
                name = m.replace("_", " ")
                rows.append(f"{label if i == 0 else '':<22} {name:<11}{cells}  {unit}")
            worst = ", ".join(f"{w['run']}" + (" (diverged)" if w["diverged"] else "") for w in e["worst"])
            why = ", ".join(f"{k} {v}" for k, v in e.get("diverged_because", {}).items())
            rows.append(f"{'':<22} diverged {e['diverged']}" + (f" ({why})" if why else "")
                        + f", saturated {e['saturated']}; worst runs: {worst}")
        return "\n".join(rows)

    def __str__(self) -> str:
        s = self.study
        t = self.timing
        nc = len(s.controllers)
        head = (f"montecarlo {s.model[3]!r}: {s.runs} run{'s' * (s.runs != 1)} x {nc} "
                f"controller{'s' * (nc != 1)}, seed {s.seed}, "
                f"demo path {s.duration:g} s at {1 / s.dt:g} Hz"
                + (f", MuJoCo stepping each plant's MJCF ({s.mujoco_plant} plant)" if s.simulator == "mujoco" else "")
                + f"\n{plant_source(s)}")
        effect = self.effect()["text"]
        head += f"\n{effect}" if effect else ""
        foot = (f"{s.runs * len(s.controllers)} simulations in {t.get('wall_s', 0.0):.1f} s on "
                f"{t.get('workers', 1)} worker(s) ({t.get('scheduler', '')}); replay a run with "
                f"study.replay(run, controller)")
        legend = "; ".join(f"{m.replace('_', ' ')}: {d}" for m, (d, _) in METRICS.items())
        return f"{head}\n{self.table()}\n{legend}\n{self.integration()}{self.divergences()}{foot}"

    def divergences(self) -> str:
        """Lines on the sampled loop and the causes of the diverged runs (:mod:`.diverged`), else ''."""
        fast = [r for r in self.per_run if (r.get("sampled_loop") or 0.0) > SAMPLED_LIMIT]
        out = ""
        if fast:
            worst = max(r["sampled_loop"] for r in fast)
            out = (f"sampled loop: {len(fast)} of {len(self.per_run)} runs have dt |eig(D_plant^-1 K_d)| > "
                   f"{SAMPLED_LIMIT:g} at the reference (up to {worst:.3g}; {sum(r['diverged'] for r in fast)} of "
                   f"them diverged): the controllers' damping, tuned to the nominal arm, is too fast for the "
                   f"period on these plants; --dt {self.study.dt * SAMPLED_LIMIT / worst:.2g} or less would "
                   f"hold them, more RK4 steps would not\n")
        total = {}
        for e in self.controllers.values():
            for c, k in e.get("diverged_because", {}).items():
                total[c] = total.get(c, 0) + k
        out += "".join(f"diverged ({c}): {k} run(s): {CAUSES[c]}\n" for c, k in total.items())
        whys = self.diverged_runs()
        out += "".join(f"  {w['text']}\n" for w in whys[:SHOWN])
        if len(whys) > SHOWN:
            out += f"  and {len(whys) - SHOWN} more diverged run(s): each record's 'why' in --json\n"
        return out

    def diverged_runs(self) -> list:
        """Each diverged run's ``why`` (:func:`.diverged.explain`) with its ``run`` and ``controller``,
        in the study's controller order, then by run."""
        out = []
        for key in self.study.controllers:
            out += [{"run": r["run"], "controller": key, **r["why"]} for r in self.per_run
                    if r["controller"] == key and r["diverged"] and r.get("why")]
        return out

    def integration(self) -> str:
        """One line when some plants needed more than one Runge-Kutta step per period, else ''."""
        steps = {}
        for r in self.per_run:
            steps[r["run"]] = max(steps.get(r["run"], 1), int(r.get("substeps", 1)))
        implicit = {r["run"] for r in self.per_run if r.get("integrator", "rk4") == "rosenbrock"}
        stiff = [m for run, m in steps.items() if m > 1 and run not in implicit]
        out = "" if not stiff else (
            f"integration: {len(stiff)} of {len(steps)} plants are too fast for one RK4 step per "
            f"{self.study.dt * 1e3:g} ms period and took up to {max(stiff)} (manipdyn.control.stiffness)\n")
        if implicit:
            out += (f"integration: {len(implicit)} of {len(steps)} plants are too stiff for RK4 (over "
                    "manipdyn.control.implicit.RK4_LIMIT steps per period) and were stepped by the Rosenbrock "
                    f"step with the friction implicit, up to {max(steps[r] for r in implicit)} steps per period\n")
        return out


