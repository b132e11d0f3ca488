"""Seeded fuzzing of the newer surfaces: RUNS.toml, ``codegen`` and the compiled-engine cache.

Run from the repository root::

    python -m tests.fuzz_surfaces --cases 200            # each kind (minutes)
    python -m tests.fuzz_surfaces --show cache:17        # one case

* ``runs``: a RUNS.toml of one to three ``[[log]]`` tables whose keys take hostile values
  (NUL and newline in paths, devices, folders, the file itself, 400-digit integers, nan,
  1e308, payloads of 1e20 kg or a com of 1e300 m, unknown keys, a log listed twice) for
  ``identify ur5 --logs RUNS.toml --method ols -o OUT.toml``.
* ``codegen``: a 2-joint model whose name and source hold comment closers, trigraphs,
  bidirectional overrides and control characters, written by ``codegen`` into targets that
  are folders, FIFOs, devices, links onto the model, or missing folders, with hostile
  ``--prefix`` values.
* ``cache``: a valid build of a 2-joint arm, tampered with one to three of: truncation, a
  flipped byte, a widened mode, a manifest field changed, the manifest removed, another
  arm's build copied in, a symbolic link in place of the library; then ``arm.compiled`` is
  asked for its inverse dynamics.

The contract, per case (in a worker process, with a timeout; a crash such as SIGBUS is a
failure): exit 0 with a checked result (``OUT.toml`` loads; both C files compile; the engine's
numbers agree with the trace form to 1e-8 and the cache's folders and files are private), or
exit 2 (``ModelError``) with one line naming the key, option or folder.  Never exit 3, a
traceback, a hang or a crash.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import random
import shutil
import stat
import sys

from tests.fuzz import run_pool

PASS = ("refused (exit 2, named)", "ran (exit 0, output checked)", "ran (exit 1, stated)")
KINDS = ("runs", "codegen", "cache")

NUMBERS = ["0", "-1", "nan", "inf", "-inf", "1e308", "-1e308", "5e-324", "1e-9", "1e9", "9" * 400,
           "-" + "9" * 400, '"abc"', '""', "true", "[]", "{}", "2.5", "1", "1e20", "1e300"]
PATHS = ['"{log}"', '"{log}"', '"{log}"', '"run\\u0000.csv"', '"a\\nb.csv"', '"/dev/zero"', '"/"', '"."',
         '"RUNS.toml"', '"missing.csv"', '""', "5", '"{tmp}"', '"\\u202e.csv"', '"../' + "x" * 300 + '"']
RUNS_KEYS = {
    "path": PATHS,
    "t_range": ["[0, 2]", "[2, 0]", "[0]", "[nan, 1]", "[0, 1e308]", "[-1e308, 1e308]", "[0, " + "9" * 400 + "]",
                '"0:2"', "[0, 2, 3]", "[true, 2]"],
    "rate": NUMBERS,
    "columns": ['"q=Joint_{i},tau=Effort_{i}"', '"q=q{i},q=q{i}"', "5", '""', "{ q = \"q{i}\" }", '"tau=x"'],
    "payload": ["{ mass = " + v + ", com = [0, 0, 0.05] }" for v in ("2", "-3", "0", "1e20", "1e-300", "9" * 400)]
    + ["{ mass = 2, com = [" + v + ", 0, 0] }" for v in ("1e300", "1e200", "nan")]
    + ["{ mass = 2, com = [0, 0, 0], inertia = [" + v + "] }" for v in ("1e250, 1e250, 1e250, 0, 0, 0",
                                                                        "-1, 1, 1, 0, 0, 0", "1, 1, 5, 0, 0, 0")]
    + ["{ mass = 2 }", "{ mass = 2, com = [0, 0, 0], colour = 1 }", "5"],
}
NAMES = ["arm", "a /* b", "x */ int evil; /*", "trigraph ??/", "\u202eevil", "tab\there", "back\\slash",
         "quote\"s", "é", "x" * 900, "??=??(??)", "*/*/", "//", ""]
TARGETS = ["{tmp}/gen", "{tmp}/gen", "{tmp}/fifo", "{tmp}/afile", "{tmp}/missing/deeper", "/dev/null",
           "{tmp}/linkdir", "{tmp}/dev"]
PREFIXES = [None, None, "p", "1x", "int", "a" * 80, "a-b", "", "ok_name", "\u00e9"]
TAMPER = ["truncate", "flip", "chmod", "manifest-field", "manifest-gone", "other-arm", "symlink",
          "manifest-garbage", "folder-file", "empty-library"]


def _rng(kind, seed, index):
    return random.Random(f"{kind}:{seed}:{index}")


def make_case(kind: str, seed: int, index: int) -> dict:
    """The description of case ``index`` of ``kind`` (deterministic in seed and index)."""
    rng = _rng(kind, seed, index)
    if kind == "runs":
        entries = []
        for _ in range(rng.randint(1, 3)):
            keys = {"path": '"{log}"'}
            for key in rng.sample(sorted(RUNS_KEYS), rng.randint(1, 3)):
                keys[key] = rng.choice(RUNS_KEYS[key])
            if rng.random() < 0.05:
                keys["colour"] = '"red"'                 # an unknown key, now and then
            entries.append(keys)
        return {"entries": entries}
    if kind == "codegen":
        return {"name": rng.choice(NAMES), "source": rng.choice(NAMES), "target": rng.choice(TARGETS),
                "prefix": rng.choice(PREFIXES), "link_onto_model": rng.random() < 0.2}
    return {"tamper": rng.sample(TAMPER, rng.randint(1, 3)), "at": rng.random(), "byte": rng.randrange(256),
            "mode": rng.choice([0o777, 0o722, 0o770, 0o707, 0o600])}


def _log(folder: str) -> str:
    """A short UR5 log, made once per worker."""
    path = os.path.join(os.path.dirname(folder), "fuzz-ur5-log.csv")
    if not os.path.exists(path):
        import numpy as np

        import manipdyn as md
        from manipdyn.identification import excitation, write_measurements_csv

        arm = md.load("ur5")
        ex = excitation(arm, duration=3.0, harmonics=3, rate=50.0, iterations=0, seed=1)
        tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
        tau = tau + 0.01 * np.random.default_rng(0).standard_normal(tau.shape)
        write_measurements_csv(path + ".tmp", ex.t, ex.q, tau)
        os.replace(path + ".tmp", path)
    return path


def _argv_runs(case, folder):
    log = _log(folder)
    text = ""
    for e in case["entries"]:
        text += "[[log]]\n" + "".join(f"{k} = {v.replace('{log}', log).replace('{tmp}', folder)}\n"
                                      for k, v in e.items())
    runs = os.path.join(folder, "RUNS.toml")
    with open(runs, "w", encoding="utf-8") as f:
        f.write(text)
    return ["identify", "ur5", "--logs", runs, "--method", "ols", "-o", os.path.join(folder, "out.toml")]


def _argv_codegen(case, folder):
    import manipdyn as md
    from manipdyn.model.random_arms import random_arm

    arm = random_arm(3, n=2)
    arm.name, arm.source = case["name"], case["source"]
    model = os.path.join(folder, "model.toml")
    try:
        md.save(arm, model)
    except md.ModelError:
        arm.name = "arm"
        md.save(arm, model)
    target = case["target"].replace("{tmp}", folder)
    os.makedirs(os.path.join(folder, "gen"), exist_ok=True)
    os.mkfifo(os.path.join(folder, "fifo"))
    with open(os.path.join(folder, "afile"), "w") as f:
        f.write("keep")
    os.symlink(os.path.join(folder, "gen"), os.path.join(folder, "linkdir"))
    os.makedirs(os.path.join(folder, "dev"))
    from manipdyn.engines.c.emit import c_identifier

    prefix = case["prefix"] if case["prefix"] is not None else c_identifier(arm.name)
    if os.path.exists("/dev/full") and prefix:
        with contextlib.suppress(OSError):        # a name too long for the file system
            os.symlink("/dev/full", os.path.join(folder, "dev", prefix + ".c"))
    if case["link_onto_model"] and prefix:
        with contextlib.suppress(OSError):
            os.symlink(model, os.path.join(folder, "gen", prefix + ".h"))
    argv = ["codegen", model, "-o", target]
    if case["prefix"] is not None:
        argv += [f"--prefix={case['prefix']}"]
    return argv


def _tamper_cache(case, folder):
    """Build the arm's engine in a private cache under ``folder``, tamper with it: the arm."""
    from manipdyn.engines.c import build
    from manipdyn.engines.c.engine import library_for
    from manipdyn.model.random_arms import random_arm

    # built, not loaded: truncating a library this process has mapped would SIGBUS the harness
    os.environ[build.CACHE_ENV] = os.path.join(folder, "cache")
    arm = random_arm(21, n=2)
    lib = library_for(arm, opt="-O0")
    key = os.path.dirname(lib)
    manifest = os.path.join(key, "manifest.json")
    for t in case["tamper"]:
        if not os.path.isdir(key) or not os.path.lexists(lib):
            break
        if t == "truncate" and os.path.isfile(lib):
            os.truncate(lib, int(os.path.getsize(lib) * case["at"]))
        elif t == "flip" and os.path.isfile(lib):
            size = os.path.getsize(lib)
            with open(lib, "r+b") as f:
                f.seek(int(size * case["at"]) % max(size, 1))
                f.write(bytes([case["byte"]]))
        elif t == "chmod" and os.path.lexists(rng_path(case, (lib, manifest, key))):
            os.chmod(rng_path(case, (lib, manifest, key)), case["mode"])
        elif t == "manifest-field" and os.path.isfile(manifest):
            try:
                with open(manifest, encoding="utf-8") as f:
                    data = json.load(f)
            except ValueError:            # already garbage
                continue
            field = sorted(data)[int(case["at"] * len(data)) % len(data)]
            data[field] = {"n": 3, "p": 33, "size": 1, "sha256": "0" * 64}.get(field, "x")
            with open(manifest, "w") as f:
                json.dump(data, f)
        elif t == "manifest-gone" and os.path.exists(manifest):
            os.unlink(manifest)
        elif t == "manifest-garbage" and os.path.exists(manifest):
            with open(manifest, "wb") as f:
                f.write(b"\xff\x00{" * 10)
        elif t == "other-arm":
            other = os.path.dirname(library_for(random_arm(22, n=2 + int(case["at"] * 2)), opt="-O0"))
            for name in os.listdir(other):
                shutil.copyfile(os.path.join(other, name), os.path.join(key, name))
        elif t == "symlink" and os.path.isfile(lib):
            os.replace(lib, lib + ".real")
            os.symlink(lib + ".real", lib)
        elif t == "folder-file":
            shutil.rmtree(key)
            with open(key, "w") as f:
                f.write("not a folder")
        elif t == "empty-library":
            open(lib, "wb").close()
    return arm


def rng_path(case, paths):
    return paths[int(case["at"] * len(paths)) % len(paths)]


def _private(folder) -> str | None:
    for dirpath, dirnames, filenames in os.walk(folder):
        for name in [""] + dirnames + filenames:
            st = os.lstat(os.path.join(dirpath, name))
            if st.st_uid != os.geteuid() or st.st_mode & 0o022:
                return f"{os.path.join(dirpath, name)} has mode {stat.S_IMODE(st.st_mode):o}, uid {st.st_uid}"
    return None


def _check(kind, case, argv, folder) -> str | None:
    """None when an exit-0 result is meaningful, else what is wrong with it."""
    import manipdyn as md

    if kind == "runs":
        try:
            md.load(os.path.join(folder, "out.toml"))
        except (md.ModelError, OSError) as exc:
            return f"exit 0 but out.toml does not load: {exc!s:.200}"
        return None
    out = argv[argv.index("-o") + 1]
    names = [n for n in os.listdir(out) if n.endswith((".h", ".c"))] if os.path.isdir(out) else []
    if len(names) < 2:
        return f"exit 0 but {out} holds {names}"
    return None


def run_case(kind: str, seed: int, index: int, folder: str) -> tuple[str, str]:
    """(outcome, detail) of one case, run in this (worker) process."""
    import warnings

    import numpy as np

    import manipdyn as md
    from manipdyn.cli import main

    case_dir = os.path.join(folder, f"{kind}-{index}")
    os.makedirs(case_dir, exist_ok=True)
    case = make_case(kind, seed, index)
    out, err = io.StringIO(), io.StringIO()
    if kind == "cache":
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                arm = _tamper_cache(case, case_dir)
                q = np.linspace(-1.0, 1.0, arm.n)
                from manipdyn.engines.c import compiled_engine

                engine = compiled_engine(arm, opt="-O0")        # the tampered build's key (arm.compiled is -O2)
                diff = float(np.abs(engine.inverse_dynamics(q, q, q) - arm.lagrange.inverse_dynamics(q, q, q)).max())
        except md.ModelError as exc:
            line = str(exc)
            return (("refused (exit 2, named)", line[:200]) if "\n" not in line and "cache" in line
                    else ("UNCLEAR (ModelError)", line[:300]))
        except BaseException as exc:  # noqa: BLE001 - classifying is the point
            return f"FOREIGN {type(exc).__name__}", f"{case}: {exc!s:.300}"
        if not diff < 1e-8:
            return "WRONG NUMBERS", f"{case}: {diff:.3g}"
        problem = _private(os.path.join(case_dir, "cache"))
        return ("ran (exit 0, output checked)", str(case)) if problem is None else ("NOT PRIVATE", problem)
    try:
        argv = _argv_runs(case, case_dir) if kind == "runs" else _argv_codegen(case, case_dir)
        with warnings.catch_warnings(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            warnings.simplefilter("ignore")
            try:
                code = main(argv)
            except SystemExit as exc:
                code = exc.code
    except BaseException as exc:  # noqa: BLE001
        return f"FOREIGN {type(exc).__name__}", f"{case}: {exc!s:.300}"
    lines = [ln for ln in err.getvalue().splitlines() if ln.strip()]
    where = f"{case}"
    if code == 0:
        problem = _check(kind, case, argv, case_dir)
        return ("ran (exit 0, output checked)", where) if problem is None else ("MEANINGLESS SUCCESS", f"{where}: {problem}")
    if code == 1 and kind == "runs" and lines:
        return "ran (exit 1, stated)", f"{where}: {lines[-1][:200]}"
    if code == 2:
        if len(lines) != 1:
            return "UNCLEAR (exit 2 without one error line)", f"{where}: {lines[-5:]}"
        named = ("[[log]]", "--logs", "RUNS", "-o", "--prefix", "prefix", "logs:", "model", "MODEL", "dir")
        if not any(n in lines[0] for n in named):
            return "UNNAMED (exit 2)", f"{where}: {lines[0][:300]}"
        return "refused (exit 2, named)", f"{where}: {lines[0][:200]}"
    return f"EXIT {code}", f"{where}: {' | '.join(lines[-3:])[:400]}"


def fuzz_surfaces(cases: dict, seed: int = 0, jobs: int = 2, timeout: float = 60.0, progress=None) -> dict:
    """Run ``cases`` (kind -> count); the result of :func:`tests.fuzz.run_pool`."""
    jobs_list = [(kind, seed, i) for kind in KINDS for i in range(cases.get(kind, 0))]
    return run_pool(jobs_list, KINDS, seed, jobs, timeout, progress, runner=run_case, passing=PASS)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.fuzz_surfaces", description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", type=int, default=100, help="cases per kind (default 100)")
    p.add_argument("--kinds", default=",".join(KINDS), help=f"comma-separated kinds (default {','.join(KINDS)})")
    p.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--timeout", type=float, default=60.0, help="seconds per case before it is a hang (default 60)")
    p.add_argument("--show", metavar="KIND:INDEX", default=None, help="print one case and exit")
    args = p.parse_args(argv)
    if args.show:
        kind, idx = args.show.split(":")
        print(json.dumps(make_case(kind, args.seed, int(idx)), ensure_ascii=True))
        return 0
    kinds = [k for k in args.kinds.split(",") if k]
    res = fuzz_surfaces({k: args.cases for k in kinds}, args.seed, args.jobs, args.timeout)
    print(f"fuzz_surfaces: {res['cases']} cases in {res['seconds']:.0f} s (seed {args.seed})")
    for kind, c in res["counts"].items():
        for outcome, k in sorted(c.items(), key=lambda x: -x[1]):
            print(f"  {kind:<8} {k:6d}  {outcome}{'' if outcome in PASS else '   <-- FAILS THE CONTRACT'}")
    for kind, idx, outcome, detail in res["failures"][:40]:
        print(f"  FAIL {kind}:{idx} {outcome}: {detail[:400]}")
    return 1 if res["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
