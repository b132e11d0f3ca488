"""Several logs in one identification: RUNS.toml, known payloads, each log read on its own.

Layer 5 (identification).

A robot is excited several times (different trajectories, with and without a payload).
Each run is read, filtered and resampled on its own (:func:`read_runs`: no derivative
crosses a file boundary), then the runs are stacked (:func:`stack`) with their
boundaries kept (``Measurements.segments``), so a fit weighs each joint by its noise in
each run.  ``--logs RUNS.toml`` lists the runs::

    [[log]]
    path = "run1.csv"                 # relative to RUNS.toml, or absolute
    t_range = [0.0, 30.0]             # optional; also rate (Hz) and columns, as on the command line
    [[log]]
    path = "run2.csv"
    payload = { mass = 2.8, com = [0.0, 0.0, 0.05], inertia = [0.006, 0.006, 0.004, 0.0, 0.0, 0.0] }

A payload is rigidly attached at the tool frame (the frame of ``arm.fkine``): ``mass`` in
kg, ``com`` in m in that frame, the optional ``inertia`` ``[ixx, iyy, izz, ixy, ixz, iyz]``
about the COM in kg m^2 (tensor sign, tool-frame axes; default 0, a point mass).  Its
torque is known (:meth:`Payload.torque`: its ten parameters on the last link's regressor
columns, :func:`.payload.fit.payload_parameter_map`), so a fit moves it to the known side:
``tau - tau_payload = Y pi``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..._support.errors import ModelError
from ...formats.logs.measurements import Measurements

__all__ = ["Payload", "LogSpec", "read_runs_file", "as_log_specs", "read_runs", "stack", "RUN_KEYS"]

#: the keys of a ``[[log]]`` table
RUN_KEYS = ("path", "t_range", "rate", "columns", "payload")
#: the keys of its ``payload``
PAYLOAD_KEYS = ("mass", "com", "inertia")


@dataclass(frozen=True)
class Payload:
    """A known rigid payload at the tool frame: ``mass`` kg, ``com`` (3,) m, ``inertia``
    (6,) ``[ixx, iyy, izz, ixy, ixz, iyz]`` kg m^2 about the COM (tensor sign, tool-frame axes)."""

    mass: float
    com: tuple
    inertia: tuple = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self):
        """Checked as RUNS.toml's payload is: a mass in (0, MAX_PAYLOAD_MASS] kg, a com within
        MAX_LENGTH m, inertia entries within MAX_INERTIA kg m^2 (:mod:`manipdyn.limits`)."""
        object.__setattr__(self, "mass", _number(self.mass, "Payload: mass", positive=True))
        object.__setattr__(self, "com", _numbers(self.com, 3, "Payload: com"))
        object.__setattr__(self, "inertia", _numbers(self.inertia, 6, "Payload: inertia"))
        _payload_ranges(self, "Payload")

    def parameters(self) -> np.ndarray:
        """``[m, m c, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]`` (10,), tensor about the tool frame's origin."""
        from ...model.inertia import parameters_from_pseudo_inertia, pseudo_inertia_from_tensor

        ixx, iyy, izz, ixy, ixz, iyz = self.inertia
        I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=np.float64)
        return parameters_from_pseudo_inertia(pseudo_inertia_from_tensor(self.mass, np.asarray(self.com), I))

    def regressor(self, arm, q, qd, qdd) -> np.ndarray:
        """``Y_P`` (N, n, 10): the joint torque of a unit of each payload parameter."""
        from ...model.inertia import parameters_from_pseudo_inertia, transform_pseudo_inertia
        from ...model.parameters import PARAMETER_BASIS

        _, tool = arm.chain()
        k = arm.n - 1
        G = parameters_from_pseudo_inertia(transform_pseudo_inertia(PARAMETER_BASIS, tool)).T   # .payload's map
        return arm.lagrange.regressor(q, qd, qdd)[..., 10 * k:10 * k + 10] @ G

    def torque(self, arm, q, qd, qdd) -> np.ndarray:
        """The payload's joint torque (N, n), N m: gravity and inertia of the load on ``arm``."""
        return self.regressor(arm, q, qd, qdd) @ self.parameters()


@dataclass(frozen=True)
class LogSpec:
    """One run: the log's ``path`` and what RUNS.toml may say of it (None: the common option)."""

    path: str
    t_range: tuple | None = None
    rate: float | None = None
    columns: object = None
    payload: Payload | None = None
    #: where it was listed (``RUNS.toml: [[log]] 2``), for messages; None when built in Python
    origin: str | None = field(default=None, compare=False)

    def __post_init__(self):
        if not isinstance(self.path, (str, os.PathLike)) or not os.fspath(self.path) or "\x00" in os.fspath(self.path):
            raise ModelError(f"LogSpec: path: expected a file name (without NUL), got {self.path!r:.60}")
        object.__setattr__(self, "path", os.fspath(self.path))
        if self.t_range is not None:
            t = _numbers(list(self.t_range) if isinstance(self.t_range, (tuple, list)) else self.t_range, 2,
                         "LogSpec: t_range")
            if not t[0] < t[1]:
                raise ModelError(f"LogSpec: t_range: expected (t0, t1) with t0 < t1, got {t}")
            object.__setattr__(self, "t_range", t)
        if self.rate is not None:
            object.__setattr__(self, "rate", _number(self.rate, "LogSpec: rate", positive=True))
        if self.columns is not None and not isinstance(self.columns, (str, dict)):
            raise ModelError(f"LogSpec: columns: expected 'q=Joint_{{i}},tau=Effort_{{i}}' or a dict, got "
                             f"{type(self.columns).__name__}")
        if self.payload is not None and not isinstance(self.payload, Payload):
            raise ModelError(f"LogSpec: payload: expected a Payload(mass, com, inertia) or None, got "
                             f"{type(self.payload).__name__}")


def _where(origin, i, key=None):
    return f"{origin}: [[log]] {i + 1}" + (f": key '{key}'" if key else "")


def _number(value, where, positive=False):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ModelError(f"{where}: expected a finite number, got {value!r:.60}")
    try:
        x = float(value)
    except OverflowError:      # an integer of hundreds of digits
        raise ModelError(f"{where}: expected a finite number, got an integer of {len(str(abs(int(value))))} "
                         "digits (beyond the float range)") from None
    if not math.isfinite(x):
        raise ModelError(f"{where}: expected a finite number, got {value!r:.60}")
    if positive and not x > 0:
        raise ModelError(f"{where}: expected a number > 0, got {value!r:.60}")
    return x


def _numbers(value, k, where):
    if isinstance(value, tuple):
        value = list(value)
    if not isinstance(value, list) or len(value) != k:
        raise ModelError(f"{where}: expected a list of {k} numbers, got {value!r:.80}")
    return tuple(_number(v, where) for v in value)


def _payload_ranges(p: "Payload", where: str) -> None:
    """A payload's numbers within the limits of real loads (:mod:`manipdyn.limits`)."""
    from ..._support import limits

    if p.mass > limits.MAX_PAYLOAD_MASS:
        raise ModelError(f"{where}.mass: {p.mass:g} kg, over the limit of {limits.MAX_PAYLOAD_MASS:g} kg "
                         "(manipdyn.limits.MAX_PAYLOAD_MASS; the heaviest industrial arms carry some 2 t): "
                         "not in kg? Raise the limit for a trusted load")
    limits.check_range(p.com, where, "com", "length")
    limits.check_range(p.inertia, where, "inertia", "inertia")


def _payload(raw, where) -> Payload:
    if not isinstance(raw, dict):
        raise ModelError(f"{where}: expected a table {{mass, com, inertia}}, got {raw!r:.80}")
    unknown = sorted(set(raw) - set(PAYLOAD_KEYS))
    if unknown:
        raise ModelError(f"{where}.{unknown[0]}: unknown key; a payload has {', '.join(PAYLOAD_KEYS)}")
    for key in ("mass", "com"):
        if key not in raw:
            raise ModelError(f"{where}.{key}: missing (a payload needs mass in kg and com in m, tool frame)")
    mass = _number(raw["mass"], f"{where}.mass", positive=True)
    com = _numbers(raw["com"], 3, f"{where}.com")
    inertia = _numbers(raw.get("inertia", [0.0] * 6), 6, f"{where}.inertia")
    try:
        p = Payload(mass, com, inertia)
    except ModelError as exc:
        raise ModelError(str(exc).replace("Payload", where, 1)) from None
    try:
        J = p.parameters()
        from ...model.inertia import pseudo_inertia_from_parameters

        ev = np.linalg.eigvalsh(pseudo_inertia_from_parameters(J))
    except ModelError as exc:
        raise ModelError(f"{where}.inertia: {exc}") from None
    if ev[0] < -1e-9 * max(ev[-1], 1e-300):
        raise ModelError(f"{where}.inertia: no rigid body has this inertia about its COM (principal moments "
                         "must be >= 0 and obey the triangle inequality)")
    return p


def _spec(raw, i, origin, base) -> LogSpec:
    if not isinstance(raw, dict):
        raise ModelError(f"{_where(origin, i)}: expected a table, got {raw!r:.60}")
    unknown = sorted(set(raw) - set(RUN_KEYS))
    if unknown:
        raise ModelError(f"{_where(origin, i, unknown[0])}: unknown; a [[log]] has {', '.join(RUN_KEYS)}")
    if "path" not in raw:
        raise ModelError(f"{_where(origin, i, 'path')}: missing (the log file, relative to the RUNS file or absolute)")
    path = raw["path"]
    if not isinstance(path, str) or not path or "\x00" in path:
        raise ModelError(f"{_where(origin, i, 'path')}: expected a file name (without NUL), got {path!r:.60}")
    path = path if os.path.isabs(path) else os.path.join(base, path)
    t_range = None
    if "t_range" in raw:
        t_range = _numbers(raw["t_range"], 2, _where(origin, i, "t_range"))
        if not t_range[0] < t_range[1]:
            raise ModelError(f"{_where(origin, i, 't_range')}: expected [t0, t1] with t0 < t1, got {list(t_range)}")
    rate = _number(raw["rate"], _where(origin, i, "rate"), positive=True) if "rate" in raw else None
    columns = raw.get("columns")
    if columns is not None and not isinstance(columns, (str, dict)):
        raise ModelError(f"{_where(origin, i, 'columns')}: expected 'q=Joint_{{i}},tau=Effort_{{i}}' or a table, "
                         f"got {columns!r:.60}")
    if columns is not None:             # its patterns checked here, where the key and [[log]] are known
        from ...formats.logs.columns import column_map

        column_map(columns, where=_where(origin, i, "columns"))
    payload = _payload(raw["payload"], _where(origin, i, "payload")) if "payload" in raw else None
    return LogSpec(path, t_range, rate, columns, payload, origin=_where(origin, i))


def read_runs_file(path) -> list[LogSpec]:
    """The runs of a RUNS.toml file (module docstring); a bad entry raises a
    :class:`~manipdyn.ModelError` naming the key and the ``[[log]]`` index (from 1)."""
    from ..._support import limits
    from ...formats.tomltext import read_toml_text

    where = os.fspath(path)
    raw = limits.read_regular(where, where, "MAX_MODEL_FILE_BYTES", "the runs file", "the runs file")
    try:                       # a regular file of bounded size: not a FIFO, not /dev/zero
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ModelError(f"{where}: not a TOML file: {exc}") from None
    data = read_toml_text(text, where, "runs file")
    extra = sorted(set(data) - {"log"})
    if extra:
        raise ModelError(f"{where}: key '{extra[0]}': unknown; a runs file holds [[log]] tables only")
    runs = data.get("log")
    if not isinstance(runs, list) or not runs:
        raise ModelError(f"{where}: no [[log]] table (each names one log: path = \"run1.csv\")")
    limits.check_count(len(runs), where, "the number of [[log]] entries", "MAX_RUNS")
    base = os.path.dirname(os.path.abspath(where))
    return [_spec(raw, i, where, base) for i, raw in enumerate(runs)]


def as_log_specs(logs) -> list:
    """``logs`` as a list of :class:`LogSpec` and :class:`Measurements`: a path, a RUNS.toml
    (expanded), a LogSpec, Measurements, or a sequence of these."""
    if isinstance(logs, (str, os.PathLike, LogSpec, Measurements)):
        logs = [logs]
    if not isinstance(logs, (list, tuple)):
        raise ModelError(f"logs: expected a file name, a RUNS.toml, a LogSpec, Measurements or a list of these, "
                         f"got {type(logs).__name__}")
    out = []
    for x in logs:
        if isinstance(x, (LogSpec, Measurements)):
            out.append(x)
        elif isinstance(x, (str, os.PathLike)):
            s = os.fspath(x)
            out.extend(read_runs_file(s) if s.lower().endswith(".toml") else [LogSpec(s)])
        else:
            raise ModelError(f"logs: expected file names, RUNS.toml files, LogSpec or Measurements, got "
                             f"{type(x).__name__}")
    if not out:
        raise ModelError("logs: no log given")
    return out


def read_runs(logs, arm, *, transmission=None, **read_options) -> list[tuple[Measurements, Payload | None]]:
    """Read every run on its own: ``[(measurements, payload or None), ...]``.

    ``logs``: as :func:`as_log_specs` takes them; ``read_options``: the keyword arguments of
    :func:`~manipdyn.identification.read_log` common to every run (a run's own ``t_range``,
    ``rate`` and ``columns`` replace them).  ``transmission``: default ``arm.transmission``.
    """
    from ...formats.logs.read import read_log

    tr = arm.transmission if transmission is None else transmission
    out, seen = [], {}
    specs = as_log_specs(logs)
    from ..._support import limits

    limits.check_count(len(specs), "logs", "the number of runs", "MAX_RUNS")
    for k, spec in enumerate(specs):
        if isinstance(spec, Measurements):
            out.append((spec, None))
            continue
        opts = dict(read_options)
        for key in ("t_range", "rate", "columns"):
            if getattr(spec, key) is not None:
                opts[key] = getattr(spec, key)
        try:
            m = read_log(spec.path, arm.n, transmission=tr, **opts)
        except ModelError as exc:
            if spec.origin is None:
                raise
            raise ModelError(f"{spec.origin}: {exc}") from None      # which [[log]] of which RUNS file
        # the same data twice is not a second experiment: it would shrink the standard deviations
        # by sqrt(2) with nothing learnt (the same file under two names, or one file listed twice)
        key = (m.source_sha256, repr(sorted(opts.items(), key=lambda kv: kv[0])), spec.payload)
        if m.source_sha256 is not None and key in seen:
            raise ModelError(f"logs: run {k + 1} ({spec.path}) is the same data as run {seen[key] + 1} "
                             f"({specs[seen[key]].path}): same sha256 {m.source_sha256[:16]}..., same window and "
                             "options; a run counted twice shrinks every standard deviation by sqrt(2). List "
                             "each run once (a different t_range of one file is a different run)")
        seen.setdefault(key, k)
        out.append((m, spec.payload))
    return out


def stack(parts) -> Measurements:
    """One :class:`Measurements` of several runs in order, with ``segments`` (the runs' sample
    counts), ``sources`` (their files) and each run's notes prefixed with its file name."""
    parts = list(parts)
    if len(parts) == 1:
        m = parts[0]
        m.segments = [len(m)]
        m.sources = [m.source]
        return m
    cat = lambda name: np.concatenate([getattr(m, name) for m in parts])   # noqa: E731
    notes = []
    for m in parts:
        label = os.path.basename(m.source) if m.source else "run"
        notes += [f"{label}: {note}" for note in m.notes]
    qd_motor = cat("qd_motor") if all(m.qd_motor is not None for m in parts) else None
    counts = np.array([len(m) for m in parts], dtype=np.float64)
    noise = None            # the velocity's noise level, RMS over the runs' samples (choices.coulomb_smoothing)
    if all(getattr(m, "qd_noise", None) is not None for m in parts):
        noise = np.sqrt(counts @ np.array([np.square(m.qd_noise) for m in parts]) / counts.sum())
    signals = tuple(dict.fromkeys(s for m in parts for s in getattr(m, "motor_signals", ())))
    rates = {m.rate for m in parts}
    out = Measurements(cat("t"), cat("q"), cat("qd"), cat("qdd"), cat("tau"), derived=any(m.derived for m in parts),
                       notes=notes, rate=parts[0].rate if len(rates) == 1 else None, cutoff=None,
                       decimation=1, qd_motor=qd_motor, measured_qd=all(m.measured_qd for m in parts),
                       source=", ".join(str(m.source) for m in parts), source_sha256=None, qd_noise=noise,
                       motor_signals=signals)
    out.segments = [len(m) for m in parts]
    out.sources = [m.source for m in parts]
    return out
