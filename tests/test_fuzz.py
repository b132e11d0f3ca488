"""The fuzz suite's CI run: a few hundred seeded mutations of the bundled
URDFs and model files, each meeting the contract (see ``tests/fuzz.py``;
the long run is ``python -m tests.fuzz --cases 5000 --model-cases 2000``).

Runs in worker processes with a 5 s timeout per case; takes about 10 s on
two cores.  A failure lists the case (``python -m tests.fuzz --show KIND:I``
prints its file).
"""

from __future__ import annotations


from tests import fuzz


def test_generators_are_deterministic_and_varied():
    a = [fuzz.make_urdf_case(7, i) for i in range(30)]
    assert a == [fuzz.make_urdf_case(7, i) for i in range(30)]
    assert len({d for d, _, _ in a}) == 30
    b = [fuzz.make_model_case(7, i) for i in range(30)]
    assert b == [fuzz.make_model_case(7, i) for i in range(30)]
    assert len({d for d, _, _ in b}) >= 25


def test_a_few_hundred_mutated_files_meet_the_contract():
    res = fuzz.fuzz(400, 200, seed=11, jobs=2, timeout=5.0)
    assert res["cases"] == 600
    failures = "\n".join(f"{k}:{i} {o}: {d[:300]}" for k, i, o, d in res["failures"])
    assert not res["failures"], failures
    # the suite exercises both sides of the contract: refusals and accepted arms
    for kind in ("urdf", "model"):
        c = res["counts"][kind]
        assert c["refused at load"] > 0 and c["agree"] > 0, c


def test_a_crash_and_a_hang_are_reported(monkeypatch):
    """The harness itself: a worker that dies or hangs is a failure, not a pass."""
    import os
    import time

    real = fuzz.run_case

    def bad(kind, seed, index, folder):
        if index == 1:
            os._exit(7)
        if index == 2:
            time.sleep(60)
        return real(kind, seed, index, folder)

    monkeypatch.setattr(fuzz, "run_case", bad)
    res = fuzz.fuzz(4, 0, seed=0, jobs=2, timeout=2.0)
    outcomes = {i: o for _, i, o, _ in res["failures"]}
    assert outcomes.get(1, "").startswith("CRASH (worker exit code 7)")
    assert outcomes.get(2, "").startswith("HANG")
    assert res["cases"] == 4


def test_cli_option_sets_meet_the_contract():
    """Issue 20: excite's and montecarlo's option sets, hostile values included, end in exit 0
    with a checked result or exit 2 naming the option; never exit 3, a hang or a crash
    (tests/fuzz_cli.py; the long run is ``python -m tests.fuzz_cli --cases 2000``)."""
    from tests import fuzz_cli

    a = [fuzz_cli.make_cli_case("montecarlo", 7, i) for i in range(30)]
    assert a == [fuzz_cli.make_cli_case("montecarlo", 7, i) for i in range(30)] and len({tuple(x) for x in a}) >= 25
    res = fuzz_cli.fuzz_cli(150, 150, seed=11, jobs=2, timeout=20.0)
    assert res["cases"] == 300
    failures = "\n".join(f"{k}:{i} {o}: {d[:300]}" for k, i, o, d in res["failures"])
    assert not res["failures"], failures
    for kind in ("excite", "montecarlo"):
        c = res["counts"][kind]
        assert c["refused (exit 2, the option named)"] > 0 and c["ran (exit 0, output checked)"] > 0, c


def test_runs_codegen_and_cache_surfaces_meet_the_contract():
    """A few seeded cases of each new surface (tests/fuzz_surfaces.py; the long run is
    ``python -m tests.fuzz_surfaces --cases 100``): RUNS.toml, codegen, the compiled-engine cache."""
    import pytest

    pytest.importorskip("casadi")
    pytest.importorskip("cvxpy")
    from tests import fuzz_surfaces

    assert [fuzz_surfaces.make_case("cache", 3, i) for i in range(20)] == \
        [fuzz_surfaces.make_case("cache", 3, i) for i in range(20)]
    res = fuzz_surfaces.fuzz_surfaces({"runs": 4, "codegen": 4, "cache": 4}, seed=5, jobs=2, timeout=120.0)
    assert res["cases"] == 12
    assert not res["failures"], res["failures"]
