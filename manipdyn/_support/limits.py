"""Limits that keep the process alive on hostile or careless input.

Layer 0 (support).  Every limit is a module attribute: raise it
for an unusual but trusted model, e.g. ``manipdyn.limits.MAX_LINKS = 5000``
before ``md.load``.  A model over a limit is refused with a
:class:`~manipdyn.ModelError` that names the limit and says how to raise it.

Why these numbers: real arms have under 50 links; Pinocchio's URDF reader
recurses once per link and crashes the interpreter (a segfault, not an
exception) on chains of some ten thousand links; the trace-form and
cross-check memory grow with ``n**2`` per state.
"""

from __future__ import annotations

import math

from .errors import ModelError

__all__ = ["MAX_FILE_BYTES", "MAX_MODEL_FILE_BYTES", "MAX_LINKS", "MAX_JOINTS", "MAX_FIXED_RUN",
           "MAX_NAME_LENGTH", "MAX_LENGTH", "MAX_ANGLE", "MAX_GRAVITY", "MAX_MASS", "MAX_INERTIA",
           "MAX_MAGNITUDE", "MAX_DATA_BYTES", "MAX_DATA_FIELD_BYTES", "MAX_HARMONICS", "MAX_EXCITATION_SAMPLES",
           "MAX_RUN_STEPS", "MAX_STUDY_STEPS", "MAX_BANDWIDTH", "MAX_DEMO_DURATION", "MAX_TRAJECTORY_BYTES",
           "MAX_GRID_VALUES", "MAX_FIT_ENTRIES", "MAX_BOOTSTRAP", "MAX_PRIOR_WEIGHT", 
           "MAX_JSON_DEPTH", "MAX_SIGNAL", "MIN_SMOOTHING", "MAX_CODEGEN_OPERATIONS", "codegen_operations", "MIN_TORQUE_PEAK", "MAX_SCHEDULER_WAIT_S", "MAX_PEER_MESSAGE_BYTES", "MAX_RUNS", "MAX_PAYLOAD_MASS", "MAX_TORQUE_CONSTANT", "CLI_RAISE", "over_limit", "check_fit_size", "check_signals", "check_count", "check_magnitude", "check_range", "open_regular"]

#: largest URDF or model file read, bytes (16 MiB; real ones are under 1 MiB)
MAX_FILE_BYTES = 16 * 1024 * 1024
#: largest model file (.toml) read, bytes (1 MiB; the bundled ones are under 10 kB)
MAX_MODEL_FILE_BYTES = 1024 * 1024
#: most ``<link>`` (and so ``<joint>``) elements in a URDF
MAX_LINKS = 1000
#: most movable joints in an arm's chain (URDF chain, DH table, model file).
#: Pinocchio's ``Data`` holds four n x n x n tensors (second-order derivatives):
#: 32 MB at n = 100, 860 MB at n = 300, and an engine holds up to six of them
#: (its own, the gravity-free twin's, one per thread of each batch pool)
MAX_JOINTS = 100
#: most fixed joints in a row along any root-to-leaf path of a URDF
MAX_FIXED_RUN = 200
#: largest length (m): origins, DH a and d, centres of mass, prismatic limits.
#: float64 holds 16 digits: a 10 km offset beside a 1 mm link leaves the 1e-9 the
#: cross-check asks for; beyond, the engines' different sums round differently
MAX_LENGTH = 1e4
#: largest angle (rad): rpy, DH alpha and theta, revolute limits (q + theta loses
#: the digits of q when theta is huge)
MAX_ANGLE = 1e4
#: largest gravity component (m/s^2): tau - g cancels digits in forward dynamics
MAX_GRAVITY = 1e4
#: largest mass (kg) and inertia entry (kg m^2) of one body: a link a billion
#: times heavier than the next one leaves its neighbours' torques at the mercy of
#: its rounding (1e-16 * 1e9 * ...), beyond the cross-check's 1e-9
MAX_MASS = 1e9
MAX_INERTIA = 1e9
#: longest name (arm, link, joint) in characters: names go into URDF text and messages
MAX_NAME_LENGTH = 1000
#: largest magnitude of any model number (lengths in m, masses in kg, inertias
#: in kg m^2, gear ratios, rotor inertias, friction): products of three of them
#: (m r^2 v^2 ...) stay far from float64 overflow (1.8e308)
MAX_MAGNITUDE = 1e60
#: largest measurement log read for identification (a CSV file, or all the files of a
#: ROS bag), bytes (256 MiB: an hour of a 7-joint arm at 1 kHz with q, qd, tau is about
#: 400 MB in text, so long logs need this raised; the parsed float64 array is about a
#: third of the text's size)
MAX_DATA_BYTES = 256 * 1024 * 1024
#: longest single field (or header line) of a measurement CSV, bytes (128 KiB: a number
#: has under 30 characters; a longer field is a file that is not the table it claims to be)
MAX_DATA_FIELD_BYTES = 128 * 1024
#: most harmonics per joint of an excitation trajectory (``manipdyn excite --harmonics``):
#: the optimiser has 2 n K variables and estimates each gradient entry with one more
#: condition-number evaluation, so its time grows with K; Swevers et al. use 5
MAX_HARMONICS = 50
#: most samples of an excitation trajectory (``--rate`` x ``--duration``): its final
#: condition number stacks an n x 10 n regressor per sample (100 000 samples of a
#: 7-joint arm: 390 MB of float64)
MAX_EXCITATION_SAMPLES = 100_000
#: most integration steps of one Monte-Carlo run (``--duration / --dt``, as ``manipdyn
#: track``): each run draws an n-wide torque-noise row per step
MAX_RUN_STEPS = 2_000_000
#: lowest cut-off (Hz) of the collision observer's residual low-pass other than 0 (none): its time constant
#: 1 / (2 pi f) is then 16 s, longer than any contact it is meant to see; 1e-300 Hz gave 6e-12 N m thresholds
MIN_VELOCITY_CUTOFF = 0.01
#: most integration steps of one replay (start states x steps to the longest horizon x substeps, every
#: model together): at some 20 microseconds a step, 5e7 steps are about 20 minutes
MAX_REPLAY_STEPS = 5e7
#: most integration steps of a whole Monte-Carlo study (runs x controllers x steps):
#: at some 20 microseconds a step, 1e9 steps are about 6 core-hours
MAX_STUDY_STEPS = 1e9
#: largest trajectory CSV read by ``manipdyn synthesize`` (64 MiB: 100 000 samples
#: of a 7-joint arm, 22 columns of full-precision numbers, are about 40 MB)
MAX_TRAJECTORY_BYTES = 64 * 1024 * 1024
#: longest demo path of a Monte-Carlo run (s; as ``manipdyn track``): its via points, and the
#: run's steps, grow with the duration
MAX_DEMO_DURATION = 300.0
#: largest controller bandwidth (rad/s): the gains grow with its square, and a loop
#: this fast is far beyond any real arm's (it diverges at any practical step anyway)
MAX_BANDWIDTH = 1e6
#: most values (samples x columns) of a log's uniform time grid, checked before it is
#: allocated: one bad time stamp (a last row at t = 1e6 s) or a --resample far above the
#: log's rate would otherwise decide the grid (8.9 GiB for t = 1e6).  50 million float64
#: are 400 MB, about five times what the largest readable log (MAX_DATA_BYTES of text)
#: parses to
MAX_GRID_VALUES = 50_000_000
#: most entries (samples x joints x parameters) of the full regressor a fit stacks: the
#: fit holds it and a few copies (base columns, weights), so its memory is some 2 to 3
#: times 8 bytes per entry; 1e8 entries (800 MB each copy) is 2 minutes of a 7-joint arm
#: at 1 kHz with every friction term, far more than a fit needs (decimate, --resample a
#: lower rate or --t-range to cut a longer log)
MAX_FIT_ENTRIES = 1e8
#: most bootstrap replicates (``identify --bootstrap``): each is a whole refit; 200 give
#: the standard deviations to some 5 %, 10 000 to 0.7 %
MAX_BOOTSTRAP = 10_000
#: largest prior weight of a consistent fit (``--prior-weight``): the entropic pull is
#: added to the data's residual; beyond 1e6 the data no longer count beside it and the
#: solver's scaling breaks down (1e308 overflows)
MAX_PRIOR_WEIGHT = 1e6
#: largest magnitude of a logged signal (q in rad or m, qd, qdd, tau in N m or N): a real
#: arm's are under 1e5; squares of 1e9 summed over a long log stay far from overflow, while
#: a cell of 1e300 overflows the fit's sums
MAX_SIGNAL = 1e9
#: smallest Coulomb ``smoothing`` other than 0 (a sharp sign), rad/s (m/s): below it ``tanh(v / smoothing)``
#: is the sign at every velocity a log resolves, and ``v / smoothing`` and the derivative's
#: ``1 / smoothing`` overflow float64 (1e-320 is a subnormal: 1 / 1e-320 is inf)
MIN_SMOOTHING = 1e-9
#: smallest peak torque of a log (N m or N): below it the torques are not in N m (or the
#: column is empty), and the fit's squares underflow
MIN_TORQUE_PEAK = 1e-20
#: deepest nesting of lists and objects in a base-model JSON (a real one nests 3 deep;
#: Python's parser recurses once per level and a deep file raises RecursionError)
MAX_JSON_DEPTH = 32
#: seconds to wait for a Dask scheduler to answer (a port that listens but is not Dask's
#: never answers the handshake)
MAX_SCHEDULER_WAIT_S = 10.0
#: largest first message a Dask scheduler may announce, bytes (its handshake is a few hundred):
#: the first 8 bytes of another service ("HTTP/1.0") read as a length of some 3e18 bytes,
#: which Dask would try to allocate
MAX_PEER_MESSAGE_BYTES = 1024 * 1024

#: most arithmetic operations of an arm's generated C (``md.codegen``, ``manipdyn codegen``,
#: ``arm.compiled``), estimated from the joint count by :func:`codegen_operations` before any
#: graph is built.  The graphs' build time and the C's size grow with it, and the compiler's
#: time and memory faster: 3.4e5 estimated operations is a 20-joint arm (some 16 s of CPU to
#: generate here); a 30-joint arm (some 8e5) took 50 s and 2.2 GB, a 50-joint one was
#: killed at 4.9 GB
MAX_CODEGEN_OPERATIONS = 340_000

#: most runs of one identification (``[[log]]`` entries of a RUNS.toml, or logs given):
#: each is read, filtered and held in memory; 35 000 entries of one small log took 4.4 GB
#: and over 120 s.  A real campaign has tens of runs
MAX_RUNS = 1000
#: heaviest known payload of a run (kg): the heaviest industrial arms carry some 2 t; a
#: payload of 1e20 kg is a unit error, and its torque swamps every other term of the fit
MAX_PAYLOAD_MASS = 1e4
#: largest motor torque constant k_t (N m/A): real motors have some 0.01 to 10; beyond,
#: currents times k_t overflow the torque-constant fit's squares (1e59 did)
MAX_TORQUE_CONSTANT = 1e3

#: how to raise a limit for one command-line run (appended to the CLI's messages)
CLI_RAISE = ("from the shell: python -c \"import sys, manipdyn._support.limits as L; from manipdyn.cli import main; "
             "L.{name} = ...; sys.exit(main())\" ARGS")


def over_limit(where: str, what: str, value, name: str) -> ModelError:
    """The error for ``what`` (= ``value``) beyond the limit ``name`` of this module."""
    limit = globals()[name]
    return ModelError(
        f"{where}: {what} is {value}, over the limit of {limit:g} (manipdyn.limits.{name}); "
        f"if the model is trusted, raise it: manipdyn.limits.{name} = ..."
    )


def check_count(value, where: str, what: str, name: str, cli: bool = False) -> None:
    """Raise the :func:`over_limit` error when ``value`` (a count) exceeds the limit ``name``;
    ``cli=True`` adds how to raise it for one command-line run (:data:`CLI_RAISE`)."""
    limit = globals()[name]
    if value > limit:
        how = f"manipdyn.limits.{name} = ..." + (f" ({CLI_RAISE.format(name=name)})" if cli else "")
        try:
            shown = f"{value:g}"
        except OverflowError:               # an integer beyond the float range
            shown = f"an integer of {len(str(value))} digits"
        raise ModelError(f"{where}: {what} is {shown}, over the limit of {limit:g} "
                         f"(manipdyn.limits.{name}); to go beyond it, raise it: {how}")


def check_fit_size(samples: int, joints: int, parameters: int, where: str = "data") -> None:
    """Refuse a fit whose full regressor (``samples`` x ``joints`` x ``parameters`` entries)
    exceeds :data:`MAX_FIT_ENTRIES`, before it is built; the message says how many samples fit."""
    entries = float(samples) * joints * parameters
    if entries > MAX_FIT_ENTRIES:
        most = int(MAX_FIT_ENTRIES // max(1, joints * parameters))
        raise ModelError(
            f"{where}: {samples} samples x {joints} joints x {parameters} parameters make a regressor of "
            f"{entries:.3g} entries ({8 * entries / 2**20:.4g} MiB per copy), over the limit of "
            f"{MAX_FIT_ENTRIES:g} (manipdyn.limits.MAX_FIT_ENTRIES): fit at most {most} samples (decimate, "
            f"resample at a lower rate or cut a window: --resample, --t-range), or raise the limit")


def check_signals(where: str, rows=None, **signals) -> None:
    """Refuse a signal beyond :data:`manipdyn.limits.MAX_SIGNAL` in magnitude (a cell of 1e300), and
    torques whose peak is below :data:`manipdyn.limits.MIN_TORQUE_PEAK` (scaled by 1e-300): the
    fit's sums overflow or underflow.  The message names the column and the row."""
    import numpy as np

    for name, a in signals.items():
        if a is None or not np.size(a):
            continue
        a = np.abs(np.asarray(a, dtype=np.float64))
        k = int(np.argmax(a))
        if not a.flat[k] <= MAX_SIGNAL:
            i, j = np.unravel_index(k, a.shape) if a.ndim == 2 else (k, 0)
            row = f"row {rows[i]}" if rows is not None else f"sample {i}"
            raise ModelError(f"{where}: column {name}{j + 1}, {row}: magnitude {float(a.flat[k]):.6g}, over "
                             f"{MAX_SIGNAL:g} (manipdyn.limits.MAX_SIGNAL); not a joint signal in SI units")
        if name == "tau" and np.any(a) and a.flat[k] < MIN_TORQUE_PEAK:
            raise ModelError(f"{where}: the torques peak at {float(a.flat[k]):.6g}, below "
                             f"{MIN_TORQUE_PEAK:g} (manipdyn.limits.MIN_TORQUE_PEAK); not in N m "
                             "(or N)? Scale the torque columns")


def check_magnitude(value, where: str, field: str, unit: str = "") -> None:
    """Raise :class:`ModelError` if any entry of ``value`` exceeds :data:`MAX_MAGNITUDE`."""
    import numpy as np

    arr = np.abs(np.asarray(value, dtype=np.float64))
    if arr.size and not float(arr.max()) <= MAX_MAGNITUDE:
        worst = float(arr.reshape(-1)[int(np.argmax(arr))])
        raise ModelError(
            f"{where}: field '{field}' has magnitude {worst:g}{unit}, over {MAX_MAGNITUDE:g} "
            "(manipdyn.limits.MAX_MAGNITUDE): products of such numbers overflow float64; "
            "check the units, or raise the limit for a trusted model"
        )


_RANGES = {"length": ("MAX_LENGTH", " m"), "angle": ("MAX_ANGLE", " rad"), "acceleration": ("MAX_GRAVITY", " m/s^2"),
           "mass": ("MAX_MASS", " kg"), "inertia": ("MAX_INERTIA", " kg m^2")}


def check_range(value, where: str, field: str, kind: str) -> None:
    """Raise :class:`ModelError` if a length, angle or acceleration is beyond its limit."""
    import numpy as np

    name, unit = _RANGES[kind]
    limit = globals()[name]
    arr = np.abs(np.asarray(value, dtype=np.float64))
    if arr.size and not float(arr.max()) <= limit:
        worst = float(arr.reshape(-1)[int(np.argmax(arr))])
        raise ModelError(
            f"{where}: field '{field}' has the {kind} {worst:g}{unit}, over {limit:g}{unit} "
            f"(manipdyn.limits.{name}): float64 cannot hold it beside the arm's other {kind}s to the "
            "cross-check's 1e-9; check the units, or raise the limit for a trusted model"
        )


def open_regular(path: str, label: str):
    """Open ``path`` for reading bytes, refusing anything but a regular file.

    A FIFO would block ``open`` forever and a device (``/dev/zero``) never
    ends; the file is opened non-blocking, checked with ``fstat``, then read.
    """
    import os
    import stat

    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise ModelError(f"{label}: {exc.strerror or exc}") from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        kind = "a directory" if stat.S_ISDIR(st.st_mode) else "not a regular file (a device, FIFO or socket)"
        raise ModelError(f"{label}: {kind}")
    return os.fdopen(fd, "rb")


def read_regular(path: str, label: str, limit_name: str, what: str = "the file",
                 size_of: str = "the file") -> bytes:
    """The bytes of the regular file ``path``, at most the limit ``limit_name`` of them.

    A ModelError starting with ``label`` says ``cannot read <what>`` when the
    file cannot be read or is not a regular file (:func:`open_regular`), and
    ``<size_of> size`` when it is larger than the limit.
    """
    cap = globals()[limit_name]
    try:
        with open_regular(path, f"{label}: cannot read {what}") as fh:
            data = fh.read(cap + 1)
    except OSError as exc:
        raise ModelError(f"{label}: cannot read {what}: {exc.strerror or exc}") from None
    if len(data) > cap:
        raise over_limit(label, f"{size_of} size", f"over {cap} bytes", limit_name)
    return data


def nonnegative(value, where: str, unit: str = "") -> float:
    """``value`` as a finite float >= 0, or a ModelError (a ValueError) naming ``where``."""
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ModelError(f"{where}: expected a number{' in ' + unit if unit else ''}, got {value!r:.60}") from None
    if not (math.isfinite(x) and x >= 0):
        raise ModelError(f"{where}: must be finite and >= 0{' ' + unit if unit else ''}, got {value!r:.60}")
    return x


def codegen_operations(n: int) -> float:
    """Estimated arithmetic operations of the generated C of an ``n``-joint arm (all its
    functions): ``370 n**2.26``, fitted to the counts of a random arm with rotors (seed 5 of
    the tests' random arms) since the RNEA derivatives come from the recursive derivative
    algorithm (issue 34): within 5 % of it for n = 4 to 20 (8099, 30656, 65127, 140148 and
    312512 operations at n = 4, 7, 10, 14 and 20); other random arms (seeds 6 and 7) hold up to
    1.6 times the estimate at n = 4, and 1.00 to 1.05 times it at n = 20, where the cap bites."""
    return 370.0 * float(n) ** 2.26
