"""Issue 38 item 11: the real-data logs are found from a clone anywhere, through ``$MANIPDYN_REALDATA``.

``LOG=../shared/realdata/...`` worked only from the original folder layout.  Now one rule
(``benchmarks/realdata.py``) says where the folder is: ``$MANIPDYN_REALDATA`` when set, else
``../shared/realdata`` beside the project; every test, benchmark and guide page goes through it.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

PROBE = """
import json, sys
import common, benchmarks.bench_panda as bp, benchmarks.bench_bands as bb
print(json.dumps({"log": str(common.PANDA_LOG), "skip": common.PANDA_SKIP, "bench_panda": str(bp.DATA),
                  "bench_bands": str(bb.DATA), "found": common.PANDA_LOG.is_file()}))
"""


def _probe(env_value, cwd=ROOT):
    env = {k: v for k, v in os.environ.items() if k != "MANIPDYN_REALDATA"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), str(ROOT / "tests")])
    if env_value is not None:
        env["MANIPDYN_REALDATA"] = env_value
    proc = subprocess.run([sys.executable, "-c", PROBE], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_the_variable_points_the_tests_and_benchmarks_at_a_folder_elsewhere(tmp_path):
    elsewhere = tmp_path / "data" / "realdata"
    (elsewhere / "panda_gaz2019").mkdir(parents=True)
    (elsewhere / "panda_gaz2019" / "panda_as_logged.csv").write_text("t\n")     # a stand-in: only found, not read
    got = _probe(str(elsewhere))
    want = str(elsewhere / "panda_gaz2019" / "panda_as_logged.csv")
    assert got["log"] == got["bench_panda"] == got["bench_bands"] == want
    assert got["found"] is True
    # a relative value is read from the current folder, as a shell user means it
    rel = _probe("data/realdata", cwd=tmp_path)
    assert rel["log"] == want


def test_an_empty_folder_skips_naming_the_variable(tmp_path):
    got = _probe(str(tmp_path))
    assert got["found"] is False
    assert "MANIPDYN_REALDATA" in got["skip"] and str(tmp_path) in got["skip"]


def test_unset_means_beside_the_project():
    got = _probe(None)
    assert got["log"] == str(ROOT.parent / "shared" / "realdata" / "panda_gaz2019" / "panda_as_logged.csv")
    assert _probe("")["log"] == got["log"]           # an empty value is unset


def test_no_test_or_benchmark_spells_the_folder_layout_itself():
    """Every path to the real data goes through benchmarks/realdata.py (a second spelling of
    ``"shared" / "realdata"`` would ignore the variable again)."""
    spelled = re.compile(r"""["']shared["']\s*/\s*["']realdata["']|["']\.\./shared/realdata""")
    found = []
    for folder in ("tests", "benchmarks"):
        for path in (ROOT / folder).rglob("*.py"):
            if path.name == "realdata.py" or path == Path(__file__).resolve():
                continue
            if spelled.search(path.read_text(encoding="utf-8")):
                found.append(str(path.relative_to(ROOT)))
    assert found == []


def test_the_guide_reads_the_log_through_the_variable():
    """Each shell block that reads the real log takes the folder from $MANIPDYN_REALDATA, with
    ../shared/realdata as the fallback; and the README says so."""
    pages = [ROOT / "README.md", *sorted((ROOT / "docs" / "guide").glob("*.md"))]
    blocks = [b for p in pages for b in re.findall(r"^```sh\n(.*?)^```", p.read_text(encoding="utf-8"), flags=re.S | re.M)]
    real = [b for b in blocks if "panda_as_logged.csv" in b]
    assert real, "the guide's real-log blocks"
    for b in real:
        assert "LOG=${MANIPDYN_REALDATA:-../shared/realdata}/panda_gaz2019/panda_as_logged.csv" in b or "$LOG" in b, b
    # the KUKA LWR4+ runs (trust.md), the same way: no placeholder path a reader must edit (issue 46 item 8)
    lwr = [b for b in blocks if "$LWR" in b]
    assert lwr, "the guide's LWR4+ blocks"
    for b in lwr:
        assert "LWR=${MANIPDYN_REALDATA:-../shared/realdata}/lwr4_flobaroid\n" in b, b
    assert "MANIPDYN_REALDATA" in (ROOT / "README.md").read_text(encoding="utf-8")
