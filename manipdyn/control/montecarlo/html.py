"""A study's report as one self-contained HTML page (``manipdyn montecarlo --report FILE.html``).

Layer 6 (control: montecarlo).

Read from the top down: what was run (the command, the model, the plants, the seed, the
version), the verdict in a sentence, the distribution of each controller's tracking error
and torque (the numbers of ``--json``'s ``controllers``), the divergences and their causes,
the worst runs (with the call that replays each), and the CDF figure.  Built from the blocks
of :mod:`manipdyn._support.html` (escaped text, tables with exact ``data-value``\\ s, inline
PNG); written atomically.
"""

from __future__ import annotations

import os

from ..._support import html as H
from ..._support.errors import ModelError
from ..stiffness import SAMPLED_LIMIT
from .diverged import CAUSES
from .identified import plant_source

__all__ = ["study_page", "write_study_report"]

#: the table names of the page (``data-table``), which tests and scripts read
TABLES = ("distribution", "divergences", "worst")


def _label(key: str) -> str:
    from ..demo import CONTROLLERS

    return CONTROLLERS.get(key, key)


def _verdict(report) -> tuple[str, str]:
    """The sentence and its level (ok, warn, bad).  Best and worst are named by the figure the
    table shows, the p90 of the RMS error over the runs that did not diverge (the best among the
    controllers that diverged least); divergences are named on their own."""
    s = report.study
    c = report.controllers
    scored = [k for k in c if c[k]["rms_error"]["p90"] is not None]
    diverged = {k: c[k]["diverged"] for k in c if c[k]["diverged"]}
    saturated = {k: c[k]["saturated"] for k in c if c[k]["saturated"]}
    if not scored:
        return f"Every run of every controller diverged over the {s.runs} plants.", "bad"
    best = min(scored, key=lambda k: (c[k]["diverged"], c[k]["rms_error"]["p90"]))
    text = (f"Over {s.runs} plant{'s' * (s.runs != 1)}, {_label(best)} tracks best: 90 % of its "
            + ("runs" if not c[best]["diverged"] else "runs that did not diverge")
            + f" stay under {H.number(c[best]['rms_error']['p90'], 3)} rad RMS error")
    worst = max(scored, key=lambda k: c[k]["rms_error"]["p90"])
    if worst != best:
        text += (f"; {_label(worst)} has the largest p90 of the RMS error "
                 f"({H.number(c[worst]['rms_error']['p90'], 3)} rad)")
    if diverged:
        text += ". Diverged: " + ", ".join(f"{_label(k)} in {v} of {s.runs} runs" for k, v in diverged.items())
    else:
        text += ". No run diverged"
    if saturated:
        text += "; torque saturated: " + ", ".join(f"{_label(k)} in {v}" for k, v in saturated.items())
    return text + ".", "bad" if diverged else ("warn" if saturated else "ok")


def _done(report, command, plants_file) -> list:
    s = report.study
    d = s.distributions.to_dict()
    t = report.timing
    rows = [("command", command or "(library call) manipdyn.control.montecarlo.run(study)"),
            ("model", s.model[3]),
            ("runs", f"{s.runs} per controller, seed {s.seed} (run k: SeedSequence({s.seed}, spawn_key=(k,)))"),
            ("controllers", ", ".join(_label(k) for k in s.controllers)),
            ("path", f"the track demo path over {s.duration:g} s at {1 / s.dt:g} Hz (dt {s.dt:g} s), "
                     f"bandwidth {s.bandwidth:g} rad/s, adaptation gain {s.gamma:g}"),
            ("simulator", "MuJoCo's RK4 on each drawn plant's MJCF, " + (
                "the plant manipdyn simulates (constraints off, its friction law at every stage)"
                if s.mujoco_plant == "model" else "the file as MuJoCo loads it (Coulomb as frictionloss)")
             if s.simulator == "mujoco" else "manipdyn's RK4 (Pinocchio's ABA)"),
            ("torque limit", "the model's own" if s.tau_max is None
             else ", ".join(H.number(x, 4) for x in s.tau_max) + " N m"),
            ("plants", plant_source(s).removeprefix("plants: ")),
            ("distributions" if s.plants is None else "other draws",
             ", ".join(f"{k.replace('_', ' ')} {v:g}" for k, v in d.items()
                       if isinstance(v, (int, float)) and (s.plants is None or v)))]
    plants_file = plants_file or getattr(s.plants, "source", None)     # the library call: the study knows it
    if plants_file:
        sha = H.sha256_of(plants_file)
        rows.append(("identification", f"{os.path.basename(os.fspath(plants_file))}"
                                       + (f", sha256 {sha}" if sha else "")))
    rows += [("ran", f"{s.runs * len(s.controllers)} simulations in {t.get('wall_s', 0.0):.1f} s on "
                     f"{t.get('workers', 1)} worker(s) ({t.get('scheduler', '')})"),
             ("manipdyn", H.version())]
    return rows


def _distribution(report):
    pcts = report.percentiles
    headers = ["controller", "figure", *(f"p{p}" for p in pcts), "max", "unit"]
    rows, flagged = [], set()
    for key, e in report.controllers.items():
        for m, (_, unit) in report.metrics.items():
            st = e[m]
            if e["diverged"]:
                flagged.add(len(rows))
            rows.append([_label(key), m.replace("_", " "), *(st[f"p{p}"] for p in pcts), st["max"], unit])
    return H.table(headers, rows, name="distribution", flagged=flagged,
                   caption="Per controller, over the runs that did not diverge: percentiles of each run's figure "
                           "(rows of a controller with diverged runs highlighted)")


def _divergences(report):
    rows, flagged = [], set()
    for i, (key, e) in enumerate(report.controllers.items()):
        why = ", ".join(f"{c}: {k}" for c, k in e.get("diverged_because", {}).items()) or "-"
        rows.append([_label(key), e["diverged"], e["saturated"], why])
        if e["diverged"]:
            flagged.add(i)
    return H.table(["controller", "diverged runs", "saturated runs", "causes (runs)"], rows, name="divergences",
                   flagged=flagged, caption="Runs that diverged (their figures leave the distributions) and runs "
                                            "whose torque met the limit")


def _diverged_runs(report):
    rows = [[_label(w["controller"]), w["run"], w["text"].split(": ", 2)[1], w["text"].split(": ", 2)[2],
             f"study.replay({w['run']}, {w['controller']!r})"] for w in report.diverged_runs()]
    return H.table(["controller", "run", "cause", "what happened", "replay"], rows, name="diverged-runs",
                   flagged=set(range(len(rows))),
                   caption="Each diverged run: the bound it crossed, when it left the path, how much heavier than "
                           "the model its plant is, and what the sampled loop and the integrator say")


def _worst(report):
    rows, flagged = [], set()
    for key, e in report.controllers.items():
        for rank, w in enumerate(e["worst"], 1):
            if w["diverged"]:
                flagged.add(len(rows))
            rows.append([_label(key), rank, w["run"], w["rms_error"], w["max_error"], w["diverged"],
                         f"study.replay({w['run']}, {key!r})"])
    return H.table(["controller", "rank", "run", "rms error (rad)", "max error (rad)", "diverged", "replay"], rows,
                   name="worst", flagged=flagged,
                   caption="The worst runs per controller, worst first (diverged first, then by RMS error)")


def _causes(report) -> list:
    seen = {c for e in report.controllers.values() for c in e.get("diverged_because", {})}
    notes = [f"{c}: {CAUSES[c]}" for c in CAUSES if c in seen]
    fast = [r for r in report.per_run if (r.get("sampled_loop") or 0.0) > SAMPLED_LIMIT]
    if fast:
        notes.append(report.divergences().splitlines()[0])
    integ = report.integration().strip()
    if integ:
        notes.append(integ)
    return notes


def _scales_caption(fig, metrics) -> str:
    """The horizontal scale of each panel of ``fig`` as drawn (log, or linear over a narrow range)."""
    scales = [ax.get_xscale() for ax in fig.axes[:len(metrics)]]
    names = [m.replace("_", " ") for m in metrics]
    if len(set(scales)) == 1:
        return f"{scales[0]} scale" if scales else "no panel"
    return ", ".join(f"{nm}: {sc} scale" for nm, sc in zip(names, scales))


def study_page(report, command: str | None = None, plants_file=None, notes=None) -> str:
    """The page (a str of HTML) of a :class:`~.report.StudyReport` (module docstring);
    ``command``: the command line that ran it, shown as given (escaped); ``notes``: the model's
    notes (default: the study's arm's ``notes``), shown as the command prints them."""
    s = report.study
    text, level = _verdict(report)
    try:
        from .plot import draw_report

        drawn = draw_report(report, title=False)
        fig = H.figure(drawn,
                       alt=f"Empirical cumulative distributions of the per-run RMS error, max error and peak torque "
                           f"of {', '.join(_label(k) for k in s.controllers)} over {s.runs} runs",
                       caption=f"Fraction of runs (vertical) at or under each value (horizontal, "
                               f"{_scales_caption(drawn, report.metrics)}), one "
                               "curve per controller; diverged runs are left out and counted in the legend (a "
                               "controller whose every run diverged has no curve).")
    except ModelError:          # matplotlib missing: the page without its figure, saying why
        fig = "No figure: matplotlib is not installed (pip install -e '.[plot]')."
    if notes is None:
        notes = list(getattr(s.arm, "notes", ()) or ())
    effect = report.effect()["text"]
    verdict = [H.verdict(text, level)]
    if effect:                  # why every controller may err by as much: the draws, not the controllers
        verdict.append(H.paragraph(effect[0].upper() + effect[1:] + "."))
    if notes:
        verdict.append(H.paragraph("The model's notes:"))
        verdict.append(H.bullets(list(notes)))
    parts = [H.section("What was run", H.facts(_done(report, command, plants_file))),
             H.section("Verdict", *verdict),
             H.section("Tracking error and torque per controller", _distribution(report),
                       H.bullets([f"{m.replace('_', ' ')}: {d} ({u})" for m, (d, u) in report.metrics.items()]), fig)]
    notes = _causes(report)
    parts.append(H.section("Divergences and their causes", _divergences(report),
                           H.bullets(notes) if notes else "No run diverged and no plant needed a shorter period.",
                           *([_diverged_runs(report)] if report.diverged_runs() else [])))
    parts.append(H.section("Worst runs", _worst(report),
                           "Replay a run alone with study.replay(run, controller), i.e. manipdyn.simulate on the "
                           "run's plant: the plant depends only on the seed and the run's index."))
    return H.page(f"Monte-Carlo study: {s.model[3]}",
                  f"{s.runs} runs x {len(s.controllers)} controllers, seed {s.seed}; plants "
                  + ("hand-chosen around the model" if s.plants is None
                     else f"drawn from the identification {getattr(s.plants, 'source', '')}"), parts)


def write_study_report(report, path, command: str | None = None, plants_file=None, notes=None) -> str:
    """Write :func:`study_page` to ``path`` atomically; returns the path."""
    H.write_page(path, study_page(report, command=command, plants_file=plants_file, notes=notes))
    return os.fspath(path)
