"""One entry point for measurement logs as they come: :func:`read_log`.

Layer 2 (formats: logs).

A log is a CSV file (:mod:`~manipdyn.formats.logs.table`, columns found
by name through :mod:`~manipdyn.formats.logs.columns`) or a ROS bag of
``sensor_msgs/msg/JointState`` (:mod:`~manipdyn.formats.logs.rosbag`).
Its samples go through, in this order:

1. units: ``deg`` positions (and velocities, accelerations) to rad; the
   ``t`` column times ``time_scale`` to s;
2. the drive (:mod:`~manipdyn.formats.logs.motor`): motor-side positions,
   velocities, torques or currents to the joints;
3. the time base (:mod:`~manipdyn.formats.logs.timebase`): duplicate rows
   dropped (but rows of an arm at rest, measured velocities exactly zero, kept),
   gaps found, a uniform grid (linear interpolation);
4. derivatives (:mod:`~manipdyn.formats.logs.filtering`): when ``qd`` and
   ``qdd`` are both measured they are used as they are (nothing filtered);
   when only ``qd`` is, it is filtered and differentiated for ``qdd``;
   otherwise both come from q.  The cut-off is chosen from the data unless
   ``cutoff`` is given, then the samples are decimated;
5. the time window ``t_range``.

Every step adds a line to ``Measurements.notes``.
"""

from __future__ import annotations

import math
import numbers
import os

import numpy as np

from ..._support.errors import ModelError
from ..._support.limits import check_signals
from .columns import column_map
from .filtering import choose_cutoff, decimation_factor, edge_samples, velocity_noise, zero_phase
from .measurements import Measurements
from .motor import as_drive
from .rosbag import is_bag, read_joint_states
from .table import read_table
from .timebase import uniform_samples

__all__ = ["read_log", "as_t_range", "model_joint_names"]


def model_joint_names(arm):
    """The model's joint names in order (a ROS bag's joint states are mapped by them), or None when a
    joint has no name."""
    names = getattr(arm, "joint_names", None)
    if names:
        return list(names)
    names = [getattr(link, "name", "") for link in getattr(arm, "links", ())]
    return names if names and all(names) else None


def _deg_factors(deg, n, where):
    if isinstance(deg, (bool, np.bool_)) or deg is None:
        return np.full(n, math.pi / 180 if deg else 1.0)
    flags = list(deg)
    if len(flags) != n:
        raise ModelError(f"{where}: deg: expected True, False or {n} flags (one per joint), got {len(flags)}")
    return np.array([math.pi / 180 if f else 1.0 for f in flags])


def _from_csv(path, n, where, columns, deg, time_scale, drive_args, rate, extra_joints=False):
    table = read_table(path, where)
    cmap = column_map(columns)
    index, unused = cmap.resolve(table.header, n, where, extra_joints)
    notes = []
    if unused:
        notes.append(f"columns: ignored {len(unused)} column(s) no signal maps to: {', '.join(unused[:12])}"
                     + (" ..." if len(unused) > 12 else ""))
    d = table.data
    get = {s: d[:, ks] for s, ks in index.items() if s != "t"}
    t = None
    if "t" in index and rate is None:
        with np.errstate(over="ignore"):
            t = d[:, index["t"][0]] * float(time_scale)
        if not np.all(np.isfinite(t)):
            k = int(np.flatnonzero(~np.isfinite(t))[0])
            raise ModelError(f"{where}: row {table.rows[k]}: t = {float(d[k, index['t'][0]])!r} times time_scale "
                             f"(--time-scale) {float(time_scale):g} overflows float64; expected seconds per unit of t")
        if time_scale != 1:
            notes.append(f"time: column {cmap.patterns['t']!r} scaled by {time_scale:g} to s")
    scale = _deg_factors(deg, n, where)
    pos = get.get("q", get.get("qm"))
    if np.any(scale != 1) and pos is not None and pos.size and np.abs(pos[:, scale != 1]).max() <= 2 * math.pi:
        notes.append("units: every position read in degrees lies within +-6.3 degrees (2 pi): radians read as "
                     "degrees (drop deg= / --deg)?")
    if np.any(scale != 1):
        for s in ("q", "qd", "qdd", "qm", "qdm"):
            if s in get:
                get[s] = get[s] * scale
        notes.append(f"units: positions, velocities and accelerations of joint(s) "
                     f"{[j + 1 for j in np.flatnonzero(scale != 1)]} read in degrees")
    motor = [s for s in ("qm", "qdm", "taum", "i") if s in get]
    drive = as_drive(n, **drive_args)
    if motor:
        if drive is None:
            raise ModelError(f"{where}: motor-side column(s) {', '.join(cmap.patterns[s] for s in motor)} need the "
                             "transmission: give transmission= (R, motor_offset, torque_constant)")
        if "i" in get and drive.torque_constant is None:
            raise ModelError(f"{where}: current columns {cmap.patterns['i']!r} need the torque constants "
                             "(torque_constant, N m/A at the motor; or let identify find them: --identify-torque-constants)")
        if "qm" in get:
            get["q"] = drive.positions(get.pop("qm"))
        if "qdm" in get and "qd" not in get:
            get["qd"] = drive.rates(get.pop("qdm"))
        if "taum" in get or "i" in get:
            get["tau"] = drive.torques(get.pop("taum", None), get.pop("i", None))
        if np.array_equal(drive.R, np.eye(n)) and not np.any(drive.offset):
            notes.append("drive: R = I and no offsets (the model has no [transmission]): the motor-side columns "
                         "are read as the joints' own; give the model a [transmission] if there are gears")
        notes.append(f"drive: motor-side {', '.join(motor)} converted to the joints (q = R^-1 (q_m - offset), "
                     "qd = R^-1 qd_m, tau = R^T tau_m" + (", tau_m = k_t i" if "i" in motor else "") + ")")
    return t, get["q"], get.get("qd"), get.get("qdd"), get["tau"], table.rows, drive, notes, table.sha256, motor


def as_t_range(value, name: str = "t_range"):
    """``value`` as ``(t0, t1)`` seconds (either None), or None: a pair of numbers or None, or the
    command line's text ``"T0:T1"`` (either side may be empty).  A :class:`ModelError` names
    ``name`` for anything else (a single number, text that is not a time, inf or NaN, t0 >= t1)."""
    if value is None:
        return None
    expected = (f"{name}: expected (t0, t1) in seconds (either may be None), or the text 'T0:T1' (either side "
                f"may be empty), got {value!r:.60}")
    if isinstance(value, str):
        lo, sep, hi = value.partition(":")
        if not sep:
            raise ModelError(expected)
        try:
            pair = tuple(None if not x.strip() else float(x) for x in (lo, hi))
        except ValueError:
            raise ModelError(expected) from None
    else:
        try:
            pair = tuple(value)
        except TypeError:
            raise ModelError(expected) from None
        if len(pair) != 2 or not all(x is None or (isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_)))
                                     for x in pair):
            raise ModelError(expected)
        pair = tuple(None if x is None else float(x) for x in pair)
    if any(x is not None and not math.isfinite(x) for x in pair):
        raise ModelError(f"{name}: expected finite times (or None for an open end), got {value!r:.60}")
    if None not in pair and not pair[0] < pair[1]:
        raise ModelError(f"{name}: expected t0 < t1, got {value!r:.60}")
    return pair


def _window(t, arrays, t_range, where, notes):
    lo, hi = (None, None) if t_range is None else t_range
    lo = -math.inf if lo is None else float(lo)
    hi = math.inf if hi is None else float(hi)
    if not lo < hi:
        raise ModelError(f"{where}: t_range: expected (t0, t1) with t0 < t1, got {t_range!r}")
    have0, have1 = float(t[0]), float(t[-1])
    keep = (t >= lo) & (t < hi)
    if keep.sum() < 2:
        raise ModelError(f"{where}: t_range {t_range!r} holds {int(keep.sum())} samples; the data spans "
                         f"{have0:.6g} to {have1:.6g} s (after the filter's trimmed ends)")
    if (math.isfinite(lo) and lo < have0) or (math.isfinite(hi) and hi > have1 + 1e-12):
        notes.append(f"window: t_range {t_range!r} reaches past the data ({have0:.6g} to {have1:.6g} s after the "
                     f"filter's trimmed ends); using {t[keep][0]:.6g} to {t[keep][-1]:.6g} s")
    else:
        notes.append(f"window: {t[keep][0]:.6g} <= t <= {t[keep][-1]:.6g} s ({int(keep.sum())} samples)")
    return t[keep], [None if a is None else a[keep] for a in arrays]


def read_log(path, n: int, *, joint_names=None, columns=None, deg=False, rate=None, time_scale: float = 1.0,
             resample=None, cutoff=None, decimate=None, topic=None, transmission=None, R=None,
             motor_offset=None, torque_constant=None, t_range=None, extra_joints: bool = False) -> Measurements:
    """Read a measurement log for an arm of ``n`` joints (module docstring).

    ``path``: a CSV file, a rosbag2 directory, an ``.mcap`` or ``.bag`` file.
    ``joint_names``: the model's joint names in order (ROS bags: required).
    ``columns``: header patterns (:func:`~manipdyn.formats.logs.columns.column_map`:
    a dict or ``"q=Joint_{i},tau=Effort_{i}"``).  ``deg``: positions, velocities
    and accelerations in degrees (True, or one flag per joint).
    ``rate``: the sample rate in Hz when there is no ``t`` column (given with
    one, it replaces the column); ``time_scale``: seconds per unit of ``t``
    (1e-3 for ms).  ``resample``: the uniform grid's rate in Hz (default the
    median rate).  ``cutoff``: the low-pass cut-off in Hz (default chosen from
    the data).  ``decimate``: the factor after filtering (default chosen, 1 or
    False for none).  ``topic``: the JointState topic of a bag.
    ``transmission``: an object or mapping with ``R`` (n, n), ``motor_offset``
    (n,), ``torque_constant`` (n,); the keyword arrays override it.
    ``t_range``: ``(t0, t1)`` keeps ``t0 <= t < t1`` s (either may be None; the command
    line's text ``"T0:T1"`` is read the same, :func:`as_t_range`),
    taken after filtering so the window keeps its edges.  ``extra_joints``: a CSV
    whose signals have columns for joints beyond ``n`` (``q8`` for a 7-joint model)
    is refused unless True (they are then ignored, and the note says so).

    Returns :class:`Measurements` with ``notes``, ``rate``, ``cutoff``,
    ``decimation``, ``qd_motor``, ``source_sha256``.  Raises
    :class:`~manipdyn.ModelError` naming the file, row and column, or the argument.
    """
    where = os.fspath(path)
    n = int(n)
    drive_args = dict(transmission=transmission, R=R, motor_offset=motor_offset, torque_constant=torque_constant)
    if joint_names is not None and (not isinstance(joint_names, (list, tuple)) or not all(
            isinstance(x, str) and x for x in joint_names)):
        # a string would be read letter by letter: "abcdef" as joints a to f
        raise ModelError(f"{where}: joint_names: expected a list of {n} names (str), got {joint_names!r:.60}")
    if joint_names is not None and len(joint_names) != n:
        raise ModelError(f"{where}: joint_names: expected {n} names, got {len(joint_names)}")
    if not (isinstance(time_scale, (int, float)) and math.isfinite(time_scale) and time_scale > 0):
        raise ModelError(f"{where}: time_scale: expected seconds per unit of t > 0, got {time_scale!r}")
    t_range = as_t_range(t_range)                       # the command line's 'T0:T1' too
    for name, v in (("rate", rate), ("resample", resample), ("cutoff", cutoff)):
        if v is not None and (isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real)
                              or not (math.isfinite(v) and v > 0)):
            raise ModelError(f"{name}: expected a frequency in Hz > 0 (a number, or None), got {v!r:.60}")
    if is_bag(path):
        if columns is not None or (deg is not False and deg is not None) or time_scale != 1:
            raise ModelError(f"{where}: columns=, deg= and time_scale= (--columns, --deg, --time-scale) are for "
                             "CSV logs; a JointState bag is mapped by joint name, is in SI units and stamped in ns")
        t, q, qd, tau, notes, sha = read_joint_states(path, joint_names, topic)
        qdd, rows, drive, motor = None, np.arange(1, len(t) + 1), as_drive(n, **drive_args), []
    else:
        if topic is not None:
            raise ModelError(f"{where}: topic= is for ROS bags; this is read as a CSV file")
        t, q, qd, qdd, tau, rows, drive, notes, sha, motor = _from_csv(path, n, where, columns, deg, time_scale,
                                                                        drive_args, rate, bool(extra_joints))
    check_signals(where, rows, q=q, qd=qd, qdd=qdd, tau=tau)
    parts = [q] + [a for a in (qd, qdd) if a is not None] + [tau]
    vel = list(range(q.shape[1], sum(a.shape[1] for a in parts[:-1])))      # the measured qd (and qdd) columns
    t, values, fs, tnotes = uniform_samples(t, np.hstack(parts), rows, where, rate=rate, resample=resample,
                                            velocity_columns=vel)
    notes += tnotes
    split = np.split(values, np.cumsum([a.shape[1] for a in parts])[:-1], axis=1)
    q, tau = split[0], split[-1]
    qd = split[1] if qd is not None else None
    qdd = split[-2] if qdd is not None else None
    if qd is not None:
        _check_measured_velocity(q, qd, t, where)
    fc, D, derived, measured_qd, noise = None, 1, True, qd is not None, None
    if qd is not None and qdd is not None:
        derived = False
        notes.append("derivatives: qd and qdd measured, used as they are (nothing filtered)"
                     + ("" if cutoff is None else f"; cutoff {cutoff:g} Hz not used"))
        if decimate not in (None, False, 1):
            D = int(decimate)
            t, q, qd, qdd, tau = (a[::D] for a in (t, q, qd, qdd, tau))
    else:
        if cutoff is None:
            fc, why = choose_cutoff(q, fs)
        else:
            fc, why = float(cutoff), "given"
        D = decimation_factor(fs, fc) if decimate is None else max(1, int(decimate or 1))
        measured = "measured qd filtered and differentiated for qdd" if qd is not None else \
            "qd and qdd derived from q"
        raw_t, raw_q, raw_qd = t, q, qd
        t, q, qd, qdd, (tau,) = zero_phase(t, q, fc, qd=qd, others=(tau,), decimate=D, where=where)
        noise = velocity_noise(raw_t, raw_q, raw_qd, fc, D, q, qd)
        notes.append(f"filter: zero-phase Butterworth low-pass at {fc:.3g} Hz ({why}); {measured}; "
                     f"{edge_samples(fs, fc) / fs:.3g} s dropped at each end (the filter's edges)")
        if D > 1:
            notes.append(f"filter: decimated by {D} after filtering and differentiating: {fs:.6g} -> {fs / D:.6g} Hz "
                         "(torques: every D-th sample, not averaged)")
    if t_range is not None:
        t, (q, qd, qdd, tau) = _window(t, [q, qd, qdd, tau], t_range, where, notes)
    return Measurements(t, q, qd, qdd, tau, derived=derived, notes=notes, rate=fs / D, cutoff=fc, decimation=D,
                        qd_motor=None if drive is None else drive.motor_rates(qd), measured_qd=measured_qd,
                        source=where, source_sha256=sha, qd_noise=noise, motor_signals=motor)


def _check_measured_velocity(q, qd, t, where) -> None:
    """Refuse a measured velocity column that is zero (or a thousand times too small) while its
    position moves: a driver that does not report velocities writes zeros, and trusting them
    leaves the fit without viscous friction or Coriolis torques.  Compared with dq/dt in RMS, for a
    joint that moves most of the time (its median |dq/dt| above zero): a log of poses held still,
    joined by jumps between them, reports zero velocities truly."""
    if len(t) < 3:
        return
    rate = np.gradient(q, t, axis=0)
    for j in range(q.shape[1]):
        want = float(np.sqrt(np.mean(rate[:, j] ** 2)))
        got = float(np.sqrt(np.mean(qd[:, j] ** 2)))
        moving = float(np.median(np.abs(rate[:, j])))
        if moving > 1e-6 and want > 1e-6 and got < 1e-3 * want:
            raise ModelError(f"{where}: column qd{j + 1}: the measured velocity is {'zero' if got == 0 else f'{got:.3g} RMS'} "
                             f"while q{j + 1} moves at {want:.3g} RMS (its derivative): a driver that does not report "
                             "velocities? Leave the qd columns out of the log so qd is derived from q")
