"""Score models on logs: :func:`validate`, what ``manipdyn validate`` runs.

Layer 5 (identification).

``md.validate(models, logs, **options)`` reads every log on its own (as
:func:`manipdyn.identify` reads them: :mod:`.runs`, a RUNS.toml included), stacks them,
and scores each model on the stacked samples with
:func:`.validation.validate` (per joint: RMS error, relative RMS, R^2, mean error; a
band where the model carries one, and the joints that leave the states it was fitted on).  A run with a known payload is scored on its measured
torque minus the payload's (the models describe the arm without it).  The options read the
logs, under the names and with the defaults of ``manipdyn validate``; ``predictions``
writes one model's measured and predicted torques and band per sample
(:func:`.validation.write_predictions`).  Several models are put side by side by
:mod:`.comparison` (the best per joint marked).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..._support.threads import blas_threads as _blas
from ..._support.errors import ModelError
from ..inputs.options import OptionError

__all__ = ["validate", "Validation", "load_scored_model"]


def load_scored_model(spec, tip=None):
    """``(model, label)``: an arm, a base model JSON (:mod:`.basemodel`) or what
    :func:`manipdyn.load` takes; an object with ``inverse_dynamics`` and ``n`` as it is."""
    if not isinstance(spec, (str, os.PathLike)):
        if not hasattr(spec, "inverse_dynamics") or not hasattr(spec, "n"):
            raise ModelError(f"models: expected arms, model files or base models, got {type(spec).__name__}")
        label = getattr(spec, "name", None) or "model"
        return spec, (f"{label} (base model)" if getattr(spec, "arm", None) is None and hasattr(spec, "fit")
                      else label)
    s = os.fspath(spec)
    if s.lower().endswith(".json"):
        from .basemodel import load_base_model

        if tip is not None:
            from ..inputs.options import OptionError, brace_safe

            raise OptionError("{}: a base model (" + brace_safe(s) + ") carries its own chain (the identification's "
                              "prior); {} is for a tree URDF given as a model", "tip", "tip")
        m = load_base_model(s)
        # the file first: "panda (base model)" would read as the bundled arm
        return m, f"{os.path.basename(s)} (base parameters identified from {m.name})"
    from ...formats.loading import load_with_notes

    arm, _ = load_with_notes(s, tip=tip)
    return arm, arm.name


@dataclass
class Validation:
    """What :func:`validate` returns: ``results`` (one :class:`.validation.ValidationResult`
    per model, in order), ``data`` (the stacked samples) and ``notes`` (the data notes)."""

    results: list
    data: object
    notes: list = field(default_factory=list)
    units: list | None = None
    held_out: list | None = None       # per model, :func:`.heldout.held_out_label`
    fit_data: list = field(default_factory=list)    # one line per model scored on its own fit data
    model_notes: list = field(default_factory=list)  # one line per model that is no physical arm

    def title(self) -> str:
        """The figure's title: the models, the logs, the scored window and, per model, whether
        the data are held out (:mod:`.heldout`)."""
        t0, t1 = float(self.data.t[0]), float(self.data.t[-1])
        logs = ", ".join(os.path.basename(str(s)) for s in self.data.sources) or "the data"
        held = self.held_out or [""] * len(self.results)
        models = "; ".join(f"{r.model} ({h})" if h else r.model for r, h in zip(self.results, held))
        return f"{models}\nscored on {logs}, t = {t0:.4g} to {t1:.4g} s ({len(self.data.t)} samples)"

    def to_dict(self) -> dict:
        """JSON-ready: one model's figures, or ``{"models": [...], "best": [...]}`` for several
        (:func:`.comparison.side_by_side_dict`)."""
        from .comparison import side_by_side_dict

        out = self.results[0].to_dict() if len(self.results) == 1 else side_by_side_dict(self.results)
        # the model's own notes (its carried trust record's: a record ignored, one trajectory) first, then
        # the notes on the models (no physical arm, torque scale): both, neither replacing the other
        out.update({"runs": self.per_run(), "data_notes": list(self.notes), "fit_data": list(self.fit_data),
                    "model_notes": list(out.get("model_notes") or []) + list(self.model_notes)})
        return out

    def per_run(self) -> list:
        """Per log: ``{"log", "samples", "rms": {model: per-joint RMS error}}`` (N m, N)."""
        rows, start = [], 0
        for src, k in zip(self.data.sources, self.data.segments):
            rms = {r.model: np.sqrt(np.mean((r.measured[start:start + k] - r.predicted[start:start + k]) ** 2,
                                            axis=0)).tolist() for r in self.results}
            rows.append({"log": os.path.basename(str(src)), "samples": int(k), "rms": rms})
            start += k
        return rows

    def format(self) -> str:
        """The text ``manipdyn validate`` prints: the data notes first (as ``identify`` prints
        them), then one model's table, or several side by side (:func:`.comparison.format_side_by_side`),
        then the RMS per log."""
        from .comparison import format_side_by_side

        body = (self.results[0].format(units=self.units) if len(self.results) == 1
                else format_side_by_side(self.results, units=self.units))
        return "\n".join([f"data: {note}" for note in self.notes] + [f"note: {x}" for x in self.fit_data + self.model_notes]
                         + [body]
                         + self._runs_text())

    def report_html(self, path, command: str | None = None, options: dict | None = None, model_files=()) -> str:
        """Write the scores as one self-contained HTML page to ``path`` (atomically; what
        ``manipdyn validate --report`` writes, :mod:`manipdyn.identification.results.html`): what was done, the verdict, per
        joint RMS, band coverage and extrapolation (flagged joints highlighted), the figure with
        the stretches beyond the fit shaded, several models side by side, the data notes.
        ``command``, ``options``, ``model_files``: shown as given (the files with their sha256).
        Returns the path."""
        from ..._support.html import write_page
        from .html import validation_page

        write_page(path, validation_page(self, command=command, options=options, model_files=model_files))
        return os.fspath(path)

    def write_predictions(self, path) -> None:
        """One model's ``t, tau{i}, pred{i}, lo{i}, hi{i}`` per sample as CSV, atomically
        (:func:`.validation.write_predictions`)."""
        from .validation import write_predictions

        if len(self.results) != 1:
            raise OptionError("{}: one MODEL at a time (the file holds one model's predictions)", "predictions")
        write_predictions(self.results[0], path)

    def _runs_text(self) -> list:
        if len(self.data.segments) < 2:
            return []
        return ["per log, RMS error per joint:"] + [
            f"  {row['log']} ({row['samples']} samples) {model}: " + " ".join(f"{x:.4g}" for x in rms)
            for row in self.per_run() for model, rms in row["rms"].items()]

    def plot(self, path, units=None) -> None:
        """Measured and predicted torque per joint, every model (:func:`.validation.plot_validation`);
        ``units`` per joint (default: N m, N for a prismatic joint of the first model)."""
        from .validation import plot_validation

        plot_validation(self.results, path, title=self.title(), units=units or self.units)


def validate(models, logs, *, tip=None, columns=None, deg: bool = False, rate=None, time_scale: float = 1.0,
             resample=None, cutoff=None, no_decimate: bool = False, t_range=None, topic=None, joint_names=None,
             extra_joints: bool = False, predictions=None, compare_column=None, blas_threads=1) -> Validation:
    """Score ``models`` on ``logs`` (module docstring); ``manipdyn validate``.

    Parameters
    ----------
    models : model or sequence of models
        Arms, base models, :class:`.result.IdentifyResult`, or what :func:`load_scored_model`
        loads (names, .toml, .urdf, base model .json; ``tip`` for a tree URDF).
    logs : path, RUNS.toml, LogSpec, Measurements, or a sequence of these
        Read with the first model's transmission and joint names.
    columns, deg, rate, time_scale, resample, cutoff, no_decimate, t_range, topic, joint_names, extra_joints
        How to read the logs, as :func:`manipdyn.identify` takes them.
    predictions : path or None
        Write the one model's measured and predicted torques and its 95 % band per sample there
        (:meth:`Validation.write_predictions`; refused with several models or a path that is a log).
    compare_column : str, optional
        A torque the log itself holds, scored as one more model (:mod:`.logged`): ``"m"`` for columns
        ``m1..mn``, ``"m=UR controller target torque"`` to name it.
    blas_threads : int or None
        BLAS threads while scoring (None: the library's own choice).
    """
    from ..inputs.runs import read_runs, stack
    from .validation import validate as score

    with _blas(blas_threads):
        if isinstance(models, (str, os.PathLike)) or hasattr(models, "inverse_dynamics"):
            models = [models]
        loaded = [load_scored_model(m, tip) for m in models]
        if not loaded:
            raise ModelError("models: no model given")
        seen: dict = {}
        for k, (m, label) in enumerate(loaded):     # two models of one name keep a row each
            seen[label] = seen.get(label, 0) + 1
            if seen[label] > 1:
                loaded[k] = (m, f"{label} ({seen[label]})")
        first = loaded[0][0]
        arm = getattr(first, "prior", None) or getattr(first, "arm", None) or first
        if predictions is not None:
            _check_predictions(predictions, loaded, logs)
        if any(m.n != first.n for m, _ in loaded):
            raise ModelError(f"models: they differ in their number of joints ({[m.n for m, _ in loaded]})")
        names = joint_names if joint_names is not None else (list(getattr(arm, "joint_names", None) or []) or None)
        read_options = dict(transmission=getattr(arm, "transmission", None), joint_names=names, columns=columns,
                            deg=deg, rate=rate, time_scale=time_scale, resample=resample, cutoff=cutoff,
                            decimate=False if no_decimate else None, topic=topic, t_range=t_range,
                            extra_joints=extra_joints)
        runs = read_runs(logs, arm, **read_options)
        from ..inputs.options import check_limits

        for data, payload in runs:
            check_limits(data, arm, deg)     # degrees read as radians are refused here too, as identify does
            if payload is not None:
                data.tau = data.tau - payload.torque(arm, data.q, data.qd, data.qdd)
                data.notes.append(f"payload: the known payload's torque ({payload.mass:g} kg at the tool frame) "
                                  "subtracted from the measured torques")
        data = stack([d for d, _ in runs])
        results = [score(m, data, name=label) for m, label in loaded]
        if compare_column is not None:          # the log's own torque columns, one more model (.logged)
            from .logged import read_logged

            logged = read_logged(compare_column, data, read_options)
            results.append(score(logged, data, name=logged.name))
            loaded.append((logged, logged.name))
    units = ["N" if t == "prismatic" else "N m" for t in getattr(arm, "joint_types", ())] or None
    from ...model.plausible import not_physical_note
    from ..inputs.units import torque_scale_note
    from .heldout import fit_data_note, held_out_label, scored_window

    fit = [fit_data_note(m, list(data.sources), scored_window(data), label, "its RMS, R^2 and band coverage")
           for m, label in loaded]
    out = Validation(results=results, data=data, notes=list(data.notes), units=units,
                     held_out=[held_out_label(m, data) for m, _ in loaded], fit_data=[x for x in fit if x],
                     model_notes=[x for x in [not_physical_note(m, label) for m, label in loaded]
                                  + [torque_scale_note(r.measured, r.predicted, label) for r, (_m, label)
                                     in zip(results, loaded)] if x])
    if predictions is not None:
        out.write_predictions(predictions)
    return out


def _check_predictions(path, loaded, logs) -> None:
    """Refuse, before any log is read, a ``predictions`` file for several models or one that is a log."""
    from ..._support.files import overwrites
    from ..inputs.options import brace_safe

    if len(loaded) != 1:
        raise OptionError("{}: one MODEL at a time (the file holds one model's predictions)", "predictions")
    if not isinstance(path, (str, os.PathLike)) or not os.fspath(path):
        raise OptionError("{}: expected a file path, got " + brace_safe(repr(path)), "predictions")
    items = [logs] if isinstance(logs, (str, os.PathLike)) or not hasattr(logs, "__iter__") else list(logs)
    for log in items:
        src = log if isinstance(log, (str, os.PathLike)) else getattr(log, "path", None)
        if src is not None and os.path.exists(src) and overwrites(os.fspath(path), os.fspath(src)):
            raise OptionError("{} " + brace_safe(os.fspath(path)) + ": would overwrite DATA "
                              + brace_safe(os.fspath(src)) + "; write the output to another file", "predictions")
