"""Issue 11's reproducers, one regression test each: hostile or careless input
gets a clear manipdyn error naming the culprit, or a correct answer.

Each test builds the reproducer from the issue (a mutated bundled URDF or
model file, a bad state, a file target) and checks the outcome: the error
class (ModelError / StateError, never a foreign exception), that the
message names the culprit, and, where an answer is given, that it is right
(compared with the trace-form engine or a native-byte-order call).
"""

from __future__ import annotations

import os
import re
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support import limits
from manipdyn._support.files import atomic_write_text, sweep_stale_temporaries
from manipdyn.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[1]
UR5 = (ROOT / "urdf" / "ur5.urdf").read_text(encoding="utf-8")
PUMA_TOML = (ROOT / "manipdyn" / "formats" / "models" / "puma560.toml").read_text(encoding="utf-8")


def first_attr(text: str, attr: str) -> re.Match:
    return re.search(rf'\b{attr}="([^"]*)"', text)


def replace_first(text: str, attr: str, value: str) -> str:
    m = first_attr(text, attr)
    return text[:m.start()] + f'{attr}="{value}"' + text[m.end():]


@pytest.fixture(scope="module")
def ur5():
    return md.load("ur5")


# ---------------------------------------------------------------------------
# Wrong answers
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("dtype", [">f8", "<f8", ">f4", "<f4", ">i8", "i4", "u2"])
@pytest.mark.parametrize("engine", ["pinocchio", "lagrange"])
def test_any_byte_order_and_width_gives_the_native_answer(ur5, engine, dtype):
    # issue: '>f8' gave a D off by 1.6 and g off by 22 N m on the Pinocchio path
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-1, 1, 6) for _ in range(3))
    if np.dtype(dtype).kind in "iu":
        q, qd, qdd = (np.round(x * 3) for x in (q, qd, qdd))
        q, qd, qdd = (np.abs(x) if dtype == "u2" else x for x in (q, qd, qdd))
    E = getattr(ur5, engine)
    cast = [x.astype(dtype) for x in (q, qd, qdd)]
    ref = [x.astype(dtype).astype(np.float64) for x in (q, qd, qdd)]  # the values the cast holds
    for one, two in ((cast, ref), ([c[None] for c in cast], [r[None] for r in ref])):
        np.testing.assert_array_equal(E.mass_matrix(one[0]), E.mass_matrix(two[0]))
        np.testing.assert_array_equal(E.gravity_torque(one[0]), E.gravity_torque(two[0]))
        np.testing.assert_array_equal(E.coriolis_torque(one[0], one[1]), E.coriolis_torque(two[0], two[1]))
        np.testing.assert_array_equal(E.inverse_dynamics(*one), E.inverse_dynamics(*two))
        np.testing.assert_array_equal(E.forward_dynamics(*one), E.forward_dynamics(*two))


def test_big_endian_state_on_the_arm_itself(ur5):
    # the arm's own methods go to the Pinocchio fast path
    q = np.linspace(0.1, 0.6, 6)
    np.testing.assert_array_equal(ur5.gravity_torque(q.astype(">f8")), ur5.gravity_torque(q))
    np.testing.assert_array_equal(ur5.mass_matrix(q.astype(">f8")), ur5.mass_matrix(q))


@pytest.mark.parametrize("case,text,pattern", [
    ("arabic-indic digit", replace_first(UR5, "ixx", "\u0661"), r"ixx=.*non-ASCII"),
    ("fullwidth digit", replace_first(UR5, "ixx", "\uff11"), r"ixx=.*non-ASCII"),
    ("tab in xyz", UR5.replace(first_attr(UR5, "xyz").group(0),
                               'xyz="%s"' % first_attr(UR5, "xyz").group(1).replace(" ", "\t"), 1),
     r"line \d+: xyz=.*tab or line break"),
    ("newline in rpy", replace_first(UR5, "rpy", "0\n0 0"), r"rpy=.*tab or line break"),
    ("char-ref tab", replace_first(UR5, "xyz", "0&#9;0 0"), r"xyz=.*tab or line break"),
    ("trailing space in a scalar", replace_first(UR5, "ixx", "0.01 "), r"ixx=.*trailing space"),
    ("trailing newline in a scalar", replace_first(UR5, "value", "3.7&#10;"), r"value=.*tab or line break"),
    ("DOCTYPE ATTLIST default", UR5.replace("<robot", '<!DOCTYPE robot [<!ATTLIST origin xyz CDATA "0 0 1">]>\n<robot', 1),
     r"refused: a DOCTYPE at line \d+ \(entities, ATTLIST"),
    ("plain DOCTYPE", UR5.replace("<robot", "<!DOCTYPE robot>\n<robot", 1), r"refused: a DOCTYPE"),
    ("underflowing literal", replace_first(UR5, "value", "1e-400"), r"value=.*underflows"),
    ("overflowing axis", UR5.replace(re.search(r'<axis xyz="[^"]+"', UR5).group(0), '<axis xyz="1e300 1e300 0"', 1),
     r"<axis xyz=\"1e300 1e300 0\">.*MAX_MAGNITUDE"),
    ("origin of 1e155 m", replace_first(UR5, "xyz", "1e155 0 0"), r"xyz=\"1e155 0 0\">.*magnitude over"),
    ("iyy of 1e308", replace_first(UR5, "iyy", "1e308"), r"iyy=\"1e308\">.*magnitude over"),
    ("negative velocity limit", replace_first(UR5, "velocity", "-1"), r"joint 'joint1'.*velocity=-1.0.*>= 0"),
    ("negative effort limit", replace_first(UR5, "effort", "-5"), r"joint 'joint1'.*effort=-5.0.*>= 0"),
])
def test_text_the_two_readers_would_read_differently_is_refused(case, text, pattern):
    with pytest.raises(md.ModelError, match=pattern):
        md.load(text)


def test_repeated_spaces_in_vectors_are_read_as_urdfdom_reads_them():
    # urdfdom skips empty pieces of a vector: accepted, and both readers must
    # then agree (the engine check passes); a space around a scalar is refused
    # (urdfdom refuses a trailing one everywhere, a leading one in <limit>)
    text = replace_first(UR5, "xyz", "  0.0   0.0 0.089159 ")
    arm = md.load(text)
    assert md.crosscheck(arm, samples=5).ok
    with pytest.raises(md.ModelError, match=r"effort=\" 150.0\">: not a finite number: a leading or trailing space"):
        md.load(replace_first(UR5, "effort", " 150.0"))


def test_numbers_urdfdom_reads_but_manipdyn_does_not_use_are_checked():
    # a fixed joint's <limit> and a visual's geometry: urdfdom parses them and
    # refuses the file (or drops the element) on a bad number
    fixed = re.search(r'<joint name="[^"]*" type="fixed">', UR5).group(0)
    text = UR5.replace(fixed, fixed + '<limit effort=".e1" velocity="1"/>', 1)
    with pytest.raises(md.ModelError, match=r"type=\"fixed\"|joint '.*'.*<limit effort=\"\.e1\">"):
        md.load(text)
    text = UR5.replace("<link name=\"shoulder\">", "<link name=\"shoulder\"><visual><geometry>"
                       "<box size=\"1 1\"/></geometry></visual>", 1)
    with pytest.raises(md.ModelError, match=r"<box size=\"1 1\">: expected 3 finite numbers"):
        md.load(text)


def test_processing_instructions_are_refused():
    text = UR5.replace("<link", "<?xml-stylesheet href='x'?><link", 1)
    with pytest.raises(md.ModelError, match=r"refused: a processing instruction <\?xml-stylesheet"):
        md.load(text)


def test_reader_disagreement_is_caught_when_the_engine_is_built(monkeypatch):
    """Even if the grammar missed a case, Pinocchio's model is compared with
    manipdyn's chain: simulate a reader that reads one mass differently."""
    arm = md.load(UR5)
    other = replace_first(UR5, "value", "4.7")  # the first <mass value> (shoulder, 3.7 kg)
    monkeypatch.setattr(arm, "source_urdf", other)
    with pytest.raises(md.ModelError, match=r"joint 'joint1' \(link 'shoulder'\) differently: mass.*"
                                            r"Pinocchio \(urdfdom\) reads 4\.7, manipdyn reads 3\.7"):
        arm.pinocchio


def test_reader_disagreement_on_a_placement_names_both_readings(monkeypatch):
    arm = md.load(UR5)
    m = re.search(r'<joint name="joint2".*?<origin ([^/]*)/>', UR5, re.S)
    other = UR5[:m.start(1)] + 'rpy="0.0 1.5707963267948966 0.0" xyz="0.0 0.2 0.0" ' + UR5[m.end(1):]
    monkeypatch.setattr(arm, "source_urdf", other)
    with pytest.raises(md.ModelError, match=r"joint 'joint2'.*origin xyz.*reads \[0\. *, 0\.2, 0\. *\], "
                                            r"manipdyn reads \[0\., 0\., 0\.\]"):
        arm.pinocchio


def test_urdfdom_refusing_what_manipdyn_read_is_a_model_error(monkeypatch):
    arm = md.load(UR5)
    monkeypatch.setattr(arm, "source_urdf", "<robot name='x'><link name='a'/></robot")
    with pytest.raises(md.ModelError, match="Pinocchio's URDF reader"):
        arm.pinocchio


@pytest.mark.parametrize("engine", ["pinocchio", "lagrange"])
def test_overflow_at_a_finite_state_is_reported_as_such(ur5, engine):
    E = getattr(ur5, engine)
    q = np.zeros(6)
    big = np.full(6, 1e200)
    with pytest.raises(md.StateError, match=r"^inverse_dynamics: the dynamics overflow at this state.*qd = \[1\.e\+200"):
        E.inverse_dynamics(q, big, q)
    with pytest.raises(md.StateError, match=r"^coriolis_torque: the dynamics overflow at this state"):
        E.coriolis_torque(q, big)
    with pytest.raises(md.StateError, match=r"overflow at this state \(state 1 of the batch\)"):
        E.inverse_dynamics(np.zeros((2, 6)), np.stack([np.zeros(6), big]), np.zeros((2, 6)))


def test_prismatic_overflow_in_mass_matrix_is_reported():
    # D depends on the prismatic q through the revolute joint before it: (1e200)^2 overflows
    arm = md.Manipulator([md.DHLink("revolute", alpha=1.0, mass=1.0, inertia=(0.1, 0.1, 0.1)),
                          md.DHLink("prismatic", alpha=1.0, mass=1.0, inertia=(0.1, 0.1, 0.1)),
                          md.DHLink("revolute", a=1.0, mass=1.0, inertia=(0.1, 0.1, 0.1))],
                         convention="standard")
    q = np.array([0.3, 1e200, 0.0])
    for E in (arm.pinocchio, arm.lagrange):
        with pytest.raises(md.StateError, match="overflow at this state"):
            E.mass_matrix(q)


def test_crosscheck_does_not_blame_its_own_tau():
    # issue: crosscheck raised "StateError: tau: entry (0, 0) is nan" on a model
    # with huge values; such a model is now refused at load, naming the value
    text = replace_first(UR5, "value", "1e300")
    with pytest.raises(md.ModelError, match=r"<mass value=\"1e300\">.*magnitude"):
        md.load(text)


# ---------------------------------------------------------------------------
# States: strict types
# ---------------------------------------------------------------------------
BAD_STATES = {
    "bool array": (lambda n: np.ones(n, dtype=bool), r"dtype bool"),
    "object array of strings": (lambda n: np.array(["1"] * n, dtype=object), r"dtype object"),
    "string array": (lambda n: np.array(["1"] * n), r"string"),
    "datetime64": (lambda n: np.array(["2020-01-01"] * n, dtype="datetime64[D]"), r"datetime64"),
    "timedelta64": (lambda n: np.zeros(n, dtype="timedelta64[s]"), r"timedelta64"),
    "masked array": (lambda n: np.ma.masked_array(np.zeros(n), mask=[True] + [False] * (n - 1)), r"masked array"),
    "complex": (lambda n: np.zeros(n, dtype=complex), r"complex"),
    "ragged list": (lambda n: [[0.0] * n, [0.0] * (n - 1)], r"ragged"),
    "int beyond float range": (lambda n: [10**400] + [0] * (n - 1), r"entry 0 is an integer beyond the float64 range"),
    "list of bools": (lambda n: [True] * n, r"dtype bool"),
    "list holding a string": (lambda n: [0.0] * (n - 1) + ["x"], r"string|holding str"),
    "nested 10000 deep": (lambda n: _deep(10000), r"nested too deeply|numpy cannot read|shape"),
    "structured": (lambda n: np.zeros(n, dtype=[("a", "f8")]), r"structured"),
    "nan": (lambda n: [np.nan] * n, r"entry 0 is nan"),
}


def _deep(k):
    a = [0.0]
    for _ in range(k):
        a = [a]
    return a


@pytest.mark.parametrize("case", sorted(BAD_STATES))
@pytest.mark.parametrize("engine", ["pinocchio", "lagrange"])
def test_bad_states_are_state_errors_naming_the_argument(ur5, engine, case):
    make, pattern = BAD_STATES[case]
    E = getattr(ur5, engine)
    good = np.zeros(6)
    with pytest.raises(md.StateError, match=r"^qd: .*" + f"(?:{pattern})"):
        E.inverse_dynamics(good, make(6), good)
    with pytest.raises(md.StateError, match=r"^q: .*" + f"(?:{pattern})"):
        E.mass_matrix(make(6))


# ---------------------------------------------------------------------------
# Crashes, hangs and foreign exceptions
# ---------------------------------------------------------------------------
def _fixed_run_urdf(n_fixed: int) -> str:
    links = ['<link name="base"/>', '<link name="l0"><inertial><mass value="1"/><inertia ixx="1" ixy="0" '
             'ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>']
    joints = ['<joint name="j" type="revolute"><parent link="base"/><child link="l0"/><axis xyz="0 0 1"/>'
              '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>']
    for i in range(1, n_fixed + 1):
        links.append(f'<link name="l{i}"/>')
        joints.append(f'<joint name="f{i}" type="fixed"><parent link="l{i - 1}"/><child link="l{i}"/></joint>')
    return '<robot name="r">' + "".join(links + joints) + "</robot>"


def _serial_urdf(n: int) -> str:
    body = ('<inertial><mass value="1"/><origin xyz="0 0 0.1"/><inertia ixx="0.1" ixy="0" ixz="0" '
            'iyy="0.1" iyz="0" izz="0.1"/></inertial>')
    links = ['<link name="l0"/>'] + [f'<link name="l{i}">{body}</link>' for i in range(1, n + 1)]
    joints = [f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
              '<origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
              "</joint>" for i in range(1, n + 1)]
    return '<robot name="c">' + "".join(links + joints) + "</robot>"


def test_twenty_thousand_fixed_joints_are_refused_not_a_segfault():
    with pytest.raises(md.ModelError, match=r"20002, over the limit of 1000 \(manipdyn.limits.MAX_LINKS\); "
                                            r"if the model is trusted, raise it"):
        md.load(_fixed_run_urdf(20000))


def test_a_long_run_of_fixed_joints_is_refused(monkeypatch):
    monkeypatch.setattr(limits, "MAX_FIXED_RUN", 50)
    with pytest.raises(md.ModelError, match=r"joint 'f51'.*fixed joints in a row.*MAX_FIXED_RUN"):
        md.load(_fixed_run_urdf(60))
    monkeypatch.setattr(limits, "MAX_FIXED_RUN", 100)
    assert md.load(_fixed_run_urdf(60)).n == 1


def test_three_thousand_joint_chain_is_refused_with_the_cap_and_how_to_raise_it(monkeypatch):
    with pytest.raises(md.ModelError, match=r"MAX_LINKS"):
        md.load(_serial_urdf(3000))
    with pytest.raises(md.ModelError, match=r"movable joints .* is 150, over the limit of 100 "
                                            r"\(manipdyn.limits.MAX_JOINTS\)"):
        md.load(_serial_urdf(150))
    monkeypatch.setattr(limits, "MAX_JOINTS", 200)
    assert md.load(_serial_urdf(150)).n == 150


def test_the_cap_holds_for_dh_arms():
    with pytest.raises(md.ModelError, match=r"links: the number of links is 101.*MAX_JOINTS"):
        md.Manipulator([md.DHLink(a=0.1, mass=1.0)] * 101, convention="standard")


def test_a_chain_at_the_cap_loads_and_agrees():
    # memory: the trace form works in chunks; the cross-check keeps per-state errors only
    arm = md.load(_serial_urdf(limits.MAX_JOINTS))
    report = md.crosscheck(arm, samples=30)
    # qdd on a 100-link chain: cond(D) ~ 1e7 costs digits; the other quantities at 1e-9
    assert all(q.ok for k, q in report.quantities.items() if k != "qdd"), report


def test_file_size_caps(tmp_path, monkeypatch):
    monkeypatch.setattr(limits, "MAX_FILE_BYTES", 1000)
    p = tmp_path / "big.urdf"
    p.write_text(UR5)
    with pytest.raises(md.ModelError, match=r"big\.urdf: the file size is over 1000 bytes.*MAX_FILE_BYTES"):
        md.load(p)
    monkeypatch.setattr(limits, "MAX_MODEL_FILE_BYTES", 1000)
    t = tmp_path / "big.toml"
    t.write_text(PUMA_TOML)
    with pytest.raises(md.ModelError, match=r"big\.toml: the model file size.*MAX_MODEL_FILE_BYTES"):
        md.load(t)


@pytest.mark.parametrize("name", ["fifo.urdf", "fifo.toml"])
def test_a_fifo_or_device_is_refused_not_a_hang(tmp_path, name):
    fifo = tmp_path / name
    os.mkfifo(fifo)
    with pytest.raises(md.ModelError, match=r"not a regular file"):
        md.load(fifo)
    with pytest.raises(md.ModelError, match=r"/dev/zero.*not a regular file"):
        md.load("/dev/zero")  # a device that never ends


def test_a_model_file_with_a_50_mb_string_is_refused_quickly(tmp_path):
    p = tmp_path / "huge.toml"
    p.write_text(PUMA_TOML.replace('name = "puma560"', 'name = "' + "x" * (50 * 2**20) + '"', 1))
    t = time.perf_counter()
    with pytest.raises(md.ModelError, match="MAX_MODEL_FILE_BYTES"):
        md.load(p)
    assert time.perf_counter() - t < 5.0  # the bound (the refusal reads 1 MiB only)


def test_non_utf8_model_file_names_the_file_and_byte_offset(tmp_path):
    p = tmp_path / "latin1.toml"
    data = PUMA_TOML.replace('name = "puma560"', 'name = "pum\u00e460"').encode("latin-1")
    p.write_bytes(data)
    offset = data.index(b"\xe4")
    with pytest.raises(md.ModelError, match=rf"latin1\.toml: .*UTF-8.*byte offset {offset} \(line \d+\)"):
        md.load(p)


def test_non_utf8_urdf_names_the_file_and_byte_offset(tmp_path):
    p = tmp_path / "bad.urdf"
    data = UR5.replace('name="ur5"', 'name="ur\u00e45"', 1).encode("latin-1")
    p.write_bytes(data)
    offset = data.index(b"\xe4")
    with pytest.raises(md.ModelError, match=rf"bad\.urdf: not valid utf-8.*byte offset {offset}"):
        md.load(p)


@pytest.mark.parametrize("key,value,pattern", [
    ("mass", "1e300", r"magnitude 1e\+300 is over 1e\+60"),
    ("mass", "1e12", r"field 'mass' has the mass 1e\+12 kg, over 1e\+09 kg \(manipdyn.limits.MAX_MASS\)"),
    ("d", "1e155", r"magnitude 1e\+155"),
    ("a", "1e5", r"field 'a' has the length 100000 m, over 10000 m \(manipdyn.limits.MAX_LENGTH\)"),
])
def test_model_file_values_that_would_overflow_or_swamp_are_refused(tmp_path, key, value, pattern):
    # issue: model values of 1e300 loaded fine and gave NaN dynamics
    p = tmp_path / "big.toml"
    p.write_text(re.sub(rf"(?m)^{key} = [-0-9.e+]+", f"{key} = {value}", PUMA_TOML, count=1))
    with pytest.raises(md.ModelError, match=rf"big\.toml.*{pattern}"):
        md.load(p)


def test_huge_integer_mass_in_a_model_file(tmp_path):
    p = tmp_path / "int.toml"
    p.write_text(re.sub(r"mass = [0-9.e+-]+", "mass = " + "9" * 400, PUMA_TOML, count=1))
    with pytest.raises(md.ModelError, match=r"int\.toml: links\[0\].*mass.*400 digits"):
        md.load(p)


def test_huge_gear_ratio_is_refused():
    with pytest.raises(md.ModelError, match=r"DHLink: field 'gear_ratio' has magnitude 1e\+300"):
        md.DHLink(gear_ratio=1e300, motor_inertia=1.0)
    with pytest.raises(md.ModelError, match=r"field 'mass' must be a number"):
        md.DHLink(mass=10**400)


def test_deeply_nested_arrays_in_a_model_file(tmp_path):
    p = tmp_path / "deep.toml"
    p.write_text("nest = " + "[" * 10000 + "]" * 10000 + "\n" + PUMA_TOML)
    with pytest.raises(md.ModelError, match=r"deep\.toml: not a model file: arrays or tables nested too deeply"):
        md.load(p)


def test_nul_and_control_characters_in_names():
    link = md.DHLink(a=0.5, mass=1.0, inertia=(0.1, 0.1, 0.1))
    with pytest.raises(md.ModelError, match=r"Manipulator: field 'name' holds the control character U\+0000 at index 1"):
        md.Manipulator([link], convention="standard", name="a\x00b")
    with pytest.raises(md.ModelError, match=r"DHLink: field 'name' holds the control character U\+0007"):
        md.DHLink(name="bell\x07")


# ---------------------------------------------------------------------------
# CLI: model problems exit 2, failed conditions 1
# ---------------------------------------------------------------------------
MASSLESS = """format = "manipdyn-model/1"
name = "massless"
convention = "standard"
""" + "".join("""
[[links]]
joint = "revolute"
a = 1.0
alpha = 0.0
d = 0.0
theta = 0.0
mass = 0.0
""" for _ in range(2))


def test_track_on_a_massless_arm_is_a_model_error(tmp_path, capsys):
    p = tmp_path / "massless.toml"
    p.write_text(MASSLESS)
    assert cli_main(["track", str(p), "--duration", "0.2"]) == 2
    err = capsys.readouterr().err
    # the gains (pd_gains, 61cea87) now refuse the singular D before any forward dynamics runs, naming the
    # arm and the joints that move no mass (issue 46 item 29): still a model error, exit 2, never internal
    assert "error: massless: the mass matrix D(q) is singular: joint(s) [1, 2] move no mass" in err
    assert "internal" not in err


def test_check_on_a_massless_arm_is_a_failed_condition(tmp_path, capsys):
    p = tmp_path / "massless.toml"
    p.write_text(MASSLESS)
    assert cli_main(["check", str(p), "--samples", "5", "--timing-calls", "0"]) == 1
    out = capsys.readouterr().out
    assert "all agree" not in out and "NOT ALL COULD BE COMPARED" in out and "FAILED" in out


def test_check_on_a_refused_urdf_exits_2(tmp_path, capsys):
    p = tmp_path / "doctype.urdf"
    p.write_text(UR5.replace("<robot", "<!DOCTYPE robot>\n<robot", 1))
    assert cli_main(["check", str(p), "--samples", "5", "--timing-calls", "0"]) == 2
    assert "refused: a DOCTYPE" in capsys.readouterr().err


# ---------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------
def test_save_refuses_device_nodes_and_fifos(tmp_path, ur5):
    arm = md.load("ur5")
    with pytest.raises(OSError, match="refusing to replace a character device"):
        md.save(arm, "/dev/null")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(OSError, match="refusing to replace a FIFO"):
        md.write_urdf(arm, fifo)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    with pytest.raises(IsADirectoryError):
        md.save(arm, tmp_path)
    assert sorted(os.listdir(tmp_path)) == ["fifo"]  # no temporary left


def test_save_keeps_the_mode_of_an_existing_file(tmp_path):
    p = tmp_path / "arm.toml"
    p.write_text("old")
    os.chmod(p, 0o600)
    md.save(md.load("ur5"), p)
    assert stat.S_IMODE(os.stat(p).st_mode) == 0o600
    assert md.load(p).n == 6


def test_save_writes_through_a_symlink(tmp_path):
    target = tmp_path / "real.toml"
    target.write_text("old")
    os.chmod(target, 0o640)
    link = tmp_path / "link.toml"
    link.symlink_to(target)
    md.save(md.load("ur5"), link)
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert stat.S_IMODE(os.stat(target).st_mode) == 0o640
    assert md.load(target).n == 6
    dangling = tmp_path / "dangling.toml"
    dangling.symlink_to(tmp_path / "new.toml")
    md.save(md.load("ur5"), dangling)
    assert dangling.is_symlink() and (tmp_path / "new.toml").is_file()


def test_keyboard_interrupt_during_a_write_leaves_no_temporary(tmp_path):
    p = tmp_path / "x.txt"

    def write(fh):
        fh.write("partial")
        raise KeyboardInterrupt

    from manipdyn._support.files import atomic_write
    with pytest.raises(KeyboardInterrupt):
        atomic_write(p, write)
    assert os.listdir(tmp_path) == []


def test_sigterm_during_a_write_leaves_no_temporary(tmp_path):
    script = textwrap.dedent(f"""
        import sys, time
        from manipdyn._support.files import atomic_write
        def write(fh):
            fh.write("partial")
            fh.flush()
            print("writing", flush=True)
            time.sleep(30)
        atomic_write({str(tmp_path / 'x.txt')!r}, write)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "writing"
        assert any(n.endswith(".tmp") for n in os.listdir(tmp_path))
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert rc == -signal.SIGTERM  # still terminated by the signal
    assert os.listdir(tmp_path) == []


def test_kill_9_leftovers_are_swept_on_the_next_write(tmp_path):
    script = textwrap.dedent(f"""
        import time
        from manipdyn._support.files import atomic_write
        def write(fh):
            fh.write("partial"); fh.flush(); print("writing", flush=True); time.sleep(30)
        atomic_write({str(tmp_path / 'x.txt')!r}, write)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "writing"
        proc.kill()
        proc.wait(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    left = [n for n in os.listdir(tmp_path) if n.endswith(".tmp")]
    assert len(left) == 1 and re.match(rf"^\.x\.txt\.manipdyn-{proc.pid}-\w+\.tmp$", left[0])
    # not yet stale (a process of another host could own it): kept
    assert sweep_stale_temporaries(str(tmp_path)) == []
    old = time.time() - 3600
    os.utime(tmp_path / left[0], (old, old))
    atomic_write_text(tmp_path / "y.txt", "new")  # the next write into the folder sweeps
    assert sorted(os.listdir(tmp_path)) == ["y.txt"]
