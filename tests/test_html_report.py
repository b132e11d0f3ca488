"""Reports a person reads (issue 33): ``--report FILE.html`` on ``identify``, ``validate`` and
``montecarlo``.  The page's tables hold the numbers of ``--json`` of the same command (item 2),
each kind renders in headless Chromium with its figures (item 3), the page fetches nothing and
escapes hostile names, and ``--report`` goes through the output checks (item 4)."""

from __future__ import annotations

import base64
import json
import os
import re
import shutil
import subprocess
import tempfile

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support import html as H
from manipdyn.cli import main

HOSTILE = "<script>alert(1)</script>&\"'"


def _page_is_self_contained(text: str) -> None:
    """No script, nothing fetched: every src is a data: URI, no link/iframe/object, the CSP in place."""
    low = text.lower()
    assert "<script" not in low and "javascript:" not in low
    for tag in ("<link", "<iframe", "<object", "<embed", "@import", "url("):
        assert tag not in low, tag
    srcs = re.findall(r'\b(?:src|href)\s*=\s*"([^"]*)"', text, flags=re.I)
    assert all(s.startswith("data:image/png;base64,") for s in srcs), srcs[:3]
    assert H.CSP in text


def _pngs(text: str) -> list:
    """The inline figures: each one's alt text and decoded PNG bytes."""
    out = []
    for data, alt in re.findall(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)" alt="([^"]+)"', text):
        png = base64.b64decode(data)
        assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(alt) > 40
        out.append((alt, png))
    return out


def _close(a, b):
    """A page number (exact, from data-value) against the JSON's: both None, or equal to rounding
    (the page keeps repr(float), so the two agree bit for bit; 1e-12 only allows a float32 slip)."""
    if a is None or b is None:
        return a is None and b is None
    return abs(a - b) <= 1e-12 * max(1.0, abs(b))


# --------------------------------------------------------------------------- the generic blocks


def test_blocks_escape_and_read_back_exactly():
    """Escaped text, numbers read back from data-value bit for bit, flagged rows marked, and a
    Markup fragment left as HTML."""
    vals = [0.1 + 0.2, 1e-300, -3.5, None, float("nan")]
    tab = H.table(["name", "value"], [[HOSTILE, v] for v in vals], name="t", flagged={1})
    assert "<script>" not in tab and "&lt;script&gt;" in tab
    assert '<tr class="flag"><th scope="row">' in tab
    rows = H.read_tables(H.page(HOSTILE, HOSTILE, [tab]))["t"]
    assert rows[0] == ["name", "value"] and all(r[0] == HOSTILE for r in rows[1:])
    assert rows[1][1] == 0.1 + 0.2 and rows[2][1] == 1e-300 and rows[3][1] == -3.5 and rows[4][1] is None
    assert np.isnan(rows[5][1])
    page = H.page(HOSTILE, "sub", [H.section(HOSTILE, H.facts([(HOSTILE, HOSTILE)]), "plain <b>text</b>")])
    _page_is_self_contained(page)
    assert page.count("&lt;script&gt;") >= 3 and "plain &lt;b&gt;text&lt;/b&gt;" in page


# --------------------------------------------------------------------------- fixtures: real runs


@pytest.fixture(scope="module")
def idv(tmp_path_factory):
    """One identification and its validations, each with --report and --json (the same command).
    A UR5 named hostilely, fitted on one synthetic excitation and scored on another whose q2 is
    shifted 0.6 rad past the fitted states (joint 2 extrapolates), alone and beside the prior."""
    pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
    pytest.importorskip("matplotlib", reason="the reports' figures need the plot extra (matplotlib)")
    from manipdyn.identification import excitation, write_measurements_csv

    d = tmp_path_factory.mktemp("reports")
    arm = md.load("ur5")
    sigma = np.array([0.06, 0.5, 0.15, 0.02, 0.004, 0.001])      # ~1 % of each joint's peak torque

    def log(path, seed, shift=0.0):
        ex = excitation(arm, duration=10.0, harmonics=3, rate=100.0, iterations=0, seed=seed)
        q = ex.q + np.asarray(shift)
        tau = arm.inverse_dynamics(q, ex.qd, ex.qdd) + sigma * np.random.default_rng(seed).standard_normal(q.shape)
        write_measurements_csv(path, ex.t, q, tau, qd=ex.qd, qdd=ex.qdd)

    fit_log = d / f"fit {HOSTILE[:8]}<b>.csv"          # a hostile file name, kept by the pages as text
    new_log = d / "shifted.csv"
    log(fit_log, 1)
    log(new_log, 2, [0.0, 0.6, 0.0, 0.0, 0.0, 0.0])
    prior = d / "prior.toml"
    md.save(md.Manipulator(arm.links, convention=arm.convention, gravity=arm.gravity, name=HOSTILE), prior)
    model = d / "ur5_id.toml"
    out = {"dir": d, "fit_log": fit_log, "new_log": new_log, "model": model, "prior": prior}
    runs = {"identify": ["identify", str(prior), str(fit_log), "-o", str(model)],
            "validate": ["validate", str(model), str(new_log)],
            "side_by_side": ["validate", str(model), str(prior), str(new_log)]}
    import contextlib
    import io

    for kind, argv in runs.items():     # one command prints --json and writes --report
        page = d / f"{kind}.html"
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            assert main(argv + ["--report", str(page), "--json"]) == 0, kind
        out[kind] = (page.read_text(encoding="utf-8"), json.loads(buf.getvalue()))
    return out


@pytest.fixture(scope="module")
def mc(tmp_path_factory):
    """A small Monte-Carlo study (3 runs of PD and computed torque on the PUMA 560 named hostilely,
    in this process), its page and its --json."""
    pytest.importorskip("matplotlib", reason="the reports' figures need the plot extra (matplotlib)")
    import warnings

    d = tmp_path_factory.mktemp("mc")
    model = d / "puma.toml"
    with warnings.catch_warnings():       # the bundled PUMA's own notes: not this test's business
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        puma = md.load("puma560")
        md.save(md.Manipulator(puma.links, convention=puma.convention, gravity=puma.gravity, name=HOSTILE), model)
    argv = ["montecarlo", str(model), "--runs", "3", "--controllers", "pd,ct", "--duration", "0.5",
            "--scheduler", "sync", "--no-progress"]
    page = d / "mc.html"
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(argv + ["--json", "--report", str(page)]) == 0
    return page.read_text(encoding="utf-8"), json.loads(buf.getvalue()), d


# --------------------------------------------------------------------------- item 2: the numbers of --json


def test_identify_tables_hold_the_json(idv):
    text, rep = idv["identify"]
    _page_is_self_contained(text)
    t = H.read_tables(text)
    joints = t["joints"][1:]
    band = rep["provenance"]["prediction_band"]
    assert len(joints) == 6
    for j, row in enumerate(joints):
        assert row[0] == f"joint {j + 1}"
        for got, want in zip(row[1:], (rep["rms_residual"][j], band["held_out_rms"][j], rep["noise_sigma"][j],
                                       band["half_width"][j])):
            assert _close(got, want), (j, row)
    params = t["base_parameters"][1:]
    assert len(params) == rep["n_base"]
    for row, p in zip(params, rep["base_parameters"]):
        assert row[1] == p["expression"] and _close(row[2], p["value"]) and _close(row[3], p.get("std"))
    links = t["links"][1:]                                   # the bodies, fitted beside the prior's
    assert len(links) == 6 == len(rep["links"])
    for row, b in zip(links, rep["links"]):
        assert row[0] == f"{b['link']} ({b['name']})"
        for got, want in zip(row[1:], [b["mass"], b["prior_mass"], *b["com"], *b["principal_moments"]]):
            assert _close(got, want), (row, b)
    assert rep["provenance"]["data_sha256"] in text          # the log named with its sha256
    for bound in rep.get("active_bounds") or []:              # the active bounds, in words
        assert f"<li>{H.escape(bound)}</li>" in text
    assert bool(rep.get("active_bounds")) != ("No plausibility bound is active" in text)
    assert len(_pngs(text)) == 1


def test_validate_tables_hold_the_json_and_highlight_the_flagged_joint(idv):
    text, rep = idv["validate"]
    _page_is_self_contained(text)
    rows = H.read_tables(text)["joints"]
    head, body = rows[0], rows[1:]
    col = {h: k for k, h in enumerate(head)}
    keys = {"RMS error": "rms", "RMS / measured RMS": "relative_rms", "R^2": "r2", "mean error": "mean_error",
            "band coverage": "band_95_coverage"}
    for j, row in enumerate(body):
        for h, key in keys.items():
            assert _close(row[col[h]], rep[key][j]), (h, j)
        ex = rep["extrapolation"][j]
        assert _close(row[col["outside fitted range"]], ex["outside_fraction"])
        assert _close(row[col["far outside"]], ex["far_outside_fraction"])
        assert ("EXTRAPOLATES" in row[col["flags"]]) == ex["extrapolates"]
    assert rep["extrapolation"][1]["extrapolates"]          # the shifted joint, flagged ...
    flagged = re.findall(r'<tr class="flag"><th scope="row">joint (\d)', text)
    assert "2" in flagged and sorted(map(int, flagged)) == [e["joint"] for e in rep["extrapolation"]
                                                           if e["extrapolates"] or e["joint"] in
                                                           rep.get("band_95_missed", [])]
    assert "Hatched yellow stretches" in text                # ... and its stretches shaded in the figure
    for note in rep["data_notes"]:
        assert H.escape(note) in text


def test_validate_side_by_side_holds_the_json(idv):
    text, rep = idv["side_by_side"]
    t = H.read_tables(text)
    head, body = t["side_by_side"][0], t["side_by_side"][1:]
    assert len(head) == 2 + len(rep["models"])
    for j, row in enumerate(body):
        for k, m in enumerate(rep["models"]):
            assert _close(row[1 + k], m["rms"][j])
        assert row[-1] == rep["best"][j]["model"]
    for k, m in enumerate(rep["models"]):
        rows = t[f"joints_{k + 1}"][1:]
        assert [r[1] for r in rows] == m["rms"]


def test_montecarlo_tables_hold_the_json(mc):
    text, rep, _ = mc
    _page_is_self_contained(text)
    t = H.read_tables(text)
    dist = t["distribution"][1:]
    expected = [[c[m][k] for k in ("p50", "p90", "p99", "max")]
                for c in rep["controllers"].values() for m in ("rms_error", "max_error", "peak_torque")]
    assert [row[2:6] for row in dist] == expected
    div = t["divergences"][1:]
    assert [row[1:3] for row in div] == [[c["diverged"], c["saturated"]] for c in rep["controllers"].values()]
    worst = t["worst"][1:]
    want = [[w["run"], w["rms_error"], w["max_error"]] for c in rep["controllers"].values() for w in c["worst"]]
    assert [[int(r[2]), r[3], r[4]] for r in worst] == want
    assert len(_pngs(text)) == 1


# --------------------------------------------------------------------------- item 4: safe output


def test_hostile_names_are_text(idv, mc):
    """A model named ``<script>...`` and a log whose file name holds markup appear escaped, never as tags."""
    for kind in ("identify", "validate", "side_by_side"):
        text = idv[kind][0]
        assert "<script>" not in text and "<b>.csv" not in text, kind
    assert "&lt;b&gt;.csv" in idv["identify"][0] and "&lt;script&gt;" in idv["side_by_side"][0]
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in mc[0] and "<script>" not in mc[0]


def test_report_goes_through_the_output_checks(idv, capsys):
    """Onto an input: refused before any work, the input untouched; onto another output, not .html, or
    into a missing folder: one line, exit 2; an existing report is replaced whole (atomic write)."""
    d, log, model = idv["dir"], idv["new_log"], idv["model"]
    before = log.read_bytes()
    assert main(["validate", str(model), str(log), "--report", str(log)]) == 2
    assert "--report" in capsys.readouterr().err and log.read_bytes() == before
    link = d / "link.html"
    link.symlink_to(log)
    assert main(["validate", str(model), str(log), "--report", str(link)]) == 2
    assert "would overwrite" in capsys.readouterr().err and log.read_bytes() == before
    assert main(["validate", str(model), str(log), "--report", str(d / "r.png")]) == 2
    assert "--report: expected a file name ending in .html" in capsys.readouterr().err
    assert main(["validate", str(model), str(log), "--report", str(d / "nope" / "r.html")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["identify", str(idv["prior"]), str(log), "-o", str(d / "m.toml"), "--base-json",
                 str(d / "x.html"), "--report", str(d / "x.html")]) == 2
    assert "the same file" in capsys.readouterr().err
    fit_link = d / "fit-link.html"
    fit_link.symlink_to(idv["fit_log"])
    fit_before = idv["fit_log"].read_bytes()
    assert main(["identify", str(idv["prior"]), str(idv["fit_log"]), "-o", str(d / "m.toml"), "--report",
                 str(fit_link)]) == 2
    assert "would overwrite LOG" in capsys.readouterr().err and idv["fit_log"].read_bytes() == fit_before
    assert main(["montecarlo", "puma560", "--runs", "1", "--report", "puma560.txt"]) == 2
    assert "--report" in capsys.readouterr().err
    page = d / "validate.html"
    assert main(["validate", str(model), str(log), "--report", str(page)]) == 0
    assert page.read_text(encoding="utf-8").rstrip().endswith("</html>")
    assert not [p for p in os.listdir(d) if p.endswith(".tmp")]


# --------------------------------------------------------------------------- item 3: a real browser


def _browser():
    """The Chromium executable, or skip saying why."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("no chromium on PATH (Debian: apt-get install chromium; .ci/run installs it)")
    try:
        subprocess.run([exe, "--version"], capture_output=True, timeout=30, check=True)
    except (OSError, subprocess.SubprocessError) as exc:
        pytest.skip(f"{exe} is installed but does not run here: {exc}")
    return exe


def _screenshot(exe, page, png, height):
    """Headless Chromium renders ``page`` to ``png`` (a fresh profile, no network services), bounded in time."""
    profile = tempfile.mkdtemp(prefix="md-chromium-")
    try:
        r = subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                            "--disable-background-networking", "--disable-component-update", "--disable-sync",
                            f"--user-data-dir={profile}", f"--screenshot={png}", f"--window-size=1200,{height}",
                            page.as_uri()], capture_output=True, text=True, timeout=120)
    finally:
        shutil.rmtree(profile, ignore_errors=True)
    assert png.exists(), r.stderr[-2000:]


@pytest.mark.parametrize("kind", ["montecarlo", "identify", "validate", "side_by_side"])
def test_each_report_renders_in_chromium_with_its_figures(kind, idv, mc, tmp_path):
    """The screenshot is not blank (many distinct colours, most of it not background) and shows the
    figure: matplotlib's first two line colours (#1f77b4, #ff7f0e, which the page's own styles never
    use) are drawn (two models' lines lie on each other in the side by side)."""
    exe = _browser()
    import matplotlib.image as mpimg

    page = mc[2] / "mc.html" if kind == "montecarlo" else idv["dir"] / f"{kind}.html"
    png = tmp_path / f"{kind}.png"
    _screenshot(exe, page, png, 5200)
    img = (mpimg.imread(png)[:, :, :3] * 255).round().astype(int)
    flat = img.reshape(-1, 3)
    assert len(np.unique(flat, axis=0)) > 200                            # text, tables and a figure, not a blank page
    assert np.mean(np.all(flat >= 250, axis=1)) < 0.97                    # something drawn
    lines = sum(np.all(np.abs(flat - c) <= 12, axis=1).sum() for c in ([0x1F, 0x77, 0xB4], [0xFF, 0x7F, 0x0E]))
    assert lines > 300, lines                 # C0/C1 curves, antialiased: a missing image leaves none


# --------------------------------------------------------------------------- the library calls


def test_library_calls_write_the_same_pages(idv, tmp_path):
    """``md.validate(...).report_html(path)``: the page of the library call holds the same per-joint
    numbers as the command's; the shaded stretches are the samples the JSON counts as far outside
    (the fallback mask when the extrapolation carries no per-sample one), and a per-sample ``beyond``
    mask, when a model's trust data carries one, is the one drawn."""
    from types import SimpleNamespace

    from manipdyn.identification.results.html import beyond_mask

    res = md.validate(str(idv["model"]), str(idv["new_log"]))
    page = tmp_path / "lib.html"
    assert res.report_html(page) == str(page)
    lib = H.read_tables(page.read_text(encoding="utf-8"))["joints"]
    cli = H.read_tables(idv["validate"][0])["joints"]
    assert lib == cli
    r = res.results[0]
    mask = beyond_mask(r, res.data)
    # the shading follows the mask the extrapolation carries (issue 37's per-sample flags, the x columns): its
    # per-joint fraction is --json's flagged_fraction; without a mask, the range rule's far_outside_fraction
    far = [e.get("flagged_fraction", e.get("beyond_fit_fraction", e["far_outside_fraction"]))
           for e in idv["validate"][1]["extrapolation"]]
    np.testing.assert_allclose(mask.mean(axis=0), far, rtol=0, atol=1e-12)
    carried = np.zeros_like(mask)
    carried[::7, 3] = True
    fake = SimpleNamespace(measured=r.measured, extrapolation=SimpleNamespace(beyond=carried))
    assert beyond_mask(fake, None) is not None and np.array_equal(beyond_mask(fake, None), carried)
    assert beyond_mask(SimpleNamespace(measured=r.measured, extrapolation=None), res.data) is None


@pytest.mark.filterwarnings("ignore::manipdyn.PhysicalConsistencyWarning")   # the bundled PUMA's own notes
def test_montecarlo_library_call(tmp_path):
    """``report.report_html(path)`` on a study run in this process: the page names the library call
    and holds the report's own numbers."""
    pytest.importorskip("matplotlib", reason="the reports' figures need the plot extra (matplotlib)")
    from manipdyn.control import montecarlo as mc

    rep = mc.run(mc.study("puma560", runs=2, controllers=("pd",), duration=0.3), scheduler="sync")
    page = tmp_path / "lib-mc.html"
    rep.report_html(page)
    text = page.read_text(encoding="utf-8")
    _page_is_self_contained(text)
    assert "(library call)" in text
    rows = H.read_tables(text)["distribution"][1:]
    assert rows[0][2:6] == [rep.controllers["pd"]["rms_error"][k] for k in ("p50", "p90", "p99", "max")]


def test_report_without_matplotlib_says_how_to_install(monkeypatch, capsys, tmp_path):
    """No plot extra: --report is refused before any work, in one line with the install command."""
    from manipdyn.cli import outputs

    def missing():
        raise md.ModelError("--plot needs matplotlib: pip install 'manipdyn[plot]' (in a source checkout: "
                            "pip install -e '.[plot]')")

    monkeypatch.setattr(outputs, "pyplot", missing)
    assert main(["montecarlo", "puma560", "--runs", "1", "--report", str(tmp_path / "r.html")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--report" in err and "pip install -e '.[plot]'" in err
    assert not (tmp_path / "r.html").exists()


# --------------------------------------------------------------------------- identify --payload


@pytest.fixture(scope="module")
def payload_report(tmp_path_factory):
    """``manipdyn identify ur5 LOG --payload --json --report`` on a UR5 carrying a known payload
    (1 % noise), the log named hostilely; and the same held still (the inertia not excited)."""
    pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
    pytest.importorskip("matplotlib", reason="the reports' figures need the plot extra (matplotlib)")
    import contextlib
    import io

    from manipdyn.control import with_payload
    from manipdyn.identification import excitation, write_measurements_csv

    d = tmp_path_factory.mktemp("payload")
    arm = md.load("ur5")
    carried = with_payload(arm, 2.5, np.array([0.02, -0.03, 0.08]), np.diag([0.010, 0.012, 0.006]))
    ex = excitation(arm, duration=10.0, harmonics=4, rate=100.0, iterations=0, seed=1)
    tau = carried.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.01 * np.abs(tau).max(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)
    moving = d / f"pay {HOSTILE[:8]}.csv"
    write_measurements_csv(moving, ex.t, ex.q, tau, qd=ex.qd, qdd=ex.qdd)
    q = np.repeat(arm.random_state(np.random.default_rng(3), 8), 30, axis=0)
    z = np.zeros_like(q)
    still = d / "still.csv"
    write_measurements_csv(still, np.arange(len(q)) * 0.01, q, carried.inverse_dynamics(q, z, z), qd=z, qdd=z)
    out = {"dir": d}
    for kind, log in (("moving", moving), ("still", still)):
        page = d / f"{kind}.html"
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            assert main(["identify", "ur5", str(log), "--payload", "--json", "--report", str(page)]) == 0
        out[kind] = (page, page.read_text(encoding="utf-8"), json.loads(buf.getvalue()))
    return out


@pytest.mark.parametrize("kind", ["moving", "still"])
def test_payload_report_holds_the_json(payload_report, kind):
    """The payload page's tables hold --json's numbers bit for bit (null std: an empty cell), the
    parameters the data do not determine are highlighted and named in the verdict, the log is named
    with its sha256 and escaped, and the figure is there."""
    import hashlib

    page, text, d = payload_report[kind]
    _page_is_self_contained(text)
    t = H.read_tables(text)
    rows = t["payload"][1:]
    assert rows[0][0] == "mass (kg)" and _close(rows[0][1], d["mass"]) and _close(rows[0][2], d["mass_std"])
    for k in range(3):
        assert _close(rows[1 + k][1], d["com"][k]) and _close(rows[1 + k][2], d["com_std"][k])
    for row, (i, k) in zip(rows[4:], ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        assert _close(row[1], d["inertia"][i][k])
    params = t["parameters"][1:]
    assert [r[0] for r in params] == list(d["parameters"])
    for r in params:
        assert _close(r[1], d["parameters"][r[0]]) and _close(r[2], d["parameter_std"][r[0]])
    joints = t["joints"][1:]
    assert len(joints) == 6
    for j, r in enumerate(joints):
        assert _close(r[1], d["rms_residual"][j]) and _close(r[2], d["noise_sigma"][j])
    sha = hashlib.sha256(open(d["data"], "rb").read()).hexdigest()
    assert sha in text and "&lt;script&gt;" in text if kind == "moving" else sha in text
    assert len(_pngs(text)) == 1
    if kind == "still":
        assert d["poorly_determined"] and "the data do not determine" in text
        assert text.count('<tr class="flag">') >= len(d["poorly_determined"])
        assert any(r[2] is None for r in params)            # an unexcited parameter: null in JSON, empty here
    else:
        assert d["poorly_determined"] == [] and "every parameter is determined by the data" in text


def test_payload_report_renders_in_chromium(payload_report, tmp_path):
    exe = _browser()
    import matplotlib.image as mpimg

    png = tmp_path / "payload.png"
    _screenshot(exe, payload_report["moving"][0], png, 3200)
    flat = (mpimg.imread(png)[:, :, :3] * 255).round().astype(int).reshape(-1, 3)
    assert len(np.unique(flat, axis=0)) > 200 and np.mean(np.all(flat >= 250, axis=1)) < 0.97
    lines = sum(np.all(np.abs(flat - c) <= 12, axis=1).sum() for c in ([0x1F, 0x77, 0xB4], [0xFF, 0x7F, 0x0E]))
    assert lines > 300, lines


def test_payload_report_goes_through_the_output_checks(payload_report, capsys):
    """Never onto an input (the log): refused in one line before any work."""
    page, _, d = payload_report["moving"]
    assert main(["identify", "ur5", d["data"], "--payload", "--report", d["data"]]) == 2
    assert "--report" in capsys.readouterr().err
