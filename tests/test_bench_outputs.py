"""Benchmarks don't modify tracked files (issue 13, finding 8): where runs go, --publish,
--check-targets, the BLAS configuration in the results, and ``manipdyn bench``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import run  # noqa: E402  (the repository root is on sys.path above)

from manipdyn.cli import bench as bench_cmd  # noqa: E402
from manipdyn.cli import main  # noqa: E402

REFERENCE = [ROOT / "benchmarks" / "results" / name for name in run.REFERENCE]
QUICK = ["--smoke", "--no-rtb", "--no-plot", "--skip", "batch", "scaling"]


def _stamp(paths):
    return {p: p.stat().st_mtime_ns for p in paths}


def test_a_run_goes_to_its_own_ignored_folder(tmp_path, monkeypatch):
    monkeypatch.setattr(run, "RUNS", str(tmp_path / "runs"))
    before = _stamp(REFERENCE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert run.main(QUICK) == 0
    (folder,) = (tmp_path / "runs").iterdir()
    assert folder.name.endswith("-smoke") and (folder / "results.json").is_file()
    assert _stamp(REFERENCE) == before                    # the published results untouched
    ignored = subprocess.run(["git", "check-ignore", "-q", "benchmarks/results/runs/x/results.json"],
                             cwd=ROOT, check=False).returncode
    assert ignored == 0, "benchmarks/results/runs/ must be ignored by git"
    # the BLAS configuration the run had, from threadpoolctl, without file paths
    machine = json.loads((folder / "results.json").read_text())["machine"]
    pools = machine["blas_config"]
    assert isinstance(pools, list) and any(p.get("user_api") == "blas" for p in pools)
    assert not any("filepath" in p for p in pools)
    assert "OPENBLAS_CORETYPE" in machine and "OPENBLAS_L2_SIZE" in machine


def test_publish_needs_a_full_run(capsys):
    assert run.main(["--smoke", "--publish"]) == 2
    assert "--publish needs a full run" in capsys.readouterr().err


def test_exit_status_of_targets():
    ok, wrong = {"passed": True}, {"passed": False}
    missed = [{"id": "T1", "status": "MISS"}, {"id": "T2", "status": "pass"}]
    met = [{"id": "T1", "status": "pass"}, {"id": "T3", "status": "skipped"}]
    assert run.exit_status(ok, missed, check_targets=False) == 0     # reported, not an error
    assert run.exit_status(ok, missed, check_targets=True) == 1
    assert run.exit_status(ok, met, check_targets=True) == 0
    assert run.exit_status(wrong, met, check_targets=True) == 2


def test_manipdyn_bench_without_a_checkout_says_so(monkeypatch, capsys):
    monkeypatch.setattr(bench_cmd, "suite_root", lambda: None)
    assert main(["bench", "--smoke"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not installed with manipdyn" in err[0] and "pip install -e '.[bench]'" in err[0]


def test_manipdyn_bench_runs_the_suite_with_the_blas_variables_unset(tmp_path):
    env = dict(os.environ, OPENBLAS_CORETYPE="Haswell", OPENBLAS_L2_SIZE="262144")
    r = subprocess.run([sys.executable, "-m", "manipdyn", "bench", *QUICK, "--out", str(tmp_path)],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    machine = json.loads((tmp_path / "results.json").read_text())["machine"]
    assert machine["OPENBLAS_CORETYPE"] is None and machine["OPENBLAS_L2_SIZE"] is None
    r = subprocess.run([sys.executable, "-m", "manipdyn", "bench", *QUICK, "--out", str(tmp_path),
                        "--keep-blas-env"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert json.loads((tmp_path / "results.json").read_text())["machine"]["OPENBLAS_CORETYPE"] == "Haswell"


def test_seeded_benchmarks_say_which_seed_runs(capsys):
    """bench_hardlog and bench_torque_constants run tens of seconds a seed: the shared loop says on
    stderr which seed runs and how long it took (issue 31 item 15), and ``--quiet`` says nothing."""
    from benchmarks.timing import seeded_runs

    args, runs = seeded_runs("bench", "doc", "demo", lambda seed, folder: {"seed": seed}, ["--seeds", "4", "7"])
    err = capsys.readouterr().err
    assert runs == [{"seed": 4}, {"seed": 7}]
    assert "demo: seed 4 (1/2) ..." in err and "demo: seed 7 (2/2) ..." in err
    assert err.count("done in") == 2
    seeded_runs("bench", "doc", "demo", lambda seed, folder: {}, ["--seeds", "1", "--quiet"])
    assert capsys.readouterr().err == ""
