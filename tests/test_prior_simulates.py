"""A model that simulates as well as it predicts torque (issue 44, items 1 to 3 and 6).

What the logs do not excite stays the prior's: the prior is made physical before the pull, the weight of
the pull is chosen on the hold-outs by torque AND forward-dynamics error, and the notes and the trust
record say what the data decided and what the prior kept.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
import guide
from common import LWR4_DIR, PANDA_LOG, needs_lwr4, needs_panda_log

pytest.importorskip("cvxpy", reason="the consistent fit needs the identify extra (cvxpy)")

from manipdyn.identification.estimation.model import arm_with_parameters  # noqa: E402
from manipdyn.model.inertia import parameters_from_pseudo_inertia, pseudo_inertia_from_parameters  # noqa: E402
from manipdyn.model.parameters import arm_parameters  # noqa: E402

#: the wrist's amplitude (rad) in the synthetic logs: the wrist barely moves (issue 44, item 6)
WRIST = 0.02
#: torque noise per joint (N m): a UR5's shoulder and elbow against its wrist
NOISE = (0.05, 0.05, 0.05, 0.005, 0.005, 0.005)


def _truth(seed=1, size=0.15, links=3):
    """A perturbed but physical UR5: the first ``links`` links' J congruent to the prior's (``X J X^T``, so J >= 0
    holds by construction) with their mass scaled by about +-15 %; the wrist's bodies are the prior's (where the
    logs are silent, the prior is right: the case a pull towards it is for).  With the wrist perturbed too the
    prior is wrong exactly where the data cannot tell, and no choice of weight can recover it (measured: the
    default's replay at 50 ms is then 1.31 times the truth's, the wrist's noise-driven drift dominating)."""
    prior = md.load("ur5")
    n = prior.n
    J = pseudo_inertia_from_parameters(arm_parameters(prior, False, False).reshape(n, 10))
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        X = np.eye(4)
        X[:3, :] += size * rng.normal(size=(3, 4)) * np.array([1, 1, 1, 0.1])
        out.append((1 + size * rng.normal()) * X @ J[i] @ X.T if i < links else J[i])
    pi = parameters_from_pseudo_inertia(np.array(out)).reshape(-1)
    return arm_with_parameters(prior, pi, name="ur5_truth")


def _motion(n, seed, T, rate):
    t = np.arange(int(T * rate)) / rate
    rng = np.random.default_rng(seed)
    amp = np.array([0.8, 0.6, 0.6, WRIST, WRIST, WRIST])
    q, qd, qdd = np.zeros((len(t), n)), np.zeros((len(t), n)), np.zeros((len(t), n))
    for k in range(3):
        w, ph, a = 2 * np.pi * 0.1 * (k + 1), rng.uniform(0, 2 * np.pi, n), amp / (k + 1)
        s, c = np.sin(w * t[:, None] + ph), np.cos(w * t[:, None] + ph)
        q, qd, qdd = q + a * s, qd + a * w * c, qdd - a * w * w * s
    return t, q + np.array([0, -1.2, 1.0, -1.0, 1.2, 0.3]), qd, qdd


def _log(arm, path, seed, T=20.0, rate=100.0):
    t, q, qd, qdd = _motion(arm.n, seed, T, rate)
    tau = arm.inverse_dynamics(q, qd, qdd) + np.random.default_rng(seed).normal(size=q.shape) * np.asarray(NOISE)
    n = arm.n
    hdr = ",".join(["t"] + [f"q{j + 1}" for j in range(n)] + [f"qd{j + 1}" for j in range(n)]
                   + [f"tau{j + 1}" for j in range(n)])
    np.savetxt(path, np.column_stack([t, q, qd, tau]), delimiter=",", header=hdr, comments="")
    return path


def _nonphysical_ur5(tmp_path):
    """The bundled UR5 (as a URDF) moved along a direction the torques cannot see (the null space of its base-parameter map)
    until link 3 is no rigid body: the same dynamics, an indefinite J_3 (as a published model can be)."""
    from manipdyn.identification.estimation.base import base_parameters

    path = tmp_path / "ur5.urdf"
    path.write_text(md.to_urdf(md.load("ur5")))
    prior = md.load(str(path))
    pi = arm_parameters(prior, False, False).copy()
    K = base_parameters(prior).K
    _, sv, Vt = np.linalg.svd(K)
    N = Vt[len(sv[sv > 1e-9 * sv[0]]):]                     # (p - r, p): the null space
    d = N.T @ (N @ np.eye(len(pi))[24])                     # link 3's I_xx, projected on the null space
    for scale in np.geomspace(1e-3, 1e3, 61):
        bad = pi + scale * d / np.abs(d).max()
        if np.linalg.eigvalsh(pseudo_inertia_from_parameters(bad[20:30]))[0] < 0:
            break
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return arm_with_parameters(prior, bad, name="ur5_bad")


def test_a_prior_that_is_no_rigid_body_is_completed_with_the_same_dynamics(tmp_path):
    from manipdyn.identification.estimation.prior import physical_prior

    bad = _nonphysical_ur5(tmp_path)
    assert np.linalg.eigvalsh(bad.chain()[0][2].body.J)[0] < 0
    good, notes = physical_prior(bad, "the prior ur5_bad")
    import re

    m = re.search(r": links? ([\d, ]+) no rigid body", notes[0]) if len(notes) == 1 else None
    assert m and 3 in [int(x) for x in m.group(1).split(",")], notes
    for j in good.chain()[0]:
        assert np.linalg.eigvalsh(j.body.J)[0] > 0
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-2, 2, (50, 6)) for _ in range(3))
    t0, t1 = bad.inverse_dynamics(q, qd, qdd), good.inverse_dynamics(q, qd, qdd)
    # the completion keeps the base parameters exactly (to the null space's rounding, 1e-14 relative)
    assert np.max(np.abs(t1 - t0)) <= 1e-9 * np.max(np.abs(t0))
    same, none = physical_prior(md.load("ur5"))
    assert none == [] and same.name == "ur5"


def test_the_weight_is_chosen_by_torque_and_forward_dynamics():
    """Every candidate is scored on the same held-out samples by torque and by acceleration error, and the fold
    score is their sum (torque alone could not see a wrist's inertia; a replay alone rewards damping)."""
    from manipdyn.identification.estimation.selection import choose_prior_weight

    truth = md.load("ur5")
    t, q, qd, qdd = _motion(6, 0, 8.0, 50.0)
    tau = truth.inverse_dynamics(q, qd, qdd) + np.random.default_rng(0).normal(size=q.shape) * np.asarray(NOISE)
    w, table = choose_prior_weight(truth, q, qd, qdd, tau, weights=(0.0, 0.1), folds=2, dt=t[1] - t[0])
    for row in table:
        assert set(row) >= {"torque_score", "accel_score", "accel_rms", "rms"}
        assert row["score"] == pytest.approx(row["torque_score"] + row["accel_score"])
        assert len(row["accel_rms"]) == 6 and all(x > 0 for x in row["accel_rms"])


def test_a_candidate_that_buys_forward_dynamics_with_torque_is_passed_over():
    """The LWR4's weight-1 fit replayed better than the data alone by damping everything, with 292 N m of torque
    error: a candidate over TORQUE_SLACK worse on any joint's held-out torque is excluded, however good its
    acceleration score; one within it that wins by more than the folds' spread is chosen."""
    from manipdyn.identification.estimation.selection import TORQUE_SLACK, exclude_worse_torque, one_se_choice

    def row(w, rms, folds):
        return {"prior_weight": w, "rms": rms, "fold_scores": folds, "score": float(np.mean(folds))}

    table = [row(0.0, [1.0, 1.0], [0.0, 0.1, 0.0]),
             row(1.0, [1.0, 1.0 + 3 * TORQUE_SLACK], [-3.0, -2.9, -3.1]),      # far better score, one joint worse
             row(3.0, [1.0 + 1.5 * TORQUE_SLACK, 1.0 + 1.5 * TORQUE_SLACK], [-3.0, -2.9, -3.1]),   # worse on average
             row(0.1, [1.0 + 1.5 * TORQUE_SLACK, 1.0], [-0.5, -0.4, -0.6])]   # within both: may win
    exclude_worse_torque(table, "prior_weight", 0.0)
    assert "joint 2" in table[1]["excluded"] and "on average" in table[2]["excluded"] and "excluded" not in table[3]
    best, why = one_se_choice(table, "prior_weight", 0.0)
    assert best["prior_weight"] == 0.1, why


def _guide_row(page: str, caption: str, label: str) -> np.ndarray:
    """The row ``label`` of the table whose first header cell starts with ``caption`` on a guide page."""
    lines = guide.page(page).splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith("| " + caption))
    row = next(line for line in lines[start:] if line.startswith(f"| {label} |"))
    return np.array([float(c.strip(" *")) for c in row.split("|")[2:-1]])


@needs_panda_log
def test_panda_default_simulates_better_than_the_published_model(tmp_path):
    """Issue 44's Panda case from the README's command: fit on 0 to 10 s, replay on 10 to 21 s.  The former default
    (the data alone) drifted 1.02e-2 rad pooled at 50 ms against the published model's 6.49e-3, losing the wrist.
    The simulator page's row is this replay (3 significant digits, as printed there)."""
    from manipdyn.identification import identify

    out = tmp_path / "panda_id.toml"
    identify("panda", [str(PANDA_LOG)], t_range=(0, 10), friction_terms="viscous,coulomb,offset", output=str(out))
    rp = md.replay([str(out), "panda"], str(PANDA_LOG), t_range=(10, 21))
    ident, pub = rp.q_rms[rp.labels[0]], rp.q_rms[rp.labels[1]]
    assert np.all(ident <= pub), (ident, pub)              # every joint, every horizon (10, 50, 200 ms)
    k = list(rp.horizons).index(0.05)
    assert rp.pooled(rp.labels[0])[k] <= 4e-3              # the target at 50 ms, pooled
    said = _guide_row("simulator", "Panda, 10 to 21 s", "`panda_id`")
    np.testing.assert_allclose(said, np.r_[ident[k], rp.pooled(rp.labels[0])[k]], rtol=5e-3,
                               err_msg="simulator.md's panda_id row against replay")


@needs_lwr4
def test_lwr4_default_simulates_better_than_the_published_model(tmp_path):
    """The LWR4+ fit on runs 1 and 2, replayed on run 3: every joint at or below the vendor URDF at 50 ms (the
    issue's 0.05 rad on joint 7 is not met: see simulator.md), and the simulator page's row is this replay."""
    from manipdyn.identification import identify

    urdf = LWR4_DIR / "kuka_lwr4_gaz.urdf"
    out = tmp_path / "lwr4_id.toml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = identify(str(urdf), [str(LWR4_DIR / "run1.csv"), str(LWR4_DIR / "run2.csv")],
                     friction_terms="viscous,coulomb,offset", output=str(out))
        rp = md.replay([str(out), str(urdf)], str(LWR4_DIR / "run3.csv"))
    assert any("the pull towards the prior starts from the nearest solid bodies" in x
               for x in r.report_dict["fit_notes"])
    k = list(rp.horizons).index(0.05)
    ident, pub = rp.q_rms[rp.labels[0]][k], rp.q_rms[rp.labels[1]][k]
    assert np.all(ident <= pub), (ident, pub)
    said = _guide_row("simulator", "LWR4+, run 3", "`lwr4_id`")
    np.testing.assert_allclose(said, np.r_[ident, rp.pooled(rp.labels[0])[k]], rtol=5e-3,
                               err_msg="simulator.md's lwr4_id row against replay")


def test_drive_terms_the_prior_does_not_state_are_not_pulled():
    from manipdyn.identification.estimation.prior import extra_scales

    names = [f"link{i}.m" for i in range(10)] + ["joint1.fv", "joint1.fc", "joint1.offset"]
    qd, qdd, tau = np.full((4, 1), 2.0), np.full((4, 1), 4.0), np.full((4, 1), 8.0)
    s = extra_scales(names, 1, qd, qdd, tau, prior_extra=[0.5, 0.0, 20.0])
    assert s[0] == pytest.approx(4.0) and np.isinf(s[1]) and s[2] == pytest.approx(20.0)


@pytest.fixture(scope="module")
def wrist_fit(tmp_path_factory):
    from manipdyn.identification import identify

    d = tmp_path_factory.mktemp("wrist")
    truth = _truth()
    fit_log, test_log = _log(truth, d / "fit.csv", 0), _log(truth, d / "test.csv", 1, T=10.0)
    auto = identify("ur5", [str(fit_log)], output=str(d / "auto.toml"))
    zero = identify("ur5", [str(fit_log)], prior_weight=0, output=str(d / "zero.toml"))
    return truth, auto, zero, d, test_log


def test_the_default_keeps_the_prior_where_the_logs_do_not_excite_and_says_so(wrist_fit):
    truth, auto, zero, d, _ = wrist_fit
    assert auto.provenance["options"]["prior_weight"] > 0          # the default is chosen, not 0
    notes = " ".join(auto.report_dict["fit_notes"])
    assert "chosen by" in notes and "acceleration" in notes
    assert "the logs do not excite these base parameters, so the prior decides them" in notes
    decided = auto.report_dict["decided"]
    prior_kept = [x for x in decided["base"] if x["by"] == "prior"]
    assert prior_kept and any("link6" in x["what"] for x in prior_kept)
    # the trust record carries it, so the model file says it too
    text = (d / "auto.toml").read_text()
    assert "decided" in text
    # the wrist's inertia as a simulation divides by it, the mass matrix's diagonal on joints 4 to 6, at the logs'
    # middle posture: the default keeps it within 5 % of the prior's (the target), the data alone do not
    prior = md.load("ur5")
    q = np.array([0, -1.2, 1.0, -1.0, 1.2, 0.3])
    m_prior = np.diag(prior.mass_matrix(q))[3:]
    m_auto = np.diag(md.load(str(d / "auto.toml")).mass_matrix(q))[3:]
    m_zero = np.diag(md.load(str(d / "zero.toml")).mass_matrix(q))[3:]
    assert np.all(np.abs(m_auto / m_prior - 1) <= 0.05), m_auto / m_prior
    assert np.any(np.abs(m_zero / m_prior - 1) > 0.05), m_zero / m_prior


def test_the_acceleration_score_averages_the_torque_error_over_the_horizon():
    """White torque noise integrates to nothing in position over 50 ms, but M^-1 of it grows as M shrinks: scored
    sample by sample it rewards a heavier model.  The held-out error is averaged over ACCEL_HORIZON within each
    contiguous stretch of held-out samples first."""
    from manipdyn.identification.estimation.selection import ACCEL_HORIZON, horizon_mean

    rng = np.random.default_rng(0)
    test = np.zeros(400, dtype=bool)
    test[50:150] = test[300:400] = True           # two stretches: no window reaches across the gap
    err = rng.normal(size=(200, 2))
    err[:100] += 1.0                              # a bias in the first stretch only
    out = horizon_mean(err, test, dt=ACCEL_HORIZON / 10)
    assert np.std(out[:100] - 1.0) < 0.5 * np.std(err[:100] - 1.0)      # the noise shrinks (by about sqrt(10))
    assert abs(np.mean(out[:100]) - 1.0) < 0.2 and abs(np.mean(out[100:])) < 0.2   # the bias stays, unshared
    assert np.array_equal(horizon_mean(err, test, None), err)


def test_the_default_simulates_near_the_truth(wrist_fit):
    """Replay at 50 ms on a log the fit never saw: the default within 1.2 x the true model's pooled error (the
    issue's target), and on the joints the logs excite, and on joint 5, near the truth where the data alone drift
    (measured: the data alone 9.5 times the truth's error on joint 5, the default 1.03 times)."""
    truth, auto, zero, d, test_log = wrist_fit
    rp = md.replay([str(d / "auto.toml"), str(d / "zero.toml"), truth], str(test_log))
    k = list(rp.horizons).index(0.05)
    auto_e, zero_e, true_e = (rp.pooled(lab)[k] for lab in rp.labels)
    assert auto_e <= 1.2 * true_e, (auto_e, zero_e, true_e)
    a, z, t = (rp.q_rms[lab][k] for lab in rp.labels)
    assert a[4] <= 1.2 * t[4] < z[4], (a, z, t)

