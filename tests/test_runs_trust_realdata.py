"""Issue 37 on the real KUKA LWR4+ (../shared/realdata/lwr4_flobaroid): runs are the unit of trust.

The vendor route with the README's recommended command and no hand-set option:
``manipdyn identify kuka_lwr4_gaz.urdf RUNS... --friction-terms viscous,coulomb,offset -o M.toml``,
then ``manipdyn validate M.toml runK.csv --predictions P.csv --json``.  Runs 1 and 2 repeat one
trajectory, run 3 is another.  Three cases, each fitted once (module fixtures):

* fit on runs 2 and 3 (two trajectories), validate on run 1: the band from held-out runs;
* fit on run 3 (one trajectory), validate on run 1: the band within one trajectory, and the flags;
* fit on runs 1 and 2 (one trajectory, repeated), validate on run 3.
"""

from __future__ import annotations

import contextlib
import io
import json
import re

import numpy as np
import pytest

from common import LWR4_DIR, needs_lwr4

pytestmark = needs_lwr4
pytest.importorskip("cvxpy", reason="identification needs the identify extra")


def _cli(*args):
    from manipdyn.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main([str(a) for a in args])
    return code, buf.getvalue()


def _identify(out, *runs):
    code, text = _cli("identify", LWR4_DIR / "kuka_lwr4_gaz.urdf", *(LWR4_DIR / r for r in runs),
                      "--friction-terms", "viscous,coulomb,offset", "-o", out, "--json", "--no-progress")
    assert code == 0
    return json.loads(text)


def _validate(model, run, pred):
    code, text = _cli("validate", model, LWR4_DIR / run, "--predictions", pred, "--json")
    assert code == 0
    out = json.loads(text)
    table = np.genfromtxt(pred, delimiter=",", names=True)
    n = 7
    inside = np.stack([(table[f"lo{j}"] <= table[f"tau{j}"]) & (table[f"tau{j}"] <= table[f"hi{j}"])
                       for j in range(1, n + 1)], axis=1)
    flags = np.stack([table[f"x{j}"] == 1.0 for j in range(1, n + 1)], axis=1)
    return out, inside, flags


def _published_rms(run):
    """RMS per joint of the two published models on ``run``: Gaz's (its rigid part, as ``validate`` loads it) and
    FloBaRoID's with its viscous and Coulomb friction (its <dynamics> tags; one of its Coulomb coefficients is
    negative, which a URDF may not hold, so the tags are applied here to the rigid part)."""
    import manipdyn as md
    from manipdyn.identification import read_log
    from manipdyn.formats.urdf.reader import load_urdf

    data = read_log(str(LWR4_DIR / run), 7)
    out = {}
    gaz = md.load(str(LWR4_DIR / "kuka_lwr4_gaz.urdf"))
    out["gaz"] = np.sqrt(np.mean((data.tau - gaz.inverse_dynamics(data.q, data.qd, data.qdd)) ** 2, axis=0))
    text = (LWR4_DIR / "kuka_lwr4_identified.urdf").read_text()
    tags = [(float(a), float(b)) for a, b in re.findall(r'<dynamics damping="([^"]+)" friction="([^"]+)"', text)]
    assert len(tags) == 7
    rigid = load_urdf(re.sub(r"<dynamics[^>]*/>", "", text))
    damping, coulomb = (np.array(x) for x in zip(*tags))
    pred = rigid.inverse_dynamics(data.q, data.qd, data.qdd) + damping * data.qd + coulomb * np.sign(data.qd)
    out["flobaroid"] = np.sqrt(np.mean((data.tau - pred) ** 2, axis=0))
    return out


@pytest.fixture(scope="module")
def two_trajectories(tmp_path_factory):
    d = tmp_path_factory.mktemp("lwr4_23")
    rep = _identify(d / "m.toml", "run2.csv", "run3.csv")
    return rep, _validate(d / "m.toml", "run1.csv", d / "p.csv")


@pytest.fixture(scope="module")
def repeated_trajectory(tmp_path_factory):
    d = tmp_path_factory.mktemp("lwr4_12")
    rep = _identify(d / "m.toml", "run1.csv", "run2.csv")
    return rep, _validate(d / "m.toml", "run3.csv", d / "p.csv")


@pytest.fixture(scope="module")
def one_trajectory(tmp_path_factory):
    d = tmp_path_factory.mktemp("lwr4_3")
    rep = _identify(d / "m.toml", "run3.csv")
    return rep, _validate(d / "m.toml", "run1.csv", d / "p.csv")


def test_two_trajectories_give_a_band_that_holds_on_the_next_run(two_trajectories):
    """The issue's first target.  Measured: RMS 0.392 0.243 0.287 0.252 0.268 0.194 0.228 N m (Gaz 1.32 4.11
    1.49 2.62 0.94 0.78 0.27; FloBaRoID 0.925 0.368 0.449 0.695 1.53 1.54 0.396); the band holds 100 100 91.3
    98.1 93.7 100 94.0 %, 96.7 % pooled (86.0 % from blocks in time before); no sample flagged."""
    rep, (out, inside, flags) = two_trajectories
    band = rep["provenance"]["prediction_band"]
    assert band["method"] == "held-out trajectories" and band["trajectories"] == 2
    assert any(x.startswith("runs: 2 distinct trajectories among 2 runs") for x in rep["fit_notes"])
    published = _published_rms("run1.csv")
    rms = np.array(out["rms"])
    assert np.all(rms <= published["gaz"]) and np.all(rms <= published["flobaroid"]), (rms, published)
    # the targets: 90-98 % pooled, 85 % on every joint, at most 10 % flagged on any joint
    assert 0.90 <= out["band_95_pooled"] <= 0.98, out["band_95_coverage"]
    assert min(out["band_95_coverage"]) >= 0.85, out["band_95_coverage"]
    assert max(out["flagged_fraction"]) <= 0.10, out["flagged_fraction"]
    np.testing.assert_allclose(np.mean(inside, axis=0), out["band_95_coverage"], atol=1e-12)
    np.testing.assert_allclose(np.mean(flags, axis=0), out["flagged_fraction"], atol=1e-12)


def test_one_trajectory_says_so_and_its_band_holds_on_the_other(one_trajectory):
    """Fit on run 3 alone, validate on run 1.  Before: a band from blocks in time held 75 % pooled (joint 1
    34 %).  Now the band of one trajectory holds out its posture regions too (bands.py), and it holds
    96.5 % pooled (89.4 99.6 99.9 99.1 91.1 96.3 100 % per joint): the issue's first alternative (90-98 %
    pooled).  The flags cover 9.7 % of the samples, 2.75 times the misses (target: at most 3x).  Not met,
    and said in the closing note: flagged samples miss 1.0 %, unflagged 3.8 % (target: flagged at least
    twice as often): the region hold-outs widened the band exactly where the flags point (q2 and q4
    beyond run 3's range), and the misses left are joint 1's and joint 5's, whose states run 3 covered
    (joint 1's friction at the same speed differs between the two trajectories by about 0.4 N m; a fit of
    its viscous, Coulomb and offset terms alone on run 1 cuts joint 1's RMS from 0.48 to 0.27 N m).
    With the band's speed class (uncertainty/conformal.py) it holds 97.6 % pooled (90.9 100 100 99.3 96.3 96.3
    100 % per joint; joint 5 from 91.8): the flags, 10.1 % of the samples, are 4.1 times the misses (2.45 %),
    which the issue's rule allows, as it asks the flags to warn only on a joint whose band holds under 85 %."""
    rep, (out, inside, flags) = one_trajectory
    band = rep["provenance"]["prediction_band"]
    assert band["trajectories"] == 1 and band["regions"] == 4
    assert any("within one trajectory" in x for x in out["model_notes"])
    assert 0.90 <= out["band_95_pooled"] <= 0.98, out["band_95_coverage"]
    for j in range(7):       # the rule, on every joint under 85 % (none today)
        if np.mean(inside[:, j]) < 0.85:
            f, i = flags[:, j], inside[:, j]
            assert np.mean(i[~f]) >= 0.85 and 1 - np.mean(i[f]) >= 2 * (1 - np.mean(i[~f])), j + 1
            assert np.sum(f) <= 3 * np.sum(~i), (j + 1, np.mean(f), np.mean(~i))
    for j in range(7):       # the json's split is the CSV's
        if flags[:, j].any():
            assert out["band_95_coverage_flagged"][j] == pytest.approx(float(np.mean(inside[flags[:, j], j])))
        assert out["band_95_coverage_unflagged"][j] == pytest.approx(float(np.mean(inside[~flags[:, j], j])))


def test_one_repeated_trajectory_gives_a_band_that_holds_on_another(repeated_trajectory):
    """Fit on runs 1 and 2 (one trajectory, repeated), validate on run 3 (another, about twice as fast).
    Before: 83.1 % pooled from blocks in time.  Now, with the posture regions held out: 92.5 % pooled (75.0
    87.2 100 89.4 99.0 97.1 100 % per joint), the issue's first alternative (90-98 %).  Not met, and said in
    the closing note: the flags cover 60 % of the samples (run 3's speeds are beyond runs 1 and 2's on every
    joint; the issue's own rule flags a joint's states beyond its range), 7.8 times the misses, and flagged
    samples miss about as often as unflagged ones (7.8 and 7.1 %)."""
    rep, (out, inside, flags) = repeated_trajectory
    band = rep["provenance"]["prediction_band"]
    assert band["trajectories"] == 1 and band["regions"] == 4
    assert any("held out together as repeats of one trajectory" in x for x in rep["fit_notes"])
    assert 0.90 <= out["band_95_pooled"] <= 0.98, out["band_95_coverage"]
    np.testing.assert_allclose(np.mean(inside, axis=0), out["band_95_coverage"], atol=1e-12)


def test_the_guides_published_rows_are_the_published_models_scores():
    """trust.md's recipe scores FloBaRoID's model as published (its rigid part plus its tags' viscous and
    Coulomb torques, which manipdyn does not load: four Coulomb coefficients are negative) and Gaz's; its
    printed rows are these scores, to the three decimals it prints."""
    import guide

    rows = {name: [float(x) for x in re.search(name + r" +RMS per joint \(N m\): \[([^\]]+)\]",
                                               guide.page("trust")).group(1).split()]
            for name in ("Gaz", "FloBaRoID")}
    published = _published_rms("run1.csv")
    np.testing.assert_allclose(rows["Gaz"], published["gaz"], atol=5e-4 + 1e-9)
    np.testing.assert_allclose(rows["FloBaRoID"], published["flobaroid"], atol=5e-4 + 1e-9)
