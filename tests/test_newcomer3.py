"""Issue 27, as a newcomer meets manipdyn (round three): items 6 to 11 and 13 to 16.

Each test is named after its item.  The README and the guide's pages (``docs/guide/``, read
through ``tests/guide.py`` since issue 38 item 15) are read as a user reads them: their Python
blocks run as scripts of their own, their extras, claims and output files are checked
against the project.  Tests on the real Panda log skip when the log is not beside the
project (it is measured outside it and never copied in).
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main

ROOT = Path(__file__).resolve().parents[1]
import guide
from common import LWR4_DIR, LWR4_SKIP, PANDA_LOG as REALDATA, REALDATA as REALDATA_DIR, \
    needs_panda_log as needs_realdata

#: the README and the guide's pages, one after another
README = guide.TEXT


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


def _blocks(lang: str):
    """``(page:line, text)`` of every fenced block of ``lang`` in the README and the guide."""
    return [(b.where, b.text) for b in guide.blocks(lang)]


def _section(heading: str) -> str:
    return guide.section(heading)


# -- item 6: every Python block of the README runs as its own script -------------------------------
PY_BLOCKS = _blocks("python")
#: blocks that another test runs already (a 200-run Dask study would double the suite's time)
RUN_ELSEWHERE = {"mc.run(study)": "the Monte-Carlo block runs as a script in tests/test_newcomer.py::"
                                  "test_item4_readme_montecarlo_snippet_runs_as_a_script"}


def _run_script(text: str, tmp_path: Path):
    script = tmp_path / "block.py"
    script.write_text(text, encoding="utf-8")
    # a block that reads the real-data folder reads it through MANIPDYN_REALDATA, as the shell blocks do
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", MANIPDYN_REALDATA=str(REALDATA_DIR))
    return subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=900)


def test_item6_readme_has_python_blocks():
    assert len(PY_BLOCKS) >= 8


@pytest.mark.parametrize("line,text", PY_BLOCKS, ids=[ln for ln, _ in PY_BLOCKS])
def test_item6_readme_python_block_runs_alone(line, text, tmp_path):
    for marker, why in RUN_ELSEWHERE.items():
        if marker in text:
            pytest.skip(why)
    if "montecarlo" in text or "dask" in text:
        pytest.importorskip("distributed", reason="the scale extra is not installed")
    if "lwr4_flobaroid" in text and not (LWR4_DIR / "kuka_lwr4_identified.urdf").is_file():
        pytest.skip(LWR4_SKIP)
    proc = _run_script(text, tmp_path)
    assert proc.returncode == 0, f"block at {line}:\n{proc.stderr[-3000:]}"
    assert "Traceback" not in proc.stderr


def test_item6_quick_start_starts_on_a_consistent_arm(tmp_path):
    line, text = PY_BLOCKS[0]
    assert "crosscheck" in text                    # the quick start
    proc = _run_script(text, tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "PhysicalConsistencyWarning" not in proc.stderr and "Warning" not in proc.stderr
    assert "all agree" in proc.stdout


# -- item 7: claims ------------------------------------------------------------------------------
def _pyproject_extras() -> set:
    return set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"])


def test_item7_every_extra_the_readme_names_exists():
    named = set()
    for m in re.finditer(r"(?:\.|manipdyn)\[([A-Za-z0-9_,\- ]+)\]", README):
        named |= {x.strip() for x in m.group(1).split(",")}
    assert {"test", "identify", "plot", "scale", "bench"} <= named     # the parse finds them
    assert named <= _pyproject_extras(), f"extras not in pyproject.toml: {sorted(named - _pyproject_extras())}"


def test_item7_conventions_have_one_drives_bullet():
    bullets = re.findall(r"^\* \*\*(.+?)\*\*", _section("## Conventions in brief"), flags=re.M)
    names = [b.rstrip(":").strip() for b in bullets]
    assert names.count("Drives") == 1, names
    assert len(names) == len(set(names)), names


def test_item7_plants_from_rows_are_explained_by_what_they_draw():
    from manipdyn import montecarlo as mc

    # the code: plants from an identification draw no payload and no added friction
    text = _section("## Is my controller robust to what my data left open?")
    para = text[text.index("| the prior's hand-chosen"):]
    assert re.search(r"first row draws no payload", para), para[:600]
    assert "second row adds an undeclared" in para
    d = mc.ABSOLUTE_DEFAULTS                                 # what the second row draws (issue 46: by options)
    assert d.payload_mass > 0 and d.friction_viscous > 0
    assert "--payload-mass 2 --friction-viscous 0.5 --friction-coulomb 0.5 --torque-noise 0.05" in text
    import inspect
    assert "payload, link scale and added friction" in inspect.getdoc(mc.study)


@pytest.fixture(scope="module")
def panda_identified(tmp_path_factory):
    """The guide's Panda commands, run once: ``identify panda LOG -o panda_id.toml --t-range 0:10
    --friction-terms viscous,coulomb,offset`` (its printout) and ``validate panda_id.toml LOG
    --t-range 10:13.8 --json`` (its figures)."""
    import contextlib
    import io

    pytest.importorskip("cvxpy", reason="identification needs the identify extra")
    out = tmp_path_factory.mktemp("panda") / "panda_id.toml"
    text, figures = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(text), contextlib.redirect_stderr(io.StringIO()):
        assert main(["identify", "panda", str(REALDATA), "-o", str(out), "--t-range", "0:10",
                     "--friction-terms", "viscous,coulomb,offset"]) == 0
    with contextlib.redirect_stdout(figures), contextlib.redirect_stderr(io.StringIO()):
        assert main(["validate", str(out), str(REALDATA), "--t-range", "10:13.8", "--json"]) == 0
    return {"model": out, "text": text.getvalue(), "validate": json.loads(figures.getvalue())}


@needs_realdata
def test_item7_readme_names_every_active_mass_bound(panda_identified):
    text = panda_identified["text"]
    at_mass = sorted({int(k) for k in re.findall(r"^\s+link (\d+) mass at its (?:upper|lower) bound", text, re.M)})
    at_com = sorted({int(k) for k in re.findall(r"^\s+link (\d+) centre of mass \w+ = .* at its bound", text, re.M)})
    m = re.search(r"(\w+) identified links \(([\d, and]+)\) come out at their mass bounds and\s+(\w+) centres "
                  r"of mass \(([^)]+)\) at theirs", README)
    # or, when identify reports none of either: "No identified link comes out at its mass bound and
    # no centre of mass at its bound"
    none = re.search(r"No identified link comes out at its mass bound and\s+no centre of mass at\s+its bound", README)
    assert m or none, "the README's sentence on the active bounds"
    said = sorted(int(x) for x in re.findall(r"\d+", m.group(2))) if m else []
    said_com = sorted(int(x) for x in re.findall(r"\d+", m.group(4))) if m else []
    assert said == at_mass and said_com == at_com


@needs_realdata
def test_issue38_item8_the_guides_panda_figures_are_the_commands(panda_identified):
    """Issue 38 item 8: each figure the guide gives of its Panda identification is read from the page
    and compared with what the commands print now (the held-out RMS row, the identified mass against
    the prior's, link 6's thinnest radius of gyration and whether the fit flags it).  When a change to
    the fit moves them, this fails and names the figure, so the page is refreshed from the commands."""
    page = guide.page("identification")
    # the table row: validate's held-out RMS per joint (printed to 3 decimals)
    row = next(l for l in page.splitlines() if l.startswith("| identified here ("))
    said = [float(x.strip("* ")) for x in row.split("|")[2:-1]]
    np.testing.assert_allclose(panda_identified["validate"]["rms"], said, atol=5e-4 + 1e-9,
                               err_msg="identification.md's row '| identified here (' against validate --json")
    # the mass: "weighs M kg against the prior's P kg (S %)", from the written model and the prior
    m = re.search(r"weighs ([\d.]+) kg against the prior's ([\d.]+) kg\s+\(([+-][\d.]+) %\)", page)
    assert m, "identification.md's sentence on the identified mass"
    mass = sum(l.mass for l in _load(str(panda_identified["model"])).links)
    prior = sum(l.mass for l in _load("panda").links)
    assert float(m.group(1)) == pytest.approx(mass, abs=0.005), f"identified mass {mass:.4g} kg"
    assert float(m.group(2)) == pytest.approx(prior, abs=0.005)
    assert float(m.group(3)) == pytest.approx(100 * (mass / prior - 1), abs=0.05), "the mass change in %"
    # link 6: its smallest radius of gyration in the written model (sqrt of the smallest principal
    # second moment about the COM over the mass, as the fit's doubts measure it), whether it sits at
    # the plausibility floor and whether identify's notes flag it as degenerate
    m = re.search(r"Link 6 weighs ([\d.]+) kg with a smallest radius\s+of gyration of ([\d.]+) mm, (at its floor, )?"
                  r"and is (flagged|not flagged)", page)
    assert m, "identification.md's sentence on link 6"
    body = _load(str(panda_identified["model"])).links[5]
    inertia = np.asarray(body.inertia, dtype=float)
    second = 0.5 * np.trace(inertia) - np.linalg.eigvalsh(inertia)
    radius = float(np.sqrt(max(second.min(), 0.0) / body.mass))
    assert float(m.group(2)) == pytest.approx(1e3 * radius, abs=0.005), f"link 6's radius {1e3 * radius:.3g} mm"
    out = panda_identified["text"]
    flagged = re.search(r"^note: link 6 \(\w+\): degenerate", out, flags=re.M) is not None
    assert (m.group(4) == "flagged") == flagged, "identify's notes on link 6"
    floor = re.search(r"^\s+link 6 radius of gyration (?:[\d.]+ m )?at its floor", out, flags=re.M) is not None
    assert (m.group(3) is not None) == floor, "whether link 6 is at its floor"
    link6 = _load(str(panda_identified["model"])).links[5].mass
    assert float(m.group(1)) == pytest.approx(link6, abs=0.05)


def test_item7_bench_panda_says_each_stage(monkeypatch, tmp_path, capsys):
    """The benchmark takes minutes: it says each stage as it starts, on stderr, before its result."""
    import benchmarks.bench_panda as bp
    import manipdyn.identification as ident
    import manipdyn.identification.estimation.selection as sel

    class Log:
        def __init__(self, t):
            self.t = t
            n = len(t)
            self.q = np.tile(_load("panda").poses["ready"], (n, 1))
            self.qd = self.qdd = np.zeros((n, 7))
            self.tau = np.ones((n, 7))

    def read_log(path, n, t_range=None, **kw):
        t = np.arange(0.0, 14.0, 0.05)
        if t_range is not None:
            t = t[(t >= t_range[0]) & (t < t_range[1])]
        return Log(t)

    class Fit:
        def predict(self, q, qd, qdd):
            return np.zeros_like(q)

        arm = _load("panda")

    monkeypatch.setattr(ident, "read_log", read_log)
    monkeypatch.setattr(sel, "choose_prior_weight", lambda *a, **k: (0.0, None))
    monkeypatch.setattr(bp, "_fit", lambda *a, **k: Fit())
    data = tmp_path / "log.csv"
    data.write_text("t\n")
    assert bp.main(["--data", str(data), "--no-write"]) == 0
    err = capsys.readouterr().err.splitlines()
    stages = [l for l in err if re.match(r"\[\d+/\d+\] ", l)]
    assert [int(re.match(r"\[(\d+)/", l).group(1)) for l in stages] == list(range(1, bp.STAGES + 1))
    assert "about a minute" not in (bp.__doc__ or "") and "(about a minute)" not in README


# -- item 8: the published Panda model ships whole -------------------------------------------------
def test_item8_bundled_panda_carries_gaz_friction():
    from benchmarks.bench_panda import SIGMOID      # the real-data README's table of Gaz et al.

    arm = _load("panda")
    f = arm.friction_model
    assert f is not None
    for k, v in SIGMOID.items():
        np.testing.assert_array_equal(getattr(f, k), v)
    qd = np.linspace(-1.0, 1.0, 7)
    A, a, p3 = (np.array(SIGMOID[k]) for k in ("sigmoid_A", "sigmoid_alpha", "sigmoid_p3"))
    expected = A / (1 + np.exp(-a * (qd + p3))) - A / (1 + np.exp(-a * p3))
    for eng in (arm.lagrange, arm.pinocchio):
        np.testing.assert_allclose(eng.friction_torque(qd), expected, rtol=1e-12, atol=1e-14)
    assert "friction" in arm.sources and "get_FrictionTorque" in arm.sources["friction"]


def test_item8_plant_variants_keep_the_friction_law_drive_and_poses():
    """A payload or scaled plant of the published panda (or any arm with a friction law and a
    coupled drive) is that arm plus the change, not a frictionless rigid copy."""
    from manipdyn.control import with_payload, with_scaled_inertia

    base = _load("ur5")
    law = md.Friction(viscous=np.full(6, 0.3), coulomb=np.full(6, 0.4), n=6)
    tr = md.Transmission.from_gear_ratios([1.0] * 6, [[6, 5, 0.5]])
    arm = md.Manipulator(base.links, convention="standard", name="drive", friction=law, transmission=tr,
                         poses=dict(base.poses))
    rng = np.random.default_rng(7)
    q, qd, qdd = arm.random_state(rng, 5), rng.uniform(-1, 1, (5, 6)), rng.uniform(-1, 1, (5, 6))
    same = with_scaled_inertia(arm, 1.0)
    np.testing.assert_allclose(same.inverse_dynamics(q, qd, qdd), arm.inverse_dynamics(q, qd, qdd), atol=1e-12)
    heavy = with_payload(arm, 1.0, (0, 0, 0.05))
    assert heavy.friction_model == arm.friction_model and heavy.transmission == arm.transmission
    assert list(heavy.poses) == ["zero", "ready"]
    panda = _load("panda")
    v = qd[:, :1].repeat(7, 1)
    np.testing.assert_array_equal(with_payload(panda, 0.5).pinocchio.friction_torque(v),
                                  panda.pinocchio.friction_torque(v))


@pytest.mark.parametrize("name", ["panda", "ur5-smooth-law"])
def test_item8_single_state_derivatives_include_the_friction_law(name):
    """Pinocchio's one-state shortcut of dtau/dqd left a friction law's derivative out (the batch
    path had it): the panda's sigmoid, now bundled, showed it.  Central differences referee."""
    if name == "panda":
        arm = _load("panda")
    else:
        base = _load("ur5")
        arm = md.Manipulator(base.links, convention="standard", name=name,
                             friction=md.Friction(viscous=np.full(6, 0.2), coulomb=np.full(6, 0.5), smoothing=0.3, n=6))
    rng = np.random.default_rng(8)
    q, qd, qdd = arm.random_state(rng), rng.uniform(-0.5, 0.5, arm.n), rng.uniform(-1, 1, arm.n)
    h = 1e-6
    fd = np.column_stack([(arm.inverse_dynamics(q, qd + h * e, qdd) - arm.inverse_dynamics(q, qd - h * e, qdd)) / (2 * h)
                          for e in np.eye(arm.n)])
    for E in (arm.pinocchio, arm.lagrange):
        for args in ((q, qd, qdd), (q.tolist(), qd.tolist(), qdd.tolist()), (q[None], qd[None], qdd[None])):
            dv = np.reshape(E.inverse_dynamics_derivatives(*args)[1], (arm.n, arm.n))
            np.testing.assert_allclose(dv, fd, atol=1e-7)         # central differences, step 1e-6
    A, _ = arm.linearize(q, qd, arm.inverse_dynamics(q, qd, qdd))
    Al, _ = arm.linearize(q, qd, arm.inverse_dynamics(q, qd, qdd), engine="lagrange")
    np.testing.assert_allclose(A, Al, atol=1e-9)


@needs_realdata
def test_item8_validate_panda_is_the_readme_published_row(capsys):
    assert main(["validate", "panda", str(REALDATA), "--t-range", "10:13.8", "--json"]) == 0
    rms = json.loads(capsys.readouterr().out)["rms"]
    row = next(l for l in README.splitlines() if l.startswith("| published (bundled `panda`"))
    said = [float(x.strip("* ")) for x in row.split("|")[2:-1]]
    np.testing.assert_allclose(rms, said, atol=5e-4 + 1e-9)     # the README prints 3 decimals
    assert "manipdyn validate panda $LOG --t-range 10:13.8" in README


# -- item 9: the README's commands leave nothing untracked in the project ------------------------
def _readme_outputs() -> set:
    outs = set()
    inline = [(0, m.group(1)) for m in re.finditer(r"`(manipdyn [^`]+)`", README)]
    for _, block in _blocks("sh") + _blocks("console") + inline:
        for m in re.finditer(r"(?:^|\s)(?:-o|--plot|--base-json|>)\s+([^\s]+)", block, flags=re.M):
            if not m.group(1).startswith("$"):
                outs.add(re.sub(r"\$\{?k\}?", "1", m.group(1)))       # a loop's run$k.csv: run1.csv
    for _, block in PY_BLOCKS:
        for m in re.finditer(r"md\.(?:save|write_urdf)\([^,]+,\s*\"([^\"]+)\"\)", block):
            outs.add(m.group(1))
    for m in re.finditer(r"hard_log\(\d+, '([^']+)'\)", README):
        outs.add(m.group(1) + "/hard_log.csv")
    return {o for o in outs if not o.startswith("/") and o != "/dev/null"}


def test_item9_readme_outputs_are_ignored_by_git():
    if subprocess.run(["git", "rev-parse", "--git-dir"], cwd=ROOT, capture_output=True).returncode:
        pytest.skip("not a git checkout")
    outs = _readme_outputs()
    assert {"traj.csv", "data.csv", "track.png", "my_arm.urdf", "my_arm.toml", "id.json"} <= outs, outs
    for path in sorted(outs):
        ignored = subprocess.run(["git", "check-ignore", "-q", "--no-index", path], cwd=ROOT).returncode
        assert ignored == 0, f"{path}: a README command writes it into the project's folder, and git sees it"
    tracked_but_ignored = subprocess.run(["git", "ls-files", "-ci", "--exclude-standard"], cwd=ROOT,
                                         capture_output=True, text=True).stdout.split()
    assert tracked_but_ignored == []            # pyproject.toml and the rest stay visible


# -- item 10: the Jacobian, its derivative, manipulability, poses, fkine ------------------------
ARMS = [*md.models(), "erd:ur5_robot"]


def _vee(W):
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def _fd_jacobian(arm, q, h=1e-6):
    """Central differences of fkine: linear velocity of the origin, and vee(dR R^T)."""
    n = arm.n
    J = np.empty((6, n))
    R = arm.fkine(q)[:3, :3]
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        Tp, Tm = arm.fkine(q + e), arm.fkine(q - e)
        dT = (Tp - Tm) / (2 * h)
        J[:3, j] = dT[:3, 3]
        J[3:, j] = _vee(dT[:3, :3] @ R.T)
    return J


@pytest.mark.parametrize("name", ARMS)
def test_item10_jacobian_two_ways_and_finite_differences(name):
    arm = _load(name)
    rng = np.random.default_rng(3)
    q = arm.random_state(rng, 4)
    JL, JP = arm.lagrange.jacobian(q), arm.pinocchio.jacobian(q)
    assert JL.shape == JP.shape == (4, 6, arm.n)
    np.testing.assert_allclose(JL, JP, atol=1e-12)
    for k in range(len(q)):
        # central differences: truncation h^2 ~ 1e-12 and round-off 1e-16/h ~ 1e-10 on O(1) poses
        np.testing.assert_allclose(JL[k], _fd_jacobian(arm, q[k]), atol=1e-8)
    np.testing.assert_array_equal(arm.jacobian(q[0]), JP[0])       # the arm: Pinocchio, (6, n)
    np.testing.assert_allclose(arm.jacobian(q[0], engine="lagrange"), JL[0], atol=1e-15)


@pytest.mark.parametrize("name", ["puma560", "stanford", "panda", "erd:ur5_robot"])
def test_item10_jacobian_dot_is_the_time_derivative(name):
    arm = _load(name)
    rng = np.random.default_rng(4)
    q, qd = arm.random_state(rng, 3), rng.uniform(-1, 1, (3, arm.n))
    DL, DP = arm.lagrange.jacobian_dot(q, qd), arm.pinocchio.jacobian_dot(q, qd)
    assert DL.shape == DP.shape == (3, 6, arm.n)
    np.testing.assert_allclose(DL, DP, atol=1e-12)
    h = 1e-6
    fd = (arm.lagrange.jacobian(q + h * qd) - arm.lagrange.jacobian(q - h * qd)) / (2 * h)
    np.testing.assert_allclose(DL, fd, atol=1e-8)                  # as above
    np.testing.assert_array_equal(arm.jacobian_dot(q[1], qd[1]), DP[1])


def test_item10_crosscheck_compares_the_jacobian_and_catches_a_wrong_one():
    arm = _load("ur5")
    report = md.crosscheck(arm, samples=20)
    assert report.ok and report["J"].ok and report["Jdot"].ok

    class SwappedRows:                      # a planted bug: angular velocity on top
        def __init__(self, eng):
            self._eng, self.name = eng, eng.name

        def __getattr__(self, attr):
            return getattr(self._eng, attr)

        def jacobian(self, q, frame="world", link=None):
            J = self._eng.jacobian(q, frame=frame, link=link)
            return np.concatenate((J[..., 3:, :], J[..., :3, :]), axis=-2)

    bad = _load("ur5")
    bad.set_engine("pinocchio", SwappedRows(bad.pinocchio))
    r = md.crosscheck(bad, samples=20)
    assert not r["J"].ok and r["Jdot"].ok and "J" in r.failures()


def test_item10_an_engine_without_jacobian_is_not_a_failure():
    from manipdyn.engines.protocol import OPTIONAL_ENGINE_METHODS

    class DynamicsOnly:                     # as the generated-C engine: no jacobian, no jacobian_dot
        def __init__(self, eng):
            self._eng, self.name = eng, "c"

        def __getattr__(self, attr):
            if attr in OPTIONAL_ENGINE_METHODS:
                raise AttributeError(attr)
            return getattr(self._eng, attr)

    arm = _load("ur5")
    arm.set_engine("pinocchio", DynamicsOnly(arm.pinocchio))
    r = md.crosscheck(arm, samples=10)
    assert r.ok and not r.not_compared and "J" not in r.quantities
    assert [n for n in r.notes if "not compared" in n] == [
        "J, Jdot, J_tool, J_link, tau_f not compared where engine pinocchio takes part: it offers no jacobian, "
        "jacobian_dot (optional)"]
    assert isinstance(_load("ur5").lagrange, md.JacobianEngine)
    assert not isinstance(DynamicsOnly(arm.lagrange), md.JacobianEngine)
    with pytest.raises(md.ModelError, match="offers no jacobian"):
        arm.jacobian(np.zeros(6))


def test_item10_manipulability():
    arm = _load("ur5")
    rng = np.random.default_rng(5)
    q = arm.random_state(rng, 5)
    J = arm.jacobian(q)
    np.testing.assert_allclose(arm.manipulability(q), np.sqrt(np.linalg.det(J @ J.swapaxes(1, 2))), rtol=1e-12)
    Jv = J[:, :3]
    np.testing.assert_allclose(arm.manipulability(q, axes="trans"),
                               np.sqrt(np.linalg.det(Jv @ Jv.swapaxes(1, 2))), rtol=1e-12)
    assert isinstance(arm.manipulability(q[0]), float) and arm.manipulability(q[0]) > 1e-4
    # the Toolbox's ready pose of the UR5 stretches the elbow (q3 = 0): a singularity
    assert arm.manipulability(arm.poses["ready"]) < 1e-6
    with pytest.raises(ValueError, match="axes: expected one of all, trans, rot"):
        arm.manipulability(q[0], axes="xyz")


def test_item10_every_bundled_arm_has_cited_named_poses(tmp_path):
    toolbox_ready = {"puma560": [0, 90, -90, 0, 0, 0], "ur5": [180, 0, 0, 0, 90, 0], "ur10": [180, 0, 0, 0, 90, 0],
                     "ur5e": [180, 0, 0, 0, 90, 0]}
    for name in md.models():
        arm = _load(name)
        assert arm.poses, name
        assert "poses" in arm.sources, name
        for key, q in arm.poses.items():
            assert q.shape == (arm.n,) and not q.flags.writeable
            if np.any(q < arm.qlim[:, 0]) or np.any(q > arm.qlim[:, 1]):   # kept as published, and said
                assert key in arm.sources["poses"] and "outside" in arm.sources["poses"], (name, key)
        if name in toolbox_ready:
            np.testing.assert_allclose(arm.poses["ready"], np.radians(toolbox_ready[name]), atol=1e-15)
    np.testing.assert_allclose(_load("panda").poses["ready"], [0, -0.3, 0, -2.2, 0, 2.0, np.pi / 4], atol=1e-15)
    arm = _load("puma560")
    md.save(arm, tmp_path / "p.toml")
    back = _load(str(tmp_path / "p.toml"))
    assert back == arm and list(back.poses) == list(arm.poses)
    with pytest.raises(TypeError):
        arm.poses["mine"] = np.zeros(6)                             # read-only


@pytest.mark.parametrize("table,match", [
    ("ready = [0.0, 1.0]", "poses.ready.*expected a list of 6 numbers"),
    ('ready = "up"', "poses.ready.*expected a list of 6 numbers"),
    ("ready = [0.0, 0.0, 0.0, 0.0, 0.0, nan]", "poses.ready"),
])
def test_item10_bad_poses_name_the_key(table, match, tmp_path):
    text = (Path(md.__file__).parent / "formats" / "models" / "ur5.toml").read_text()
    head, rest = text.split("[poses]\n", 1)
    bad = tmp_path / "bad.toml"
    bad.write_text(head + "[poses]\n" + table + "\n" + rest[rest.index("\n\n"):])
    with pytest.raises(md.ModelError, match=match):
        md.load(str(bad))


def test_item10_fkine_names_its_frame():
    doc = md.Arm.fkine.__doc__
    assert "tool frame" in doc and "DH frame n" in doc and "tip" in doc and "(4, 4)" in doc
    arm = _load("puma560")
    q = arm.poses["ready"]
    np.testing.assert_allclose(arm.fkine(q), arm.pinocchio.frame_placement(q, "tool"), atol=1e-14)


# -- item 11: the calls of the engines on the arm ----------------------------------------------
def test_item11_arm_answers_coriolis_matrix_regressor_kinetic_energy():
    arm = _load("puma560_akb")
    rng = np.random.default_rng(6)
    q, qd, qdd = arm.random_state(rng, 3), rng.uniform(-1, 1, (3, 6)), rng.uniform(-1, 1, (3, 6))
    np.testing.assert_array_equal(arm.coriolis_matrix(q, qd), arm.pinocchio.coriolis_matrix(q, qd))
    np.testing.assert_array_equal(arm.regressor(q, qd, qdd, armature=True),
                                  arm.pinocchio.regressor(q, qd, qdd, armature=True))
    np.testing.assert_array_equal(arm.kinetic_energy(q, qd), arm.pinocchio.kinetic_energy(q, qd))
    # and they are the arm's dynamics: Y pi = tau, K = qd^T D qd / 2, C qd = h
    tau = arm.inverse_dynamics(q, qd, qdd)
    np.testing.assert_allclose(arm.regressor(q, qd, qdd, armature=True) @ arm.parameters(armature=True), tau,
                               rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(arm.kinetic_energy(q, qd), 0.5 * np.einsum("bi,bij,bj->b", qd, arm.mass_matrix(q), qd),
                               rtol=1e-12)
    np.testing.assert_allclose(np.einsum("bij,bj->bi", arm.coriolis_matrix(q, qd), qd), arm.coriolis_torque(q, qd),
                               atol=1e-12)


# -- item 13: the calibration study's --help describes every option ------------------------------
def test_item13_calibration_help_describes_every_option(capsys):
    from manipdyn.identification.experiments.calibration import build_parser

    parser = build_parser()
    options = [a for a in parser._actions if a.dest != "help"]
    assert {a.dest for a in options} == {"model", "repeats", "noise", "seed"}
    for a in options:
        assert a.help and len(a.help) > 20, a.dest
    with pytest.raises(SystemExit):
        parser.parse_args(["--help"])
    out = capsys.readouterr().out
    assert "``" not in out and "default: 500" in out


# -- item 14: the Monte-Carlo header says what was drawn ---------------------------------------
def test_item14_montecarlo_header_wording(capsys):
    assert main(["montecarlo", "puma560", "--runs", "1", "--duration", "0.03", "--scheduler", "sync",
                 "--controllers", "ct", "--friction-viscous", "0", "--friction-coulomb", "0"]) == 0
    head = capsys.readouterr().out.splitlines()[:2]
    assert "1 run x 1 controller," in head[0]
    assert "no added friction" in head[1] and "added friction:" not in head[1]
    assert main(["montecarlo", "puma560", "--runs", "2", "--duration", "0.03", "--scheduler", "sync",
                 "--controllers", "ct,pd", "--payload-mass", "0"]) == 0
    head = capsys.readouterr().out.splitlines()[:2]
    assert "2 runs x 2 controllers," in head[0]
    # the default draws are now sized to the arm (issue 46 item 18, merge f679cd4): the header says so and
    # gives the sized bounds (fractions of each joint's torque scale tau_j) instead of the old absolute 0.5
    assert "distributions sized to the arm" in head[1] and "no payload" in head[1]
    assert "added friction: viscous <= 0.1 tau_j / qd_j, Coulomb <= 0.1 tau_j" in head[1]


# -- item 15: figures --------------------------------------------------------------------------
@pytest.fixture
def captured_figures(monkeypatch, tmp_path):
    pytest.importorskip("matplotlib", reason="figures need the plot extra")
    monkeypatch.chdir(tmp_path)          # nothing is written, and if it were, not into the project
    import matplotlib

    matplotlib.use("Agg")
    import manipdyn._support.figures as figures
    import manipdyn.control.plots as plots

    figs = []

    def keep(fig, path):
        fig.canvas.draw()
        figs.append(fig)

    monkeypatch.setattr(plots, "save_figure", keep)
    monkeypatch.setattr(figures, "save_figure", keep)
    return figs


def _texts(fig):
    return [t.get_text() for t in fig.findobj(lambda o: hasattr(o, "get_text"))]


def test_item15_validation_residual_says_measured_minus_predicted(captured_figures):
    from manipdyn.identification.results import validation

    t = np.linspace(0, 1, 50)
    meas = np.column_stack([np.sin(t), np.cos(t)])
    r = validation.ValidationResult(model="m", rms=np.ones(2), relative_rms=np.ones(2), r2=np.ones(2),
                                    mean_error=np.zeros(2), t=t, measured=meas, predicted=meas * 0.9)
    validation.plot_validation(r, "v.png")
    texts = [" ".join(x.split()) for x in _texts(captured_figures[-1])]
    assert sum("measured \u2212 predicted" in x for x in texts) == 2        # one per joint's residual panel
    # issue 31 item 21: it is the residual axis's label, outside the traces, not a text over them
    labels = [" ".join(ax.get_ylabel().split()) for ax in captured_figures[-1].axes]
    assert sum(x.startswith("measured \u2212 predicted") for x in labels) == 2
    assert not any(ax.texts for ax in captured_figures[-1].axes)


def test_item15_base_model_figure_is_named_by_its_file(monkeypatch):
    import manipdyn.identification.results.basemodel as bm
    from manipdyn.cli import validate as cli_validate

    class Base:
        name = "panda"

    monkeypatch.setattr(bm, "load_base_model", lambda spec: Base())
    _, label = cli_validate.load_model("runs/b.json")
    assert label.startswith("b.json") and label != "panda (base model)" and "panda" in label


def test_item15_track_figures_have_units_and_show_every_joint(captured_figures):
    from manipdyn.control import ComputedTorque, PD, Quintic
    from manipdyn.control.plots import plot_compare, plot_single

    arm = _load("puma560")
    path = Quintic(np.zeros(6), np.full(6, 0.3), duration=0.05)
    logs = {"PD": md.simulate(arm, PD(arm, kp=100, kd=20), path, duration=0.05),
            "CT": md.simulate(arm, ComputedTorque(arm, kp=100, kd=20), path, duration=0.05)}
    plot_compare(logs, arm, "t", "c.png")
    fig = captured_figures[-1]
    ax_n, ax_r, ax_p = fig.axes[:3]
    assert "(rad)" in ax_n.get_ylabel() and "(rad)" in ax_r.get_ylabel() and "(N m)" in ax_p.get_ylabel()
    assert ax_p.get_yscale() == "log"           # a wrist's torques beside a shoulder's
    plot_single(logs["CT"], arm, "t", "s.png")
    ax_e, ax_t = captured_figures[-1].axes[:2]
    assert ax_e.get_ylabel().endswith("(rad)") and ax_t.get_ylabel().endswith("(N m)")


@pytest.mark.parametrize("lo,hi", [(55.0, 90.0), (65.5, 114.7), (0.003, 0.25), (2e-5, 3.0)])
def test_item15_log_axes_print_plain_numbers(lo, hi, captured_figures):
    from manipdyn.control.plots import plain_log_ticks, pyplot

    plt = pyplot()
    fig, ax = plt.subplots()
    ax.plot([lo, hi], [0, 1])
    ax.set_xscale("log")
    plain_log_ticks(ax.xaxis)
    fig.canvas.draw()
    shown = [(t.get_loc(), t.label1.get_text()) for t in ax.xaxis.get_major_ticks() + ax.xaxis.get_minor_ticks()
             if t.label1.get_text() and lo <= t.get_loc() <= hi]
    assert len(shown) >= 2, shown                                   # never a lone label
    for loc, text in shown:
        assert re.fullmatch(r"[0-9.e+-]+", text) and math.isclose(float(text), loc, rel_tol=1e-6), text
    plt.close(fig)


def test_item15_montecarlo_figure_uses_plain_log_ticks(captured_figures, monkeypatch):
    from manipdyn import montecarlo as mc
    import manipdyn.control.montecarlo.plot as mplot

    monkeypatch.setattr(mplot, "save_figure", lambda fig, path: (fig.canvas.draw(), captured_figures.append(fig)))
    study = mc.study(_load("puma560"), runs=2, seed=1, controllers=("ct",), duration=0.05)
    mplot.plot_report(mc.run(study, scheduler="sync"), "mc.png")
    for ax in captured_figures[-1].axes:
        if ax.get_xscale() == "log":
            labels = [t.label1.get_text() for t in ax.xaxis.get_major_ticks() + ax.xaxis.get_minor_ticks()]
            assert not any("times" in x or "^" in x for x in labels), labels


# -- item 16: manipdyn bench --strict ------------------------------------------------------------
def test_item16_bench_strict_exits_1_on_a_miss(monkeypatch, tmp_path, capsys):
    from benchmarks import run

    real = run.evaluate_targets

    def missed(*a, **k):             # the first target, planted as missed (a smoke run times too little)
        targets = real(*a, **k)
        first = dict(targets[0], status="MISS", measured={"puma560": 99.0}, worst_arm="puma560", worst=99.0,
                     miss_by="planted")
        first.pop("reason", None)
        return [first] + targets[1:]

    monkeypatch.setattr(run, "evaluate_targets", missed)
    quick = ["--smoke", "--no-rtb", "--no-plot", "--skip", "batch", "scaling"]
    assert run.main(quick + ["--out", str(tmp_path / "a")]) == 0
    assert "--strict makes a miss exit 1" in capsys.readouterr().out
    assert run.main(quick + ["--strict", "--out", str(tmp_path / "b")]) == 1
    assert re.search(r"--strict: missed \w+", capsys.readouterr().err)
    assert json.loads((tmp_path / "b" / "results.json").read_text())["targets"][0]["status"] == "MISS"


def test_item16_manipdyn_bench_passes_strict_to_the_suite(monkeypatch):
    import manipdyn.cli.bench as bench_cmd

    seen = []

    class Child:
        def __init__(self, cmd, **kw):
            seen.append(cmd)

        def wait(self, timeout=None):
            return 1

    monkeypatch.setattr(bench_cmd.subprocess, "Popen", Child)
    assert main(["bench", "--strict", "--smoke"]) == 1
    assert "--strict" in seen[0] and "--smoke" in seen[0]
