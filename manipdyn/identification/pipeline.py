"""One identification from prior and logs to a written model: :func:`identify`.

Layer 5 (identification).

``md.identify(prior, logs, **options)`` is what ``manipdyn identify`` runs, with the same
options under the same names and the same defaults (``method="consistent"``, plausibility
bounds around the prior, ``prior_weight=0``; ``tests/test_pipeline.py`` compares them).
In order:

1. the prior (an arm, or what :func:`manipdyn.load` takes) and the options, checked
   (:mod:`.options`) before any log is read;
2. each log read, filtered and resampled on its own (:mod:`.runs`: a RUNS.toml, paths,
   or Measurements), its positions checked against the joint limits;
3. with ``identify_torque_constants``: ``k_t`` per motor from the currents
   (:mod:`.torque_constants`), the torques rescaled, the prior's ``[transmission]``
   given them;
4. the known payloads' torques moved to the known side; the runs stacked;
5. which runs repeat one trajectory (:mod:`.inputs.trajectories`): the groups held out together;
   the Coulomb smoothing, unless given, by held-out error among candidates around the log's
   velocity noise, the noise level kept unless a candidate wins by more than the folds' spread
   (:mod:`.inputs.smoothing`; folds: the trajectories when there are two or more, else blocks);
   the friction shapes by variable projection (:mod:`.varpro`) when the friction terms have any,
   the prior weight by the same held-out folds and rule when ``"auto"``;
6. :func:`.fit` with each run's joints weighed by their noise in that run, and, with friction, each joint's
   samples at rest (:mod:`.inputs.rest`) still and out of its rows; their static level goes to the trust record;
7. with ``band_folds`` (default 5): ``band_folds`` refits, each on all but one block of the
   stacked data in time and keeping the runs' boundaries, and with two or more trajectories a
   refit per trajectory left out, whose held-out residuals give the 95 % prediction band
   (:mod:`.bands`); with the states the fit saw (:mod:`.coverage`) it goes into
   the provenance (:func:`.provenance.fit_record`), so the written model carries what
   ``validate`` scores on new data;
8. what the fit should doubt (:mod:`.results.doubts`: degenerate bodies, a run far off, a declared
   payload the data contradict), in the notes and the trust record;
9. provenance (:mod:`.provenance`) and the identified arm, named as the command line names
   it: after the output file (``-o arm_id.toml`` gives ``arm_id``), else
   ``<prior>_identified`` until :meth:`IdentifyResult.save` names it after its file.

BLAS runs with ``blas_threads`` threads (default 1: manipdyn's matrices are small, and
:mod:`manipdyn._support.threads` measured 2 to 9 times faster fits with one thread than with two; the
README's Panda fit, ``identify("panda", LOG, t_range=(None, 10), friction_terms="viscous,coulomb,offset")``,
took 1.6 s with one thread and 8.0 to 12.1 s with OpenBLAS's two, on a loaded 2-core machine).
"""

from __future__ import annotations

import os

import numpy as np

from .._support.threads import blas_threads as _blas
from .._support import limits
from .._support.errors import ModelError
from ..formats.logs.read import model_joint_names
from .inputs.options import OptionError
from .results.notes import decided_by, decided_record, fit_doubts, not_physical_notes, units_notes
from .results.result import IdentifyResult, write_model_files

__all__ = ["identify", "IdentifyResult"]

#: the options a model's provenance records (those given: not None, False or 0)
PROVENANCE_KEYS = ("method", "friction", "friction_terms", "friction_side", "smoothing", "stribeck_velocity",
                   "sigmoid_alpha", "armature", "mass_bound", "com_bound", "total_mass_bound", "no_bounds",
                   "prior_weight", "bootstrap", "scheduler", "identify_torque_constants", "scale_from_gravity", "cutoff", "columns", "deg",
                   "rate", "time_scale", "resample", "no_decimate", "t_range", "topic", "joint_names", "extra_joints")
#: the file kinds ``output`` may name
OUTPUTS = (".toml", ".urdf", ".json")


def _load(prior, tip):
    from ..formats.loading import load_with_notes

    if isinstance(prior, (str, os.PathLike)):
        arm, _ = load_with_notes(os.fspath(prior), tip=tip)
        return arm, os.fspath(prior)
    if tip is not None:
        raise OptionError("{}: only for a prior given as a URDF file", "tip")
    return prior, prior.name


def _check_target(arm, output, armature, friction_terms, prior_label):
    from ..model.arm import Manipulator, URDFArm

    if output is None:
        return
    out = os.fspath(output).lower()
    if not out.endswith(OUTPUTS):
        raise OptionError("{}: expected a file name ending in .toml, .urdf or .json, got "
                          + repr(os.fspath(output)).replace("{", "{{").replace("}", "}}"), "output")
    if isinstance(arm, URDFArm):
        if out.endswith(".urdf") and armature:
            raise OptionError("{}: a URDF has no rotor inertia; write a model file that keeps the URDF's chain and "
                              "adds the drive (-o OUT.toml), or only the base model (-o OUT.json)", "armature")
        if out.endswith(".urdf") and friction_terms is not None:
            raise OptionError("{}: a URDF's <dynamics> holds viscous and Coulomb friction only; write a model file "
                              "that keeps the URDF's chain and adds the friction law (-o OUT.toml), use {}, or "
                              "write only the base model (-o OUT.json)", "friction_terms", "friction")
        if out.endswith(".toml") and not armature and friction_terms is None and not arm.custom_drive:
            raise ModelError(f"-o {os.fspath(output)}: a URDF prior ({prior_label}) is written back as URDF: "
                             "-o OUT.urdf (or OUT.json for the base model); a model file (.toml) keeps the URDF's "
                             "chain and adds what URDF cannot hold: --armature, --friction-terms")
    elif not isinstance(arm, Manipulator) and not out.endswith(".json"):
        raise ModelError(f"prior {prior_label}: identify writes a DH model or a URDF; give a bundled model "
                         "name, a .toml model file or a URDF as the prior")


def _with_transmission(arm, transmission):
    """``arm`` with another :class:`~manipdyn.Transmission` (the identified torque constants)."""
    from ..model.arm import Manipulator
    from ..formats.urdf.reader import load_urdf

    law = arm.friction_model if arm.friction is None else None
    if isinstance(arm, Manipulator):
        return Manipulator(arm.links, convention=arm.convention, gravity=arm.gravity, name=arm.name,
                           source=arm.source, sources=arm.sources, description=arm.description,
                           transmission=transmission, friction=law, base=arm.base, tool=arm.tool)
    return load_urdf(arm.urdf_text, tip=arm.tip, name=arm.name, gravity=arm.gravity, transmission=transmission,
                     friction=law if arm.custom_drive else None)


def _torque_constants(arm, runs, friction, armature, reference, scale=None):
    """Step 3: ``(arm with k_t, runs with rescaled torques, TorqueConstants)``."""
    from ..model.drive import Transmission
    from .payload.gravity_scale import torque_constants
    from .payload.torque_constants import CURRENT_NOTE

    for data, _ in runs:
        if not any(CURRENT_NOTE in note for note in data.notes):
            raise ModelError(f"identify_torque_constants: {data.source} has no current columns (i1..in, or "
                             "columns='i=...'): torque constants are identified from currents")
    tc = torque_constants(arm, runs, armature=armature, friction=friction, reference=reference, scale_from_gravity=scale)
    tr = arm.transmission
    R = np.asarray(tr.R, dtype=np.float64)
    gain = R.T @ np.diag(tc.values) @ np.linalg.inv(R).T        # tau = R^T diag(k) i, i = R^-T tau_read
    scaled = []
    for data, payload in runs:
        scaled.append((_with_tau(data, data.tau @ gain.T, data.notes), payload))
    arm = _with_transmission(arm, Transmission(R, tr.motor_offset, tc.values))
    return arm, scaled, tc


def _read(arm, logs, read_options, deg, unit_gains):
    from ..model.drive import Transmission
    from .inputs.options import check_limits
    from .inputs.runs import read_runs

    tr = arm.transmission
    if unit_gains:        # currents read as they are: tau = R^T i, the gains come later
        tr = Transmission(tr.R, tr.motor_offset, np.ones(arm.n))
    runs = read_runs(logs, arm, transmission=tr, **read_options)
    for data, _ in runs:
        check_limits(data, arm, deg)
    return runs


def _known_payloads(arm, runs):
    """Step 4: one Measurements of every run, each payload's torque subtracted."""
    from .inputs.runs import stack

    parts = []
    for data, payload in runs:
        if payload is not None:
            data.tau = data.tau - payload.torque(arm, data.q, data.qd, data.qdd)
            data.notes.append(f"payload: the known payload's torque ({payload.mass:g} kg at the tool frame) "
                              "subtracted from the measured torques")
        parts.append(data)
    return stack(parts)


def identify(prior, logs, *, method: str = "consistent", tip=None, friction: bool = False, friction_terms=None,
             friction_side=None, smoothing=None, stribeck_velocity=None, sigmoid_alpha=None,
             armature: bool = False, mass_bound=None, com_bound=None, total_mass_bound=None, no_bounds: bool = False,
             prior_weight=None, bootstrap: int = 0, scheduler=None, band_folds: int = 5, identify_torque_constants: bool = False,
             torque_constant_reference=None, scale_from_gravity=None, output=None, base_json=None, name=None, columns=None,
             deg: bool = False, rate=None, time_scale: float = 1.0, resample=None, cutoff=None,
             no_decimate: bool = False, t_range=None, topic=None, joint_names=None, extra_joints: bool = False,
             blas_threads=1, progress=None) -> IdentifyResult:
    """Identify ``prior``'s parameters from ``logs`` (module docstring); ``manipdyn identify``.

    Parameters
    ----------
    prior : manipdyn.Arm or str
        The kinematics and the prior (an arm, a bundled name, a .toml model file, a URDF;
        ``tip`` for a tree URDF).
    logs : path, RUNS.toml, :class:`.runs.LogSpec`, Measurements, or a sequence of these
        Each read on its own (:func:`.runs.read_runs`).
    method, friction, friction_terms, friction_side, smoothing, stribeck_velocity, sigmoid_alpha,
    armature, mass_bound, com_bound, total_mass_bound, no_bounds, prior_weight
        What to identify and how (:mod:`.options`, :func:`.fit`); ``prior_weight`` may be ``"auto"``, the default
        (None) for ``method="consistent"``: chosen on the hold-outs by torque and acceleration error
        (:mod:`.estimation.selection`); 0 for the other methods.
    bootstrap, scheduler
        Refit on ``bootstrap`` block-resampled copies (:func:`.bootstrap`), here or on Dask.
    band_folds : int
        Blocked hold-outs of the fit data for the 95 % prediction band the model carries
        (:func:`.provenance.fit_record`; 2 to 100, default 5, each a refit; 0: no band).
    identify_torque_constants, torque_constant_reference, scale_from_gravity
        ``k_t`` per motor from current logs (:mod:`.torque_constants`); the scale from a run
        with a known payload, else from the prior's ``k_t`` of the reference motors (1-based;
        default all), else (or with ``scale_from_gravity``, 1-based motors) from the prior's
        gravity torque on those motors (:mod:`.payload.gravity_scale`; default: where it varies).
    output, base_json
        Write the model (.toml, .urdf) or the base model (.json) there
        (:meth:`IdentifyResult.save`), and the base model also at ``base_json``.
    name
        The identified arm's name (default: the output file's stem, else ``<prior>_identified``).
    columns, deg, rate, time_scale, resample, cutoff, no_decimate, t_range, topic, joint_names, extra_joints
        How to read the logs (:func:`~manipdyn.identification.read_log`; ``t_range`` is
        ``(t0, t1)`` in s, ``no_decimate`` is ``decimate=False``).
    blas_threads : int or None
        BLAS threads while identifying (None: the BLAS library's own choice).
    progress : callable, optional
        Told what runs: ``progress(stage)`` as each long stage starts (reading, torque constants,
        the smoothing's and the prior weight's held-out refits, the fit, the band's folds, the
        bootstrap) and ``progress(stage, done, total)`` as the bootstrap's refits come back
        (``manipdyn identify`` draws these on stderr).

    Returns :class:`IdentifyResult`; raises :class:`~manipdyn.ModelError` (an
    :class:`.options.OptionError` for a bad option) naming what is wrong.
    """
    with _blas(blas_threads):
        return _identify(prior, logs, locals())


def _identify(prior, logs, o) -> IdentifyResult:
    from .estimation.fitting import METHODS, fit
    from .inputs.options import brace_safe, bounds_option, friction_option, prior_weight_option
    from .inputs.rest import measured_rest, rest_option, rest_trust
    from .results.provenance import fit_record, model_metadata, provenance

    if o["method"] not in METHODS:
        raise OptionError("{}: expected one of " + ", ".join(METHODS) + ", got " + brace_safe(repr(o["method"])), "method")
    arm, prior_label = _load(prior, o["tip"])
    as_loaded, prior_notes = arm, []
    bounds = bounds_option(arm, o["method"], o["mass_bound"], o["com_bound"], o["total_mass_bound"], o["no_bounds"])
    if o["method"] == "consistent":      # the pull starts from physical bodies (.estimation.prior); bounds as published
        from .estimation.prior import physical_prior

        arm, prior_notes = physical_prior(arm, f"the prior {os.path.basename(str(prior_label))}")
    law = friction_option(arm, o["friction"], o["friction_terms"], o["friction_side"], o["smoothing"],
                          o["stribeck_velocity"], o["sigmoid_alpha"])
    weight = prior_weight_option(o["prior_weight"], o["method"])
    boot = o["bootstrap"]
    if isinstance(boot, bool) or not isinstance(boot, int) or boot < 0 or boot == 1:
        raise OptionError("{}: expected at least 2 replicates (0: none), got " + brace_safe(repr(boot)), "bootstrap")
    limits.check_count(boot, "bootstrap", "the number of replicates (each a whole refit)", "MAX_BOOTSTRAP")
    if o["scheduler"] is not None and not boot:
        raise OptionError("{}: only with {} N", "scheduler", "bootstrap")
    folds = o["band_folds"]
    if isinstance(folds, bool) or not isinstance(folds, (int, np.integer)) or not 0 <= folds <= 100 or folds == 1:
        raise OptionError("{}: expected 0 (no band) or 2 to 100, got " + brace_safe(repr(folds)), "band_folds")
    if o["torque_constant_reference"] is not None and not o["identify_torque_constants"]:
        raise OptionError("{}: only with {}", "torque_constant_reference", "identify_torque_constants")
    if o["scale_from_gravity"] is not None and not o["identify_torque_constants"]:
        raise OptionError("{}: only with {}", "scale_from_gravity", "identify_torque_constants")
    ref = o["torque_constant_reference"]
    if ref is not None and (isinstance(ref, (str, bytes)) or not hasattr(ref, "__iter__") or not all(
            isinstance(k, (int, np.integer)) and not isinstance(k, bool) and 1 <= k <= arm.n for k in ref) or not len(ref)):
        raise OptionError("{}: expected motor numbers 1 to " + f"{arm.n} (integers), got " + brace_safe(f"{ref!r:.60}"),
                          "torque_constant_reference")
    _check_target(arm, o["output"], o["armature"], o["friction_terms"], prior_label)
    tell = o["progress"] if o["progress"] is not None else (lambda stage, done=None, total=None: None)
    if not callable(tell):
        raise OptionError("{}: expected a callable progress(stage, done=None, total=None), got "
                          + brace_safe(f"{tell!r:.40}"), "progress")
    tell("reading the logs")
    read_options = dict(joint_names=o["joint_names"] if o["joint_names"] is not None else model_joint_names(arm),
                        columns=o["columns"], deg=o["deg"], rate=o["rate"], time_scale=o["time_scale"],
                        resample=o["resample"], cutoff=o["cutoff"], decimate=False if o["no_decimate"] else None,
                        topic=o["topic"], t_range=o["t_range"], extra_joints=o["extra_joints"])
    runs = _read(arm, logs, read_options, o["deg"], o["identify_torque_constants"])
    side, smoothing, law_notes = o["friction_side"], o["smoothing"], []
    if o["friction"] or o["friction_terms"] is not None:    # the side and smoothing not given: from the log
        from .inputs.choices import choose_friction_options
        from .inputs.runs import stack

        side, smoothing, law_notes = choose_friction_options(arm.transmission, stack([d for d, _ in runs]), side,
                                                             smoothing, smoothed=o["friction_terms"] is not None)
        law = friction_option(arm, o["friction"], o["friction_terms"], side, smoothing, o["stribeck_velocity"],
                              o["sigmoid_alpha"])
    tc, as_read = None, arm
    if o["identify_torque_constants"]:
        tell("torque constants from the currents")
        arm, runs, tc = _torque_constants(arm, runs, law, o["armature"], o["torque_constant_reference"],
                                          o["scale_from_gravity"])
    payload_logs = [os.path.basename(str(d.source)) for d, p in runs if p is not None]
    data = _known_payloads(arm, runs)
    labels, group_note = _trajectory_groups(runs, data)
    smoothing_table = None
    if o["smoothing"] is None and o["friction_terms"] is not None and smoothing is not None:
        tell("Coulomb smoothing by held-out error (a refit per candidate and fold)")
        smoothing, law, smoothing_table, note = _held_out_smoothing(arm, data, o, side, smoothing, bounds, weight,
                                                                    labels)
        # one note: the held-out choice names the noise level it started from (no second, contradicting one)
        law_notes = [x for x in law_notes if not x.startswith("Coulomb smoothing")] + [note]
    # joints at rest (.inputs.rest) with the friction terms of a real log's route (--friction-terms, a smoothed
    # sign); --friction keeps its sharp sign(qd) law at every speed, rest included (a simulated log's exact law:
    # taken as a static band at rest it cost the README's synthetic UR5 27 % on joint 6's residual).  The refits
    # (smoothing, shapes, band, bootstrap) fit with it, as the fit does; the prior weight's folds do not yet (with it
    # the Panda's weight fell from 1 to 0.1 and its replay lost joint 3 to the published model at 10 ms, issue 44)
    rest = rest_option(data, smoothing, law_notes) if o["friction_terms"] is not None else None
    shapes = None
    from ..model.friction import Friction
    from .inputs.options import SHAPED

    if isinstance(law, Friction) and set(law.terms) & set(SHAPED):
        from .estimation.varpro import fit_shapes

        tell("friction shapes (Stribeck, sigmoid) by variable projection")
        law, shapes = fit_shapes(arm, data, law, armature=o["armature"], rest=measured_rest(data, rest))
        if tc is not None:         # the gains again, with the fitted shapes
            arm, runs, tc = _torque_constants(as_read, _reread(runs, tc, arm), law, o["armature"],
                                              o["torque_constant_reference"], o["scale_from_gravity"])
            data = _known_payloads(arm, runs)
    extra = _extra_scale(arm, o, law, data)
    selection = None
    if weight == "auto":
        from .estimation.selection import (PRIOR_WEIGHT_FOLDS, choose_prior_weight, describe_weight_choice,
                                           fold_kind, fold_masks, one_se_choice)

        tell("prior weight by held-out error (a refit per weight and fold)")
        dt = float(np.median(np.diff(data.t))) if len(data.t) > 1 else None
        weight, selection = choose_prior_weight(arm, data.q, data.qd, data.qdd, data.tau, friction=law, dt=dt,
                                                armature=o["armature"], bounds=bounds, labels=labels,
                                                segments=data.segments, extra_scale=extra)
        _, why = one_se_choice(selection, "prior_weight", 0.0)
        law_notes.append(describe_weight_choice(selection, weight, why,
                                                fold_kind(fold_masks(len(data.q), PRIOR_WEIGHT_FOLDS, labels,
                                                                     segments=data.segments),
                                                          labels)))
    given_name = o["name"]
    name = given_name or _name_from(o["output"]) or f"{arm.name or 'arm'}_identified"
    segments = data.segments if len(data.segments) > 1 else None
    tell(f"fit ({o['method']})")
    result = fit(arm, data.q, data.qd, data.qdd, data.tau, method=o["method"], friction=law,
                 armature=o["armature"], bounds=bounds, name=name, prior_weight=weight, segments=segments,
                 extra_scale=extra, rest=rest)
    chosen = {"prior_weight": weight, "friction_side": side, "smoothing": smoothing}
    options = {k: chosen.get(k, o[k]) for k in PROVENANCE_KEYS}
    options = {k: v for k, v in options.items() if v is not None and v is not False and not (
        isinstance(v, (int, float)) and not isinstance(v, bool) and v == 0)}
    sources = getattr(data, "sources", [data.source])
    shas = [m.source_sha256 for m, _ in runs]
    prov = provenance(", ".join(os.path.basename(str(s)) for s in sources), o["method"], options, prior_label,
                      result.report["rms_residual"], sha256=", ".join(str(s) for s in shas))
    # the fitted range and the band travel with the model: in the provenance before its metadata is written
    if folds:
        tell(f"prediction band ({int(folds)} blocked hold-outs, a refit each)")
    refits = {}
    record, record_notes = fit_record(arm, data, folds=int(folds), smoothing=smoothing, method=o["method"],
                                      friction=law, armature=o["armature"], bounds=bounds, prior_weight=weight,
                                      segments=segments, labels=labels, refits=refits, extra_scale=extra, rest=rest)
    prov.update(record)
    if tc is not None:       # the constants and where their scale came from, in one line (payload.torque_constants)
        prov["torque_constants"] = tc.as_dict()["summary"]
    record_notes += rest_trust(prov, result, data, rest)
    doubts = fit_doubts(result, data, runs)
    if doubts:
        prov["doubts"] = doubts
    rep = dict(result.report)
    decided, decided_notes = decided_by(result, arm, weight, data, o["method"])
    if decided is not None:
        prov["decided"] = decided_record(decided)
        rep["decided"] = decided
    rep["fit_notes"] = units_notes(arm, data) + ([group_note] if group_note else []) + prior_notes + law_notes \
        + list(rep.get("fit_notes", [])) + decided_notes + record_notes + doubts + not_physical_notes(as_loaded,
                                                                                                      prior_label)
    rep["doubts"] = doubts
    if smoothing_table is not None:
        rep["smoothing_selection"] = smoothing_table
    if isinstance(law, Friction) or not isinstance(law, bool):
        if getattr(law, "side", "joint") == "motor" and np.array_equal(np.asarray(arm.transmission.R), np.eye(arm.n)):
            rep["fit_notes"] = list(rep.get("fit_notes", [])) + [
                "--friction-side motor: the model has no transmission (R = I, no gear ratios), so the motor "
                "side is the joint side; give the model a [transmission] for motor-side friction"]
    out = IdentifyResult(fit=result, prior=arm, prior_label=prior_label, data=data, friction=law,
                         armature=o["armature"], provenance=prov, metadata=model_metadata(prov), name=name,
                         named=given_name is not None, report_dict=rep, selection=selection, shapes=shapes,
                         torque_constants=tc, payload_logs=payload_logs, logs_label=_label(logs),
                         held_out=_held_out(refits, record, labels, folds))
    out.rename(name)
    if boot:
        from .uncertainty.bootstrap import bootstrap

        from .uncertainty.bootstrap import bootstrap_summary

        tell(f"bootstrap ({boot} refits)")
        bs = bootstrap(arm, data, boot, scheduler=o["scheduler"], method=o["method"], friction=law,
                       armature=o["armature"], bounds=bounds, prior_weight=weight, extra_scale=extra, rest=rest,
                       progress=lambda done, total: tell("bootstrap refits", done, total))
        out.bootstrap = bootstrap_summary(bs)     # its std and covariance go to the base model too
    if o["output"] is not None or o["base_json"] is not None:
        write_model_files(out, o["output"], o["base_json"])
    return out


def _extra_scale(arm, o, law, data):
    """The scales of the pull on the drive terms (:func:`.estimation.prior.extra_scales`), or None when the fit
    has none (not the consistent method, or no armature or friction identified)."""
    from ..model.parameters import parameter_names
    from .estimation.prior import extra_scales, prior_parameters

    if o["method"] != "consistent" or not (o["armature"] or law):
        return None
    names = parameter_names(arm.n, o["armature"], law)
    if len(names) <= 10 * arm.n:
        return None
    prior = prior_parameters(arm, o["armature"], law, len(names))
    return extra_scales(names, arm.n, data.qd, data.qdd, data.tau, prior[10 * arm.n:])


def _held_out(refits, record, labels, folds):
    """The band's hold-outs and refits as :class:`.results.result.HeldOut`, or None without a band: its kind the
    held-out trajectories when there are two or more, else the blocks."""
    from .results.result import HeldOut

    if record.get("prediction_band") is None or not refits.get("blocks"):
        return None
    kind = "trajectories" if refits.get("trajectories") else "blocks"
    return HeldOut(kind, int(folds), {k: v for k, v in refits.items() if v},
                   None if labels is None else np.asarray(labels))


def _trajectory_groups(runs, data):
    """``(labels, note)``: the held-out group of every stacked sample (runs repeating one trajectory share one,
    :mod:`.inputs.trajectories`), None with a single run; ``note`` names the groups."""
    from .inputs.trajectories import describe_groups, group_labels, repeat_groups

    if len(runs) < 2:
        return None, None
    groups = repeat_groups([(d.t, d.q) for d, _ in runs])
    names = [os.path.basename(str(d.source)) if d.source else f"run {k + 1}" for k, (d, _) in enumerate(runs)]
    note = "runs: " + describe_groups(groups, names) + (
        "; the band and the options are held out by trajectory" if len(groups) > 1 else "")
    return group_labels(data.segments, groups), note


def _held_out_smoothing(arm, data, o, side, v0, bounds, weight, labels=None):
    """``(smoothing, law, table, note)``: the Coulomb smoothing by blocked held-out error
    (:mod:`.inputs.smoothing`), starting from the noise-level choice ``v0`` (with ``--friction-terms``, whose
    fit has a rest threshold: each candidate's refits keep the joints at rest still at the threshold a fit with
    that smoothing would use)."""
    from .inputs.options import friction_option
    from .inputs.rest import rest_threshold
    from .inputs.smoothing import choose_smoothing

    def law_of(v):
        return friction_option(arm, o["friction"], o["friction_terms"], side, v, o["stribeck_velocity"],
                               o["sigmoid_alpha"])

    v, table, note = choose_smoothing(arm, data, law_of, v0, method=o["method"], armature=o["armature"],
                                      bounds=bounds, prior_weight=0.0 if weight == "auto" else weight, labels=labels,
                                      rest=lambda v: rest_threshold(data, v)[0])
    return v, law_of(v), table, note


def _reread(runs, tc, arm):
    """The runs' torques back to ``R^T i`` (unit gains), for a second estimate of ``k_t``."""
    R = np.asarray(arm.transmission.R, dtype=np.float64)
    undo = np.linalg.inv(R.T @ np.diag(tc.values) @ np.linalg.inv(R).T)
    out = []
    for data, payload in runs:
        tau = data.tau
        if payload is not None:      # _known_payloads subtracted it: put it back first
            tau = tau + payload.torque(arm, data.q, data.qd, data.qdd)
        notes = [n for n in data.notes if not n.startswith("payload: ")]
        out.append((_with_tau(data, tau @ undo.T, notes), payload))
    return out


def _label(logs) -> str:
    """The logs as the caller named them (paths as given), for the report."""
    items = [logs] if isinstance(logs, (str, os.PathLike)) or not hasattr(logs, "__iter__") else list(logs)
    return ", ".join(os.fspath(x) if isinstance(x, (str, os.PathLike))
                     else str(getattr(x, "path", None) or getattr(x, "source", None) or "log") for x in items)


def _with_tau(data, tau, notes):
    """A copy of the Measurements ``data`` with other torques and notes (everything else shared)."""
    import copy

    out = copy.copy(data)
    out.tau, out.notes = tau, list(notes)
    return out


def _name_from(output):
    if output is None:
        return None
    name = os.path.splitext(os.path.basename(os.fspath(output)))[0]
    return name[:-5] if name.endswith(".base") else name or None
