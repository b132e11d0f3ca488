"""``manipdyn bench``: the benchmark suite of a source checkout, with a clean BLAS environment.

Layer 7 (CLI, the top).

The suite (``benchmarks/``) is part of the repository, not of the installed
package: it compares against other libraries and writes result files that
belong to the checkout.  ``manipdyn bench`` finds it next to the ``manipdyn``
package (an editable install or a checkout on ``sys.path``) and runs
``python -m benchmarks.run`` there as its own process, with
``OPENBLAS_CORETYPE`` and ``OPENBLAS_L2_SIZE`` unset for that run alone (they
select OpenBLAS kernels that slow NumPy's small matrix products; the run
records the configuration it got either way).  Without a checkout it says so
and exits 2.  The exit status is the suite's: 0, 1 (a missed target with
``--strict``), 2 (a wrong answer or bad options).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from .._support.errors import ModelError

__all__ = ["register", "run", "suite_root"]

#: environment variables removed for the benchmark run (unless --keep-blas-env)
BLAS_ENV = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")


def suite_root() -> Path | None:
    """The checkout that holds ``benchmarks/run.py`` beside the ``manipdyn`` package, or None."""
    root = Path(__file__).resolve().parents[2]
    return root if (root / "benchmarks" / "run.py").is_file() else None


def _suite_argv(args) -> list[str]:
    argv = []
    for flag in ("smoke", "publish", "check_targets", "no_rtb", "no_plot"):
        if getattr(args, flag):
            argv.append("--strict" if flag == "check_targets" else "--" + flag.replace("_", "-"))
    if args.out:
        argv += ["--out", os.path.abspath(args.out)]
    if args.arms:
        argv += ["--arms", *args.arms]
    if args.skip:
        argv += ["--skip", *args.skip]
    if args.seed is not None:
        argv += ["--seed", str(args.seed)]
    return argv


def run(args) -> int:
    root = suite_root()
    if root is None:
        raise ModelError(
            "the benchmark suite is not installed with manipdyn: it lives in the source repository's "
            "benchmarks/ folder. From a checkout: pip install -e '.[bench]' && manipdyn bench "
            "(or python -m benchmarks.run)")
    env = dict(os.environ)
    if not args.keep_blas_env:
        for name in BLAS_ENV:
            env.pop(name, None)
    cmd = [sys.executable, "-m", "benchmarks.run", *_suite_argv(args)]
    child = subprocess.Popen(cmd, cwd=root, env=env)
    try:
        return child.wait()
    except KeyboardInterrupt:
        # Ctrl-C reached the suite too (same process group): it removes its run folder and
        # exits 130 quietly; wait for that rather than leave it half-way
        try:
            child.wait(timeout=30)
        except (subprocess.TimeoutExpired, KeyboardInterrupt):
            child.kill()
            child.wait()
        print("manipdyn bench: interrupted", file=sys.stderr)
        return 130


def register(sub) -> None:
    """Add ``manipdyn bench``."""
    b = sub.add_parser(
        "bench", help="run the benchmark suite (source checkout only)",
        description=__doc__.split("\n\n")[2].replace("\n", " ").replace("``", "'"))   # no RST quotes in --help
    b.add_argument("--smoke", action="store_true", help="a few seconds, tiny sizes (checks the code runs)")
    b.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (default: benchmarks/results/runs/<UTC time>-<mode>/, ignored by git)")
    b.add_argument("--publish", action="store_true",
                   help="also rewrite the committed reference results (full runs only)")
    b.add_argument("--strict", "--check-targets", dest="check_targets", action="store_true",
                   help="exit 1 when a performance target is missed (the report still says MISS; "
                        "without it a miss is reported and the exit is 0)")
    b.add_argument("--arms", nargs="+", default=None, metavar="ARM", help="bundled arms to time (default: puma560 stanford ur5 ur10)")
    b.add_argument("--no-rtb", action="store_true", help="leave the Robotics Toolbox out")
    b.add_argument("--no-plot", action="store_true", help="do not write scaling.png")
    b.add_argument("--skip", nargs="+", default=None, choices=("per-call", "batch", "scaling"),
                   help="sections to leave out")
    b.add_argument("--seed", type=int, default=None, help="seed of the random states (default the suite's)")
    b.add_argument("--keep-blas-env", action="store_true",
                   help=f"keep {' and '.join(BLAS_ENV)} for the run (default: unset them)")
    b.set_defaults(func=run)
