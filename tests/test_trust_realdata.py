"""Issue 30 on the real Franka Panda log (../shared/realdata/panda_gaz2019), from the vendor's URDF.

The README's run "From a vendor URDF": ``identify erd:panda LOG --tip panda_hand -o erd_id.toml
--t-range 0:10 --friction-terms viscous,coulomb,offset`` (the recommended command: no hand-set
smoothing or cut-off), validated on 10-21 s and 10-13.8 s.  Items 1 (the record survives the
URDF route), 2 (the band's targets on another stretch of the real arm), 3 (the smoothing chosen
by the hold-outs, its candidates in the report), 4 (against the published model) and 6 (the
README's figures are this run's)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

import guide  # noqa: E402  the README and the guide's pages (issue 38 item 15)
from common import PANDA_LOG as DATA, needs_panda_log

pytestmark = needs_panda_log
pytest.importorskip("cvxpy", reason="identification needs the identify extra")


@pytest.fixture(scope="module")
def erd_model(tmp_path_factory):
    import contextlib
    import io

    from manipdyn.cli import main

    out = tmp_path_factory.mktemp("erd") / "erd_id.toml"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["identify", "erd:panda", str(DATA), "--tip", "panda_hand", "-o", str(out), "--t-range", "0:10",
                     "--friction-terms", "viscous,coulomb,offset", "--json"]) == 0
    return out, json.loads(buf.getvalue())


def _validate(capsys, *args):
    from manipdyn.cli import main

    capsys.readouterr()
    assert main(["validate", *map(str, args), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_the_vendor_urdf_model_keeps_its_band_and_flags(erd_model, capsys):
    model, rep = erd_model
    text = model.read_text()
    assert "urdf = '''" in text and "\n[trust]\n" in text and "\n[trust.prediction_band]\n" in text
    for window, row in (("10:21", "| 10 s <= t < 21 s |"), ("10:13.8", "| 10 s <= t < 13.8 s |")):
        out = _validate(capsys, model, DATA, "--t-range", window)
        cov = out["band_95_coverage"]
        assert 0.90 <= out["band_95_pooled"] <= 0.98, cov          # the target, pooled
        missed = [j + 1 for j, c in enumerate(cov) if c < 0.80]
        assert missed == out["band_95_missed"]                     # under 80 %: flagged, by name
        assert any(e["extrapolates"] for e in out["extrapolation"])
        # the README's row is this run, to its digits
        line = next(x for x in guide.TEXT.splitlines() if x.startswith(row))
        printed = [float(x) for x in re.findall(r"([0-9.]+) %", line.split("|", 2)[2])]
        # to 0.15 %: the conic solver's last digits move a sample or two across the band between runs
        measured = [100 * c for c in cov] + [100 * out["band_95_pooled"]]
        assert max(abs(a - b) for a, b in zip(printed, measured)) <= 0.15, (row, printed, measured)


def test_the_smoothing_is_chosen_by_the_hold_outs(erd_model):
    _, rep = erd_model
    table = rep["smoothing_selection"]
    assert len(table) == 5 and all(row["score"] is not None for row in table)
    best = min(table, key=lambda row: row["score"])
    assert rep["provenance"]["options"]["smoothing"] == best["smoothing"]
    assert any(note.startswith("Coulomb smoothing tanh(v / ") and "chosen by 5-fold blocked hold-outs" in note
               for note in rep["fit_notes"])
    assert f"{best['smoothing']:.3g} rad/s" in guide.TEXT


def test_the_default_command_against_the_published_model(erd_model, capsys):
    """Item 4, measured honestly: on 10-21 s the fit beats the published model (bundled ``panda``: Gaz et al.'s
    parameters and friction) on every joint; on 10-13.8 s on every joint but 2, whose q2 the fit never saw
    (0.465 against 0.426 N m, README)."""
    model, _ = erd_model
    for window, losers in (("10:21", []), ("10:13.8", [2])):
        out = _validate(capsys, model, "panda", DATA, "--t-range", window)
        assert [b["joint"] for b in out["best"] if b["index"] != 0] == losers, out["best"]
