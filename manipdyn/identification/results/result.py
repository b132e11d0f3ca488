"""What :func:`manipdyn.identify` returns: the fit, its story, and how to write and score it.

Layer 5 (identification).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..._support.errors import ModelError

__all__ = ["IdentifyResult", "HeldOut", "write_model_files", "EXIT_OK", "EXIT_NO_ARM"]

#: :attr:`IdentifyResult.exit_code` values (``manipdyn identify`` exits with them)
EXIT_OK, EXIT_NO_ARM = 0, 1


@dataclass
class HeldOut:
    """The hold-outs of the prediction band and the refits that predicted them
    (:mod:`manipdyn.identification.uncertainty.bands`).

    ``kind``: the band's own, ``"trajectories"`` (each trajectory group held out, when there are two or
    more) or ``"blocks"`` (``folds`` blocks in time, block k the k-th part of every run); ``refits``: per
    kind computed, a list of ``(test, arm)``, ``test`` the held-out samples of the stacked fit data (N,)
    bool and ``arm`` the refit's arm (None when its parameters are no physical arm); ``labels`` (N,) or
    None: each sample's trajectory group.  The collision thresholds watch the same hold-outs through the
    observer of these refits (:mod:`manipdyn.control.collision.holdouts`).
    """

    kind: str
    folds: int
    refits: dict
    labels: object = None

    def pairs(self, kind: str | None = None) -> list:
        """The ``(test, arm)`` pairs of ``kind`` (default the band's own, ``kind``); a :class:`ModelError`
        when they were not computed."""
        kind = self.kind if kind is None else kind
        if not self.refits.get(kind):
            raise ModelError(f"held-out kind: expected one of {', '.join(k for k in self.refits if self.refits[k])}, "
                             f"got {kind!r}")
        return list(self.refits[kind])


@dataclass
class IdentifyResult:
    """The result of :func:`manipdyn.identify`.

    Attributes
    ----------
    fit : FitResult
        The estimate (:func:`.fit`): ``fit.arm`` (None when the parameters are no physical
        arm, ``fit.arm_error`` says why), ``fit.base``, ``fit.beta``, ``fit.covariance``.
    arm : manipdyn.Arm or None
        The identified arm, named :attr:`name`, its provenance in its citation.
    prior : manipdyn.Arm
        The prior (with the identified torque constants in its transmission, if asked).
    data : Measurements
        The fit data, the runs stacked (``data.segments``: their sample counts).
    provenance : dict
        :func:`.provenance.provenance` of the fit.
    torque_constants : TorqueConstants or None
        ``k_t`` per motor with standard deviations, when identified.
    output, base_model : str or None
        What :meth:`save` or ``identify(output=...)`` wrote.
    exit_code : int
        0 a model written (or nothing asked), 1 only the base model could be written.
    held_out : HeldOut or None
        The band's hold-outs and their refits (None without a band).
    """

    fit: object
    prior: object
    prior_label: str
    data: object
    friction: object
    armature: bool
    provenance: dict
    metadata: tuple
    name: str
    named: bool = False
    report_dict: dict = field(default_factory=dict)
    selection: list | None = None
    shapes: dict | None = None
    torque_constants: object = None
    payload_logs: list = field(default_factory=list)
    bootstrap: dict | None = None
    arm: object = None
    output: str | None = None
    base_model: str | None = None
    exit_code: int = EXIT_OK
    logs_label: str = ""
    held_out: HeldOut | None = None

    def rename(self, name: str) -> None:
        """Name the identified arm ``name`` (its citation stays the fit's provenance)."""
        from ..estimation.model import arm_with_parameters
        from .provenance import trust_record

        self.name = name
        if self.fit.arm is None:
            self.arm = None
            return
        import warnings

        from ..._support.errors import PhysicalConsistencyWarning

        with warnings.catch_warnings():      # as fit() builds it: the prior's own notes were given at load
            warnings.simplefilter("ignore", PhysicalConsistencyWarning)
            self.arm = arm_with_parameters(self.prior, self.fit.parameters, armature=self.armature,
                                           friction=self.friction, name=name, metadata=self.metadata,
                                           trust=trust_record(self.provenance))
        self.fit.arm = self.arm

    def save(self, path) -> str:
        """Write the identified model to ``path``: ``.toml`` (a model file), ``.urdf`` (a URDF
        prior's text with the identified ``<inertial>``s, or a DH arm as URDF) or ``.json`` (the
        base model, :mod:`.basemodel`).  Unless a ``name`` was given to :func:`manipdyn.identify`, the
        arm is named after the file (``arm_id.toml``: ``arm_id``).  Returns the path.

        When the parameters are no physical arm (``ols`` or ``wls`` may give a ``J_i`` that is not
        positive semidefinite) and ``path`` is a ``.toml`` or ``.urdf``, the base model is written
        beside it, ``X.base.json``, and a :class:`ModelError` says so: what ``manipdyn identify
        -o X.toml`` does too (it writes ``X.base.json`` and exits 1).
        """
        from ..._support.files import atomic_write_text
        from ...model.arm import URDFArm
        from ...formats.save import save, write_urdf
        from .basemodel import prior_text, write_base_model

        path = os.fspath(path)
        low = path.lower()
        if not self.named:
            stem = os.path.splitext(os.path.basename(path))[0]
            stem = stem[:-5] if stem.endswith(".base") else stem
            if stem and stem != self.name:
                self.rename(stem)
        if low.endswith(".json"):
            self.fit.report["name"] = self.name
            write_base_model(path, self.fit, prior_text(self.prior), self.provenance, bootstrap=self.bootstrap)
            return path
        if self.arm is None:
            if not low.endswith((".toml", ".urdf")):
                raise ModelError(f"path: expected a file name ending in .toml, .urdf or .json, got {path!r}")
            base = _save_base(self, base_beside(path))
            raise ModelError(f"{path}: the {self.fit.method} parameters are not a physical arm "
                             f"({self.fit.arm_error or 'a J_i is not >= 0'}); the base model is written to {base} "
                             "instead (validate scores it; method='consistent' gives a physical arm)")
        if isinstance(self.arm, URDFArm) and low.endswith(".urdf"):
            atomic_write_text(path, self.arm.urdf_text)
        elif low.endswith(".toml"):
            save(self.arm, path)
        elif low.endswith(".urdf"):
            write_urdf(self.arm, path)
        else:
            raise ModelError(f"path: expected a file name ending in .toml, .urdf or .json, got {path!r}")
        return path

    def report(self) -> dict:
        """The figures ``manipdyn identify --json`` prints (JSON-ready).

        Keys are added, never renamed (other tools read them).  Besides the fit's
        (:func:`.estimation.report`): ``fit_notes`` (sentences), ``doubts`` (what the fit should
        doubt, :mod:`.doubts`; also in ``fit_notes`` and the trust record), ``smoothing_selection``
        (when the Coulomb smoothing was chosen: one ``{"smoothing", "score", "rms"}`` per candidate,
        :mod:`..inputs.smoothing`), ``prior_weight_selection``, ``bootstrap``, ``friction_shapes``,
        ``torque_constants``, ``provenance`` (with ``prediction_band``, ``fitted_range``,
        ``leverage``, ``doubts``: the trust record's content), ``runs``, ``data_notes``, and
        ``links`` (:func:`link_table`: each body's mass, COM and principal moments, fitted and prior), and
        ``decided`` (:func:`manipdyn.identification.estimation.prior.attribution`: per base parameter and link,
        decided by the data, the prior or the floor).
        """
        rep = dict(self.report_dict)
        if self.selection is not None:
            rep["prior_weight_selection"] = self.selection
        if self.bootstrap is not None:
            rep["bootstrap"] = {k: v for k, v in self.bootstrap.items() if k != "covariance"}   # in the base model
        if self.shapes is not None:
            rep["friction_shapes"] = self.shapes
        if self.torque_constants is not None:
            rep["torque_constants"] = self.torque_constants.as_dict()
            rep["fit_notes"] = list(rep.get("fit_notes", [])) + [rep["torque_constants"]["summary"]]
        rep.update({"model": self.prior_label, "data": self.logs_label or self.provenance["data"], "name": self.name,
                    "output": self.output, "base_model": self.base_model,
                    "derived_derivatives": self.data.derived, "provenance": self.provenance,
                    "runs": [{"log": os.path.basename(str(s)), "samples": int(k)}
                             for s, k in zip(self.data.sources, self.data.segments)],
                    "payload_logs": list(self.payload_logs), "data_notes": list(self.data.notes),
                    "links": link_table(self.fit.parameters, self.prior)})
        return rep

    def format(self) -> str:
        """The text ``manipdyn identify`` prints."""
        from ..estimation.report import format_report

        rep = self.report()
        lines = [f"data: {note}" for note in rep["data_notes"]]
        lines.append(format_report(rep))
        lines += [f"note: {note}" for note in rep.get("fit_notes", [])]
        if rep.get("active_bounds"):
            lines.append("active bounds (the fit sits on them; --no-bounds or wider bounds to free it):")
            lines += [f"  {b}" for b in rep["active_bounds"]]
        if self.selection is not None:
            lines.append("prior weight by 5-fold blocked cross-validation (score: mean log RMS over the joints of "
                         "the held-out blocks, lower is better): " + ", ".join(
                             f"{row['prior_weight']:g} (score {row['score']:.4f})" for row in self.selection)
                         + f" -> {rep['prior_weight']:g}")
        sh = self.shapes
        if sh is not None:
            lines.append("friction shapes by variable projection (" + ("converged" if sh["converged"] else
                         "NOT converged: " + sh["message"]) + f", {sh['evaluations']} evaluations): "
                         + "; ".join(f"{k} " + " ".join(f"{x:.4g}" for x in v) for k, v in sh["fitted"].items()))
            if sh["at_bound"]:
                lines.append(f"  at the search's bound (not determined by the data?): {', '.join(sh['at_bound'])}")
            if sh.get("undetermined"):
                lines.append(f"  not determined by the data (the residual does not change with them over the log's "
                             f"speeds; another start?): {', '.join(sh['undetermined'])}")
        tc = self.torque_constants
        if tc is not None:          # the constants' one line is among the notes above
            lines += [f"  torque constants: {note}" for note in tc.notes]
        if self.bootstrap is not None:
            from ..uncertainty.bootstrap import format_bootstrap

            lines.append(format_bootstrap(self.bootstrap, rep["base_parameters"]))
        band = self.provenance.get("prediction_band")
        if band:
            k, regions = int(band.get("trajectories", 1)), int(band.get("regions", 0))
            within = "WITHIN ONE TRAJECTORY (it has not seen how another trajectory differs)"
            how = (f"{k} held-out trajectories (each predicted by a fit on the others), at least the within-run "
                   f"band of {band['folds']} blocked hold-outs" if k > 1 else
                   f"{regions} held-out posture regions (each predicted by a fit on the others), at least the "
                   f"band of {band['folds']} blocked hold-outs, {within}" if regions else
                   f"{band['folds']} blocked hold-outs of the fit data, {within}")
            lines.append(f"95 % prediction band from {how} (validate scores it on new data): +- "
                         + ", ".join(f"{x:.3g}" for x in band["half_width"]))
        if self.output:
            lines.append(f"wrote {self.output}")
        if self.base_model:
            lines.append(f"wrote {self.base_model} (base model: {rep['n_base']} base parameters with their "
                         f"standard deviations; score it with manipdyn validate)")
        return "\n".join(lines)

    def report_html(self, path, command: str | None = None) -> str:
        """Write this identification as one self-contained HTML page to ``path`` (atomically;
        what ``manipdyn identify --report`` writes, :mod:`manipdyn.identification.results.html`): what was done (the logs with
        their sha256, the options, the version), the verdict, per joint RMS in-sample and held
        out, the fit figure with its band, the parameters with their standard deviations and the
        active bounds, the data notes.  ``command``: the command line to show.  Returns the path."""
        from ..._support.html import write_page
        from .html import identify_page

        write_page(path, identify_page(self, command=command))
        return os.fspath(path)

    def score(self, logs, **options):
        """:func:`manipdyn.identification.validate` of the identified model on ``logs`` (the
        base model when the parameters are no physical arm)."""
        from .scoring import validate

        return validate(self if self.arm is None else self.arm, logs, **options)

    # scored as a model: the base model's prediction (the fit's) when there is no arm
    @property
    def n(self) -> int:
        return self.prior.n

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """The fit's torque prediction (N, n), N m: ``Y_b beta`` plus the prior's known terms."""
        return self.fit.predict(q, qd, qdd)


def base_beside(output) -> str:
    """``X.base.json`` for ``X.toml`` (or ``X.urdf``): where a fit that is no physical arm is written."""
    return os.path.splitext(os.fspath(output))[0] + ".base.json"


def write_model_files(result: IdentifyResult, output, base_json) -> None:
    """Write what ``identify(output=..., base_json=...)`` asks: the model at ``output`` (or, when
    the parameters are no physical arm, the base model beside it: ``OUT.base.json``, exit code 1,
    as :meth:`IdentifyResult.save` does), and the base model at ``base_json``."""
    base_path = base_json
    if output is not None:
        out = os.fspath(output)
        if out.lower().endswith(".json"):
            base_path = out
        elif result.arm is not None:
            result.output = result.save(out)
        else:
            result.exit_code = EXIT_NO_ARM
            base_path = base_path or base_beside(out)
    if base_path:
        result.base_model = result.save(base_path) if result.named or output is None else _save_base(result, base_path)


def _save_base(result, path):
    """The base model at ``path`` without renaming the arm after it (it is named after ``output``)."""
    from .basemodel import prior_text, write_base_model

    result.fit.report["name"] = result.name
    write_base_model(os.fspath(path), result.fit, prior_text(result.prior), result.provenance,
                     bootstrap=result.bootstrap)
    return os.fspath(path)


def link_table(pi, prior) -> list:
    """Per link, the identified body beside the prior's (JSON-ready; ``identify --json`` ``links``).

    ``pi`` (>= 10 n,): the fit's full parameters, link k's ten in its URDF link frame ``L_k``
    (:mod:`manipdyn.model.parameters`).  Each entry: ``link`` (1..n), ``name``, ``mass`` and
    ``prior_mass`` (kg), ``com`` and ``prior_com`` (m, in ``L_k``), ``principal_moments`` and
    ``prior_principal_moments`` (kg m^2, about the COM, ascending); a body of zero or negative
    mass (a fit that is no physical arm) has ``com`` and its moments None.
    """
    from ...model.inertia import pseudo_inertia_from_parameters, tensor_from_pseudo_inertia
    from ...model.parameters import arm_parameters

    n = prior.n
    names = [j.link_name or f"link{k + 1}" for k, j in enumerate(prior.chain()[0])]
    ref = arm_parameters(prior)

    def body(p):
        J = pseudo_inertia_from_parameters(np.asarray(p, dtype=np.float64))
        if not J[3, 3] > 0:
            return float(J[3, 3]), None, None
        m, c, inertia = tensor_from_pseudo_inertia(J)
        return m, c.tolist(), np.linalg.eigvalsh(inertia).tolist()

    out = []
    for k in range(n):
        m, c, moments = body(pi[10 * k:10 * k + 10])
        m0, c0, moments0 = body(ref[10 * k:10 * k + 10])
        out.append({"link": k + 1, "name": names[k], "mass": m, "prior_mass": m0, "com": c, "prior_com": c0,
                    "principal_moments": moments, "prior_principal_moments": moments0})
    return out
