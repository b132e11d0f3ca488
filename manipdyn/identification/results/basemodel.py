"""The base model: identified base parameters written as JSON when no physical arm has them.

Layer 5 (identification).

``ols`` and ``wls`` identify the base parameters ``beta = K pi`` (:mod:`.base`).
When no arm with every ``J_i >= 0`` (or with a mass >= 0) reproduces them, no model
file can hold them, but they still predict torques: ``tau = Y_b beta``.  A base model
keeps exactly that, self-contained:

* ``format``: ``"manipdyn-base-model/1"``;
* ``prior``: the prior arm as text (``kind`` ``"toml"`` model file text or ``"urdf"``
  text with its ``tip``), which gives the kinematics and the regressor;
* ``armature``, ``friction``: the regressor's extra columns;
* ``base_parameters``: for each, its ``expression`` over the full parameters, ``value``
  and, for ``wls``, ``std`` (the standard deviation from the weighted least-squares
  covariance) and ``rel_std_percent`` (Gautier's relative standard deviation,
  ``100 std / |value|``);
* ``covariance``: the (r, r) covariance of the base parameters (row-major lists) for
  ``wls`` and ``consistent`` (:mod:`.uncertainty`), or null: the correlations that
  the per-parameter ``std`` leaves out (``manipdyn montecarlo --plants-from`` draws
  from it);
* ``parameters``: the full vector closest to the prior with ``K pi = beta`` (no sign or
  PSD constraint), used to predict: ``Y pi = Y_b beta`` for every state;
* ``provenance``: data file, its sha256, method, options, date;
* ``bootstrap`` (with ``identify --bootstrap N``): replicates, block, seed, failed
  replicates, and the block bootstrap's ``std`` and ``covariance`` of the base parameters
  (:func:`~manipdyn.identification.uncertainty.bootstrap.bootstrap_summary`), which ``--plants-from``
  draws from in place of ``covariance``: it keeps the residuals' correlation over time.

:func:`load_base_model` reads it back; :meth:`BaseModel.inverse_dynamics` predicts.
Both are what ``manipdyn validate BASE.json DATA`` uses.
"""

from __future__ import annotations

import json
import math
import os

import numpy as np

from ..._support import limits
from ..._support.files import atomic_write_text
from ..._support.errors import ModelError
from ..estimation.report import friction_to_json

__all__ = ["BASE_MODEL_FORMAT", "BaseModel", "base_model_dict", "write_base_model", "load_base_model",
           "prior_text"]

BASE_MODEL_FORMAT = "manipdyn-base-model/1"


def prior_text(arm) -> dict:
    """The prior as self-contained text: ``{"kind": "toml"|"urdf", "text": ..., "tip": ...}``."""
    from ...model.arm import Manipulator
    from ...formats.save import to_toml

    if isinstance(arm, Manipulator):
        return {"kind": "toml", "text": to_toml(arm), "tip": None}
    src = getattr(arm, "source_urdf", None)
    if not src:
        raise ModelError(f"prior {arm.name!r}: has neither model-file nor URDF text to embed")
    return {"kind": "urdf", "text": src, "tip": getattr(arm, "tip", None)}


def friction_from_json(value, n: int):
    """The regressor's ``friction=`` of :func:`friction_to_json`'s output."""
    if isinstance(value, bool):
        return value
    if not isinstance(value, dict) or not isinstance(value.get("terms"), list):
        raise ValueError("key 'friction': expected true, false or {terms: [...], side: ...}")
    from ...model.friction import Friction

    z = np.zeros(n)
    kw = {}
    for t in value["terms"]:
        if t == "asymmetric":
            kw.update(coulomb_pos=z, coulomb_neg=z)
        elif t == "stribeck":
            kw.update(stribeck_level=z, stribeck_velocity=value["stribeck_velocity"])
        elif t == "sigmoid":
            kw.update(sigmoid_A=z, sigmoid_alpha=value["sigmoid_alpha"], sigmoid_p3=value["sigmoid_p3"])
        else:
            kw[t] = z
    return Friction(**kw, side=value.get("side", "joint"), smoothing=value.get("smoothing", 0.0),
                    deadband=value.get("deadband", 0.0), stribeck_exponent=value.get("stribeck_exponent", 2.0), n=n)


def _finite(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _covariance_rows(cov):
    if cov is None or not np.all(np.isfinite(cov)):
        return None
    return [[float(x) for x in row] for row in np.asarray(cov)]


def base_model_dict(result, prior: dict, provenance: dict, bootstrap: dict | None = None) -> dict:
    """The JSON-ready base model of a :class:`FitResult` (module docstring); ``bootstrap``: the
    :func:`~manipdyn.identification.uncertainty.bootstrap.bootstrap_summary` of the same fit, if any."""
    rep = result.report
    rows = []
    for row in rep["base_parameters"]:
        rows.append({k: (_finite(v) if isinstance(v, float) else v) for k, v in row.items()})
    return {
        "format": BASE_MODEL_FORMAT,
        "name": rep.get("name") or result.prior.name,
        "prior": prior,
        "method": result.method,
        "armature": bool(result.base.armature),
        "friction": friction_to_json(result.base.friction, result.prior.n),
        "base_columns": [int(i) for i in result.base.independent],
        "condition_number": _finite(result.condition_number),
        "noise_sigma": [float(x) for x in result.sigma],
        "rms_residual": rep["rms_residual"],
        "base_parameters": rows,
        "covariance": _covariance_rows(getattr(result, "covariance", None)),
        "parameters": [float(x) for x in result.parameters],
        "why_no_model": result.arm_error,
        "provenance": provenance,
        **({} if bootstrap is None else {"bootstrap": bootstrap}),
    }


def write_base_model(path, result, prior: dict, provenance: dict, bootstrap: dict | None = None) -> None:
    """Write :func:`base_model_dict` as strict JSON, atomically."""
    atomic_write_text(path, json.dumps(base_model_dict(result, prior, provenance, bootstrap), indent=2,
                                       allow_nan=False) + "\n")


class BaseModel:
    """A base model read back: the prior arm, the regressor flags and the parameters.

    Attributes
    ----------
    arm : manipdyn.Arm
        The prior (kinematics and regressor).
    parameters : (p,)
        Full parameters reproducing the base parameters.
    beta, std : (r,)
        Base parameter values and standard deviations (NaN where the file has none).
    covariance : (r, r) or None
        Their covariance, when the file has one.
    armature, friction : bool
    data : dict
        The whole JSON object.
    """

    def __init__(self, data: dict, arm, origin: str):
        self.data, self.arm, self.origin = data, arm, origin
        self.name = str(data.get("name") or arm.name)
        self.armature = bool(data["armature"])
        self.friction = friction_from_json(data["friction"], arm.n)
        cols = data.get("base_columns")
        self.base_columns = None if cols is None else np.asarray(cols, dtype=int)
        self.parameters = np.asarray(data["parameters"], dtype=np.float64)
        rows = data["base_parameters"]
        self.beta = np.array([r["value"] for r in rows], dtype=np.float64)
        self.std = np.array([np.nan if r.get("std") is None else r["std"] for r in rows], dtype=np.float64)
        cov = data.get("covariance")
        self.covariance = None if cov is None else np.array(cov, dtype=np.float64)
        if self.covariance is not None and self.covariance.shape != (len(rows), len(rows)):
            raise ValueError(f"key 'covariance': expected {len(rows)} x {len(rows)} numbers, "
                             f"got shape {self.covariance.shape}")
        self.n = arm.n

    def prediction_std(self, q, qd, qdd) -> np.ndarray | None:
        """Standard deviation of the predicted torque from the base parameters' covariance,
        ``sqrt(diag(Y_b C Y_b^T))`` (N m), (n,) or (N, n); None when the file has no covariance.
        It is the model's uncertainty only: a measurement adds its own noise (``noise_sigma``)."""
        if self.covariance is None or self.base_columns is None:
            return None
        Y = self.arm.lagrange.regressor(q, qd, qdd, armature=self.armature, friction=self.friction)
        Yb = Y[..., self.base_columns]
        return np.sqrt(np.maximum(np.einsum("...ik,kl,...il->...i", Yb, self.covariance, Yb), 0.0))

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """Predicted joint torques ``Y(q, qd, qdd) pi`` (N m or N), (n,) or (N, n).

        The trace form's regressor of the prior with the file's armature/friction columns;
        where those were not identified, the prior's own armature and friction torques are
        added (as :meth:`FitResult.predict` does).
        """
        from ..estimation.fitting import known_torque

        Y = self.arm.lagrange.regressor(q, qd, qdd, armature=self.armature, friction=self.friction)
        return Y @ self.parameters + known_torque(self.arm, qd, qdd, self.armature, self.friction)


class _HugeInt(str):
    """An integer literal too long for any field of a base model (kept as its text)."""


def _int_or_huge(text):
    return _HugeInt(text) if len(text.lstrip("-")) > 18 else int(text)


def strict_json(text: str, where: str):
    """``text`` parsed as strict JSON, a ModelError naming ``where`` and the key otherwise: no
    NaN or Infinity, no integer over 18 digits, nested at most
    :data:`manipdyn.limits.MAX_JSON_DEPTH` deep."""
    deep = (f"{where}: nested deeper than the limit of {limits.MAX_JSON_DEPTH} "
            "(manipdyn.limits.MAX_JSON_DEPTH)")
    try:
        data = json.loads(text, parse_int=_int_or_huge)
    except json.JSONDecodeError as exc:
        raise ModelError(f"{where}: not JSON (line {exc.lineno}: {exc.msg})") from None
    except RecursionError:
        raise ModelError(deep) from None
    stack = [(data, 0, "")]
    while stack:
        x, depth, key = stack.pop()
        if depth > limits.MAX_JSON_DEPTH:
            raise ModelError(deep + f" at key {key!r}")
        if isinstance(x, _HugeInt):
            raise ModelError(f"{where}: key {key!r}: an integer of {len(x.lstrip('-'))} digits; expected a number "
                             "float64 holds")
        if isinstance(x, float) and not math.isfinite(x):
            raise ModelError(f"{where}: key {key!r}: {x!r} is not strict JSON; expected a finite number")
        if isinstance(x, dict):
            stack.extend((v, depth + 1, f"{key}.{k}" if key else str(k)) for k, v in x.items())
        elif isinstance(x, list):
            stack.extend((v, depth + 1, f"{key}[{i}]") for i, v in enumerate(x))
    return data


def _numbers(value, where, key, shape=None, nullable=False, nonnegative=False):
    """``value`` as a float array of finite numbers (None -> NaN when ``nullable``), or a
    ModelError naming ``key``."""
    def ok(x):
        return (x is None and nullable) or (isinstance(x, (int, float)) and not isinstance(x, bool))

    flat = value if isinstance(value, list) else [value]
    rows = [r for r in flat if isinstance(r, list)] if shape and len(shape) == 2 else None
    items = [x for r in rows for x in r] if rows is not None and len(rows) == len(flat) else flat
    if not all(ok(x) for x in items):
        bad = next(x for x in items if not ok(x))
        raise ModelError(f"{where}: key {key!r}: expected numbers{' or null' if nullable else ''}, got {bad!r:.60}")
    arr = np.array([np.nan if x is None else float(x) for x in items], dtype=np.float64)
    if shape is not None and arr.size != int(np.prod(shape)):
        raise ModelError(f"{where}: key {key!r}: expected {' x '.join(map(str, shape))} numbers, got {arr.size}")
    real = arr[~np.isnan(arr)] if nullable else arr
    if not np.all(np.isfinite(real)):
        raise ModelError(f"{where}: key {key!r}: expected finite numbers")
    limits.check_magnitude(real, where, key)
    if nonnegative and np.any(real < 0):
        raise ModelError(f"{where}: key {key!r}: a standard deviation (or variance) is negative: "
                         f"{float(real[real < 0][0]):g}")
    return arr if shape is None else arr.reshape(shape)


def check_numbers(data: dict, where: str, p: int) -> None:
    """Refuse the hostile numbers of a base model, naming the key: non-finite or null
    parameters and values, negative standard deviations or variances, base columns out of
    range, a covariance of the wrong shape (``p`` full parameters)."""
    _numbers(data["parameters"], where, "parameters", shape=(p,))
    rows = data["base_parameters"]
    if not isinstance(rows, list) or not rows or not all(isinstance(r, dict) for r in rows):
        raise ModelError(f"{where}: key 'base_parameters': expected a list of objects")
    r = len(rows)
    _numbers([row.get("value") for row in rows], where, "base_parameters[].value")
    _numbers([row.get("std") for row in rows], where, "base_parameters[].std", nullable=True, nonnegative=True)
    cols = data.get("base_columns")
    if cols is not None:
        if not (isinstance(cols, list) and len(cols) == r and all(isinstance(c, int) and not isinstance(c, bool)
                                                                  and 0 <= c < p for c in cols)
                and len(set(cols)) == r):
            raise ModelError(f"{where}: key 'base_columns': expected {r} distinct column indices in [0, {p})")
    for key in ("noise_sigma",):
        if data.get(key) is not None:
            _numbers(data[key], where, key, nonnegative=True)
    if data.get("covariance") is not None:
        if not isinstance(data["covariance"], list) or len(data["covariance"]) != r:
            raise ModelError(f"{where}: key 'covariance': expected {r} rows of {r} numbers")
        cov = _numbers(data["covariance"], where, "covariance", shape=(r, r))
        if np.any(np.diag(cov) < 0):
            raise ModelError(f"{where}: key 'covariance': a variance (diagonal entry) is negative")


def load_base_model(path) -> BaseModel:
    """Read a base model JSON file (module docstring); errors name the file and the key."""
    where = os.fspath(path)
    try:
        text = limits.read_regular(where, where, "MAX_FILE_BYTES", what="the base model").decode("utf-8")
    except UnicodeDecodeError:
        raise ModelError(f"{where}: not UTF-8 text; expected a base model JSON file") from None
    data = strict_json(text, where)
    if not isinstance(data, dict) or data.get("format") != BASE_MODEL_FORMAT:
        raise ModelError(f"{where}: key 'format': expected {BASE_MODEL_FORMAT!r}")
    for key in ("prior", "armature", "friction", "base_parameters", "parameters"):
        if key not in data:
            raise ModelError(f"{where}: missing key {key!r}")
    prior = data["prior"]
    if not isinstance(prior, dict) or prior.get("kind") not in ("toml", "urdf") or not isinstance(
            prior.get("text"), str):
        raise ModelError(f"{where}: key 'prior': expected {{kind: 'toml'|'urdf', text: ...}}")
    if prior["kind"] == "urdf" and not prior["text"].lstrip("\ufeff \t\r\n").startswith("<"):
        # the text itself, never a name or a path to open: a file received from someone else
        # must not make manipdyn read a file of this machine
        raise ModelError(f"{where}: key 'prior.text': expected the prior's URDF text (starting with '<'), "
                         f"got {prior['text']!r:.60}; a base model carries its prior, it never names a file")
    if prior.get("tip") is not None and not isinstance(prior["tip"], str):
        raise ModelError(f"{where}: key 'prior.tip': expected a link name or null, got {prior['tip']!r:.60}")
    try:
        if prior["kind"] == "toml":
            from ...formats.modelfile import parse_model

            arm = parse_model(prior["text"], origin=f"{where} (prior)")
        else:
            from ...formats.urdf.reader import load_urdf

            arm = load_urdf(prior["text"], tip=prior.get("tip"))
    except ModelError as exc:
        raise ModelError(f"{where}: key 'prior': {exc}") from None
    from ...model.parameters import parameter_count

    try:
        friction = friction_from_json(data["friction"], arm.n)
    except (ValueError, KeyError, TypeError) as exc:
        raise ModelError(f"{where}: {exc}") from None
    want = parameter_count(arm.n, bool(data["armature"]), friction)
    if not isinstance(data["parameters"], list) or len(data["parameters"]) != want:
        raise ModelError(f"{where}: key 'parameters': expected {want} numbers for this prior")
    check_numbers(data, where, want)
    try:
        return BaseModel(data, arm, where)
    except (TypeError, ValueError, KeyError) as exc:
        raise ModelError(f"{where}: malformed base model ({exc})") from None
