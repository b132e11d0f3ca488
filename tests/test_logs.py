"""Measurement logs as they come: read_log (manipdyn.formats.logs.read and its parts).

A known motion goes through every path (uneven, repeated and dropped time
stamps; no t; measured qd; other column names; degrees; the motor side) and
comes back with small, justified errors; every malformed file is refused with
its row and column named; a FIFO is refused without hanging.
"""

from __future__ import annotations

import math
import os
import threading
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support import limits
from manipdyn.identification import read_log, read_measurements
from manipdyn.formats.logs.filtering import choose_cutoff

pytest.importorskip("scipy")

REPO = Path(__file__).resolve().parents[1]
from common import PANDA_LOG as PANDA, PANDA_SKIP  # noqa: E402

W = np.array([2 * np.pi * 0.3, 2 * np.pi * 0.5])     # rad/s of the two joints
A = np.array([0.8, 0.4])                             # rad


def motion(t):
    """q, qd, qdd (N, 2) of a known motion."""
    s, c = np.sin(np.outer(t, W)), np.cos(np.outer(t, W))
    return A * s, A * W * c, -A * W**2 * s


def torque(q, qd):
    return np.column_stack([3.0 * q[:, 0] + 0.2 * np.sign(qd[:, 0]), -2.0 * q[:, 1] + 0.5])


def write_csv(path, header, cols, fmt=repr):
    rows = [",".join(header)] + [",".join(fmt(float(x)) for x in r) for r in np.column_stack(cols)]
    Path(path).write_text("\n".join(rows) + "\n", encoding="utf-8")


def ragged_log(rate=500.0, duration=30.0, seed=0):
    """Time stamps with jitter, dropped samples, a 20 ms gap and repeated rows."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, duration, 1 / rate)
    t = t + rng.uniform(-0.2e-3, 0.2e-3, len(t))           # host jitter, stamps still increasing
    keep = rng.random(len(t)) > 0.03                        # 3 % dropped
    keep[(t > 14.0) & (t < 14.02)] = False                  # one 20 ms gap
    t = t[keep]
    q, qd, _ = motion(t)
    tau = torque(q, qd)
    dup = np.flatnonzero(rng.random(len(t)) < 0.05)          # the same sample logged again
    dup = dup[(dup > 0) & (dup < len(t) - 1)]
    order = np.sort(np.concatenate([np.arange(len(t)), dup]))
    tt = t[order].copy()
    rep = np.concatenate([[False], order[1:] == order[:-1]])
    tt[rep] = (t[order[rep]] + t[np.minimum(order[rep] + 1, len(t) - 1)]) / 2   # logged later, same values
    return tt, q[order], tau[order], int(rep.sum())


def test_uneven_repeated_and_dropped_time_stamps_are_recovered(tmp_path):
    t, q, tau, ndup = ragged_log()
    p = tmp_path / "ragged.csv"
    write_csv(p, ["t", "q1", "q2", "tau1", "tau2"], [t, q, tau])
    m = read_log(p, 2)
    text = "\n".join(m.notes)
    assert f"dropped {ndup} duplicate rows" in text
    assert "gaps" in text and "resampled onto a uniform grid at 500." in text
    # the median of 15000 steps jittered by +-0.2 ms: its sampling error is ~2 us in 2 ms
    assert m.rate * m.decimation == pytest.approx(500.0, rel=2e-3) and m.cutoff is not None
    assert np.allclose(np.diff(m.t), 1 / m.rate, rtol=1e-9)
    q_ref, qd_ref, qdd_ref = motion(m.t)
    # budget (relative to each signal's peak): the filter at >= 2 Hz passes 0.5 Hz with
    # 1 / (1 + (0.25)^8) ~ 1.5e-5 error; the edge transient at 0.75 / cutoff is under 3e-3
    # of qdd's RMS for motions up to cutoff / 3 (filtering.py, "Edges"), far less at 0.5 Hz;
    # linear interpolation errs h^2 |q''| / 8 ~ 5e-6 rad between samples and
    # ~5e-4 rad across the 20 ms gap, which the filter spreads to ~3e-4 of qdd; the
    # jitter is honest (stamps are the true times). Measured 5.3e-4 (qdd of joint 2).
    for got, ref in ((m.q, q_ref), (m.qd, qd_ref), (m.qdd, qdd_ref)):
        assert np.all(np.abs(got - ref).max(axis=0) < 2e-3 * np.abs(ref).max(axis=0))
    # the torques are not filtered: linear interpolation of the sampled tau
    assert np.abs(m.tau[:, 1] - torque(q_ref, qd_ref)[:, 1]).max() < 1e-3


def test_time_going_back_or_clashing_names_the_row(tmp_path):
    p = tmp_path / "back.csv"
    p.write_text("t,q1,tau1\n0,1,2\n0.01,1.1,2\n\n0.005,1.2,2\n")
    with pytest.raises(md.ModelError, match=r"back.csv: column 't' must increase: row 5 \(t = 0.005\) goes back"):
        read_log(p, 1)
    p.write_text("t,q1,tau1\n0,1,2\n0,1.1,2\n")
    with pytest.raises(md.ModelError, match="row 3 repeats the time 0.0 of row 2 with different values"):
        read_log(p, 1)


def test_repeated_rows_at_rest_are_samples_repeated_rows_in_motion_are_not(tmp_path):
    """A repeated row with every measured velocity exactly zero is an arm at rest and stays; a
    repeated row carrying a velocity is a sample logged twice and goes (timebase.py, item 2)."""
    t = np.arange(60) * 0.01
    q = np.repeat([[0.1, -0.2], [0.4, 0.3], [0.7, 0.1]], 20, axis=0)        # three poses held still
    qd = np.zeros_like(q)
    tau = np.repeat([[1.0, 2.0], [1.5, 2.5], [0.5, 1.0]], 20, axis=0)
    p = tmp_path / "held.csv"
    write_csv(p, ["t", "q1", "q2", "qd1", "qd2", "qdd1", "qdd2", "tau1", "tau2"], [t, q, qd, qd, tau])
    m = read_log(p, 2)                  # qd and qdd measured: used as they are, nothing filtered
    text = "\n".join(m.notes)
    assert "kept 57 rows that repeat the previous row" in text and "duplicate" not in text
    assert len(m.t) == 60 and np.array_equal(m.q, q) and np.array_equal(m.tau, tau)
    # the same rows with a velocity that is not zero: samples logged again while moving, dropped
    from manipdyn.formats.logs.timebase import uniform_samples
    values = np.hstack([q, np.full_like(q, 0.5), tau])
    t2, v2, _, notes = uniform_samples(t, values, np.arange(60) + 2, "held.csv", velocity_columns=[2, 3])
    assert "dropped 57 duplicate rows" in "\n".join(notes) and len(t2) == 3
    # without velocity columns the rule cannot tell, and drops them as before
    t3, _, _, notes = uniform_samples(t, np.hstack([q, tau]), np.arange(60) + 2, "held.csv")
    assert "dropped 57 duplicate rows" in "\n".join(notes) and len(t3) == 3


@pytest.mark.skipif(not PANDA.is_file(), reason=PANDA_SKIP)
def test_real_panda_log_reads_as_logged():
    m = read_log(PANDA, 7)
    text = "\n".join(m.notes)
    assert "dropped 1131 duplicate rows" in text
    assert m.measured_qd and m.derived and m.rate > 0
    assert "resampled onto a uniform grid at 1000 Hz" in text
    # the robot's own velocity and the derivative of its position agree once the
    # time base is rebuilt: measured 1.4 % of the peak (the robot filters its qd;
    # stamps jitter by ~0.1 ms). Taking the rows as uniform 1 kHz samples instead
    # (rate=1000, the time stamps ignored) disagrees by 3 to 15 %.
    g = np.gradient(m.q, 1 / m.rate, axis=0)
    assert np.all(np.abs(g - m.qd).max(axis=0) < 0.03 * np.abs(m.qd).max(axis=0))
    naive = read_log(PANDA, 7, rate=1000.0)
    gn = np.gradient(naive.q, 1 / naive.rate, axis=0)
    assert np.abs(gn - naive.qd).max() > 0.03 * np.abs(naive.qd).max()
    # identify on t < 10 s, validate on 10 <= t < 13.8 s of the same file
    fit, val = read_log(PANDA, 7, t_range=(None, 10.0)), read_log(PANDA, 7, t_range=(10.0, 13.8))
    assert fit.t[-1] < 10.0 <= val.t[0] and val.t[-1] < 13.8
    assert fit.source_sha256 == val.source_sha256 and len(fit.source_sha256) == 64


def test_no_time_column_needs_the_rate(tmp_path):
    t = np.arange(0, 20, 1 / 200)
    q, qd, qdd = motion(t)
    p = tmp_path / "not.csv"
    write_csv(p, ["q1", "q2", "tau1", "tau2"], [q, torque(q, qd)])
    with pytest.raises(md.ModelError, match=r"no time column 't'; give the sample rate with rate=HZ"):
        read_log(p, 2)
    m = read_log(p, 2, rate=200.0)
    assert "no 't' column" in m.notes[0]
    _, _, qdd_ref = motion(m.t)
    assert np.abs(m.qdd - qdd_ref).max() < 2e-3 * np.abs(qdd_ref).max()   # budget as above


def test_implausible_rate_says_how_to_fix(tmp_path):
    t = np.arange(0, 20, 1 / 200) * 1e3                  # milliseconds
    q, qd, _ = motion(t / 1e3)
    p = tmp_path / "ms.csv"
    write_csv(p, ["t", "q1", "q2", "tau1", "tau2"], [t, q, torque(q, qd)])
    with pytest.raises(md.ModelError, match=r"median step of 5 s.*implausible.*time_scale=1e-3.*rate=HZ"):
        read_log(p, 2)
    m = read_log(p, 2, time_scale=1e-3)
    assert m.rate * m.decimation == pytest.approx(200.0)
    with pytest.raises(md.ModelError, match="implausible"):
        write_csv(p, ["t", "q1", "q2", "tau1", "tau2"], [t * 1e-6, q, torque(q, qd)])   # 200 MHz
        read_log(p, 2)


def test_measured_qd_is_filtered_and_differentiated(tmp_path):
    rng = np.random.default_rng(1)
    t = np.arange(0, 20, 1 / 1000)
    q, qd, _ = motion(t)
    p = tmp_path / "qd.csv"
    noisy_qd = qd + 1e-3 * rng.standard_normal(qd.shape)
    write_csv(p, ["t", "q1", "q2", "qd1", "qd2", "tau1", "tau2"], [t, q, noisy_qd, torque(q, qd)])
    m = read_log(p, 2)
    assert m.measured_qd and m.derived and "measured qd filtered" in "\n".join(m.notes)
    _, qd_ref, qdd_ref = motion(m.t)
    # white noise of 1e-3 rad/s through a 2 Hz low-pass of a 1 kHz signal keeps
    # sqrt(2 / 500) of its rms (6e-5); differentiated at 2 Hz that is ~1e-3 rad/s^2
    # rms, ~4e-3 peak, against a peak qdd of 3.9: 2e-3 relative covers it
    assert np.abs(m.qd - qd_ref).max() < 1e-3 * np.abs(qd_ref).max()
    assert np.abs(m.qdd - qdd_ref).max() < 2e-3 * np.abs(qdd_ref).max()


def test_measured_qd_and_qdd_are_used_as_they_are(tmp_path):
    t = np.arange(0, 2, 1 / 100)
    q, qd, qdd = motion(t)
    p = tmp_path / "all.csv"
    write_csv(p, ["t", "q1", "q2", "qd1", "qd2", "qdd1", "qdd2", "tau1", "tau2"], [t, q, qd, qdd, torque(q, qd)])
    m = read_measurements(p, 2)
    assert not m.derived and m.cutoff is None
    np.testing.assert_array_equal(m.qdd, qdd)


def test_column_map_and_degrees(tmp_path):
    t = np.arange(0, 20, 1 / 200)
    q, qd, qdd = motion(t)
    tau = torque(q, qd)
    plain, other = tmp_path / "plain.csv", tmp_path / "other.csv"
    write_csv(plain, ["t", "q1", "q2", "tau1", "tau2"], [t, q, tau])
    write_csv(other, ["time", "Joint_0", "Joint_1", "Effort_0", "Effort_1", "temperature"],
              [t, np.degrees(q), tau, np.full_like(t, 30.0)])
    a = read_log(plain, 2)
    b = read_log(other, 2, columns="t=time,q=Joint_{i0},tau=Effort_{i0}", deg=True)
    assert any("ignored 1 column(s) no signal maps to: temperature" in x for x in b.notes)
    # degrees -> rad rounds in the last digit of repr: relative 1e-15, amplified by
    # the filter's derivatives (x (2 pi cutoff)^2) to ~1e-12 of qdd
    np.testing.assert_allclose(b.qdd, a.qdd, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(b.tau, a.tau)
    with pytest.raises(md.ModelError, match=r"unknown signal 'torque'"):
        read_log(other, 2, columns={"torque": "Effort_{i}"})
    with pytest.raises(md.ModelError, match=r"must contain \{i\}"):
        read_log(other, 2, columns="q=Joint")
    with pytest.raises(md.ModelError, match=r"other.csv: missing column\(s\) \['q1', 'q2'\].*no joint position"):
        read_log(other, 2)


def _drive():
    R = np.array([[-100.0, 0.0], [30.0, 50.0]])        # joint 1 reversed; motor 2 drives q1 and q2
    return R, np.array([0.3, -1.2]), np.array([0.05, 0.12])


def test_motor_side_with_coupling_and_a_negative_ratio(tmp_path):
    t = np.arange(0, 20, 1 / 500)
    q, qd, _ = motion(t)
    tau = torque(q, qd)
    R, off, kt = _drive()
    qm = q @ R.T + off                                   # q_m = R q + offset
    taum = tau @ np.linalg.inv(R)                        # tau = R^T tau_m
    joint, motor, amps = tmp_path / "j.csv", tmp_path / "m.csv", tmp_path / "i.csv"
    write_csv(joint, ["t", "q1", "q2", "tau1", "tau2"], [t, q, tau])
    write_csv(motor, ["t", "qm1", "qm2", "taum1", "taum2"], [t, qm, taum])
    write_csv(amps, ["t", "qm1", "qm2", "i1", "i2"], [t, qm, taum / kt])
    ref = read_log(joint, 2)
    with pytest.raises(md.ModelError, match=r"m.csv: motor-side column\(s\) qm\{i\}, taum\{i\} need the transmission"):
        read_log(motor, 2)
    drive = dict(R=R, motor_offset=off, torque_constant=kt)
    for path in (motor, amps):
        m = read_log(path, 2, transmission=drive)
        # R^-1 and a 100:1 ratio cost ~1e-13 rad of q; the filter passes it unchanged
        np.testing.assert_allclose(m.q, ref.q, atol=1e-10)
        np.testing.assert_allclose(m.tau, ref.tau, atol=1e-10)
        np.testing.assert_allclose(m.qd_motor, ref.qd @ R.T, atol=1e-8)
    with pytest.raises(md.ModelError, match="need the torque constants"):
        read_log(amps, 2, R=R, motor_offset=off)

    class Transmission:                                  # any object with the attributes
        pass

    tr = Transmission()
    tr.R, tr.motor_offset, tr.torque_constant = R, off, kt
    np.testing.assert_allclose(read_log(amps, 2, transmission=tr).q, ref.q, atol=1e-10)
    with pytest.raises(md.ModelError, match="R is singular"):
        read_log(motor, 2, R=np.ones((2, 2)))


def test_cutoff_chosen_from_a_fast_motion_and_decimated(tmp_path):
    rate = 5000.0
    t = np.arange(0, 12, 1 / rate)
    w = 2 * np.pi * np.array([3.0, 4.5])
    q = np.sin(np.outer(t, w)) * [0.5, 0.2]
    qdd_ref = -np.sin(np.outer(t, w)) * [0.5, 0.2] * w**2
    p = tmp_path / "fast.csv"
    write_csv(p, ["t", "q1", "q2", "tau1", "tau2"], [t, q, q])
    m = read_log(p, 2)
    assert m.cutoff > 5.0                 # 3 x 4.5 Hz = 13.5 Hz: the motion passes
    assert m.decimation > 1 and m.rate < rate / 2
    assert any(f"decimated by {m.decimation}" in x for x in m.notes)
    assert any("99.99 % of qd's power" in x for x in m.notes)
    ref = qdd_ref[np.searchsorted(t, m.t[0]):][:: m.decimation][: len(m.t)]
    # the top harmonic at 4.5 Hz passes a 13.5 Hz cut-off with 1.5e-4 error
    assert np.abs(m.qdd - ref).max() < 2e-3 * np.abs(ref).max()
    explicit = read_log(p, 2, cutoff=5.0)           # accepted: below Nyquist
    assert explicit.cutoff == 5.0 and "(given)" in "\n".join(explicit.notes)
    with pytest.raises(md.ModelError, match=r"cutoff: expected 0 < cutoff < 2500 Hz"):
        read_log(p, 2, cutoff=3000.0)
    assert read_log(p, 2, cutoff=20.0, decimate=False).decimation == 1


def test_cutoff_ignores_a_noise_floor():
    rng = np.random.default_rng(2)
    t = np.arange(0, 20, 1 / 1000)
    q = np.column_stack([0.5 * np.sin(2 * np.pi * 0.4 * t), 1e-3 * rng.standard_normal(len(t))])
    fc, why = choose_cutoff(q, 1000.0)
    assert fc == 2.0 and "clipped" in why       # 3 x 0.4 Hz below the 2 Hz floor, noise ignored


# -- malformed files: every error names the file, the row and the column ------------------

@pytest.mark.parametrize("body, match", [
    ("t,q1,tau1\n0,1,2\n0.01,1,2,3\n", r"f.csv: row 3 has 4 field\(s\), the header has 3"),
    ("t,q1,tau1\n0,1,2\n\n\n0.01,abc,2\n", r"f.csv: row 5, column 2 \('q1'\): 'abc' is not a number"),
    ("t,q1,tau1\n0,1,2\n0.01,1,1e999\n", r"f.csv: row 3, column 3 \('tau1'\): '1e999' overflows float64"),
    ("t,q1,tau1\n0,1,2\n0.01,nan,2\n", r"f.csv: row 3, column 2 \('q1'\): 'nan' is not a finite number"),
    ("t,q1,q1\n0,1,2\n", r"f.csv: row 1 \(the header\), column 3: duplicate column name 'q1'"),
    ("\n\n", r"f.csv: no header line"),
])
def test_malformed_csv_names_row_and_column(tmp_path, body, match):
    p = tmp_path / "f.csv"
    p.write_text(body, encoding="utf-8")
    with pytest.raises(md.ModelError, match=match):
        read_log(p, 1)


def test_excel_bom_crlf_quotes_and_comments(tmp_path):
    t = np.arange(0, 20, 1 / 100)
    q, qd, _ = motion(t)
    tau = torque(q, qd)
    lines = ['"t";"q1";"q2";"tau1";"tau2"', "# exported"] + \
        [";".join(f'"{x!r}"' if k == 1 else repr(x) for k, x in enumerate(map(float, r)))
         for r in np.column_stack([t, q, tau])]
    p = tmp_path / "excel.csv"
    p.write_bytes(b"\xef\xbb\xbf" + "\r\n".join(lines).encode() + b"\r\n")
    m = read_log(p, 2)
    ref = tmp_path / "ref.csv"
    write_csv(ref, ["t", "q1", "q2", "tau1", "tau2"], [t, q, tau])
    np.testing.assert_array_equal(m.q, read_log(ref, 2).q)


def test_not_utf8_and_limits(tmp_path, monkeypatch):
    p = tmp_path / "latin.csv"
    p.write_bytes("t,q1,tau1\n0,1,2\n0.01,1,2 \xb0C\n".encode("latin-1"))
    with pytest.raises(md.ModelError, match=r"latin.csv: row 3: not UTF-8 text \(byte 0xb0"):
        read_log(p, 1)
    p.write_bytes("t,q1,tau1\n".encode("utf-16"))
    with pytest.raises(md.ModelError, match="UTF-16 text; save it as CSV UTF-8"):
        read_log(p, 1)
    big = tmp_path / "field.csv"
    big.write_text("t,q1,tau1\n0,1,2\n0.01," + "1" * 300_000 + ",2\n")
    with pytest.raises(md.ModelError, match=r"field.csv: row 3, column 2: the field size .*MAX_DATA_FIELD_BYTES"):
        read_log(big, 1)
    monkeypatch.setattr(limits, "MAX_DATA_FIELD_BYTES", 1 << 30)
    monkeypatch.setattr(limits, "MAX_DATA_BYTES", 100_000)
    with pytest.raises(md.ModelError, match=r"field.csv: the data file size is over 100000 bytes.*MAX_DATA_BYTES"):
        read_log(big, 1)


def test_fifo_and_devices_are_refused_without_hanging(tmp_path):
    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs on this platform")
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    outcome = []

    def attempt(path):
        try:
            read_log(path, 1)
        except md.ModelError as exc:
            outcome.append(str(exc))

    for path in (fifo, Path("/dev/zero")):
        th = threading.Thread(target=attempt, args=(path,), daemon=True)
        th.start()
        th.join(timeout=30)             # a hang would block here; the refusal takes milliseconds
        assert not th.is_alive(), f"reading {path} hangs"
    assert len(outcome) == 2 and all("not a regular file" in x for x in outcome)


def test_large_file_streams(tmp_path):
    """Rows are parsed chunk by chunk: a file over several chunks reads whole and in order."""
    from manipdyn.formats.logs.table import CHUNK_BYTES, read_table

    t = np.arange(0, 60, 1 / 1000)
    q, qd, _ = motion(t)
    p = tmp_path / "long.csv"
    write_csv(p, ["t", "q1", "q2", "tau1", "tau2"], [t, q, torque(q, qd)])
    assert p.stat().st_size > 3 * CHUNK_BYTES
    tab = read_table(p)
    assert tab.data.shape == (len(t), 5) and np.array_equal(tab.data[:, 0], t)
    assert np.array_equal(tab.rows, np.arange(2, len(t) + 2))


def test_t_range_clips_with_a_note_and_refuses_empty(tmp_path):
    t = np.arange(0, 20, 1 / 200)
    q, qd, _ = motion(t)
    p = tmp_path / "w.csv"
    write_csv(p, ["t", "q1", "q2", "tau1", "tau2"], [t, q, torque(q, qd)])
    m = read_log(p, 2, t_range=(0.0, 5.0))
    from manipdyn.formats.logs.filtering import EDGE_TRIM

    assert m.t[0] >= EDGE_TRIM / m.cutoff - 1e-9 and m.t[-1] < 5.0       # after the filter's trimmed start
    assert any("reaches past the data" in x for x in m.notes)
    with pytest.raises(md.ModelError, match=r"t_range \(30.0, 40.0\) holds 0 samples; the data spans"):
        read_log(p, 2, t_range=(30.0, 40.0))
    assert math.isclose(m.rate * m.decimation, 200.0)


def test_cli_log_options(tmp_path):
    import argparse

    from manipdyn.cli.logopts import log_options_from_args, register_log_options

    parser = argparse.ArgumentParser()
    register_log_options(parser)
    t = np.arange(0, 20, 1 / 200)
    q, qd, _ = motion(t)
    p = tmp_path / "cli.csv"
    write_csv(p, ["time_ms", "J1", "J2", "E1", "E2"], [t * 1e3, np.degrees(q), torque(q, qd)])
    args = parser.parse_args(["--columns", "t=time_ms,q=J{i},tau=E{i}", "--deg", "--time-scale", "1e-3",
                              "--cutoff", "5", "--no-decimate", "--t-range", "2:10"])
    m = read_log(p, 2, **log_options_from_args(args, joint_names=["a", "b"]))
    assert m.cutoff == 5.0 and m.decimation == 1 and 2.0 <= m.t[0] and m.t[-1] < 10.0
    for bad, match in ((["--t-range", "5"], "--t-range: expected \\(t0, t1\\) in seconds.*T0:T1"), (["--rate", "-1"], "--rate: expected")):
        with pytest.raises(md.ModelError, match=match):
            log_options_from_args(parser.parse_args(bad))


def test_a_log_with_more_joints_than_the_model_is_refused(tmp_path, capsys):
    """A 7-joint log read for a 5-joint model (another arm, or a chain cut short with --tip) used to
    fit the first five joints silently, with a note; joints 6 and 7 moved, so that model is wrong."""
    from manipdyn.cli import main

    t = np.arange(0, 12, 0.01)
    q = np.sin(np.outer(t, np.arange(1, 8) * 0.3))
    p = tmp_path / "seven.csv"
    write_csv(p, ["t"] + [f"q{i}" for i in range(1, 8)] + [f"tau{i}" for i in range(1, 8)], [t, q, q])
    with pytest.raises(md.ModelError, match=r"\['q6', 'tau6'\] belong to joint 6, but the model has 5 joints"):
        read_log(p, 5)
    m = read_log(p, 5, extra_joints=True)           # a gripper's columns, knowingly ignored
    assert m.q.shape[1] == 5 and any("ignored 4 column(s)" in x for x in m.notes)
    assert read_log(p, 7).q.shape[1] == 7
    assert main(["validate", "ur5", str(p)]) == 2
    assert "belong to joint 7, but the model has 6 joints" in capsys.readouterr().err


def test_a_json_file_given_as_the_log_is_named(tmp_path):
    p = tmp_path / "base.json"
    p.write_text('{\n  "format": "manipdyn base model"\n}\n')
    with pytest.raises(md.ModelError, match=r"base.json: starts with '\{': a JSON file .* not a CSV log"):
        read_log(p, 6)
