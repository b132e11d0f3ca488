"""The demo tracking run as one library call: :func:`track` (``manipdyn track`` prints it).

Layer 6 (control).  ``track(arm, ...)`` builds the standard demo path
(:func:`~manipdyn.control.demo.demo_path`), the tuned controllers
(:func:`~manipdyn.control.demo.make_controller`) and, with a payload, a plant
that carries it unknown to the controllers; it simulates each controller
(:func:`~manipdyn.control.simulate.simulate`) and returns a :class:`TrackResult`
that prints, serialises and draws itself.  The command line only parses its
options, calls :func:`track` and prints the result, so that both run the same
thing with the same defaults.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from .._support.errors import ModelError
from ..model.variants import with_payload
from .demo import CONTROLLERS, DEFAULT_BANDWIDTH, DEFAULT_GAMMA, DEFAULT_PAYLOAD_COM, demo_path, make_controller
from .reference import ReferencePath, read_path
from .simulate import SimulationDiverged, simulate
from .trajectory import Trajectory

__all__ = ["track", "TrackResult", "check_track_options", "track_header", "reference_for", "MAX_DURATION", "MAX_STEPS"]

#: bounds on a demo run: the via-point spline of the demo path is solved densely
#: (its cost grows with the square of the duration) and the log is in memory
MAX_DURATION = 300.0
MAX_STEPS = 2e6


def check_track_options(*, duration: float | None, dt: float, payload: float, bandwidth: float, gamma: float,
                        prefix: str = "") -> None:
    """Refuse every bad numeric option of :func:`track` before any work.

    ``prefix`` is put before each name in the message (the command line passes ``"--"``,
    so that its one-line errors name its options).  ``duration`` None: not known yet (the
    length of a path still to be read); it is checked again when it is.
    """
    if duration is None:
        stand_in = min(max(dt, 1e-9), MAX_DURATION) if isinstance(dt, (int, float)) and dt > 0 else 1.0
        check_track_options(duration=stand_in, dt=dt,
                            payload=payload, bandwidth=bandwidth, gamma=gamma, prefix=prefix)
        return
    values = {"duration": duration, "dt": dt, "payload": payload, "bandwidth": bandwidth, "gamma": gamma}
    for name, v in values.items():
        if not isinstance(v, (int, float, np.floating, np.integer)) or isinstance(v, bool) or not math.isfinite(v):
            raise ModelError(f"{prefix}{name}: must be a finite number, got {v!r:.60}")
    if not (0 < duration <= MAX_DURATION):
        raise ModelError(f"{prefix}duration: must be > 0 s and at most {MAX_DURATION:g} s, got {duration}")
    if not (dt > 0) or dt > duration:
        raise ModelError(f"{prefix}dt: must be > 0 s and at most {prefix}duration, got {dt}")
    if duration / dt > MAX_STEPS:
        raise ModelError(f"{prefix}dt: {duration:g} s at dt = {dt:g} s is more than {MAX_STEPS:g} steps")
    if not (payload >= 0):
        raise ModelError(f"{prefix}payload: must be >= 0 kg, got {payload}")
    if not (bandwidth > 0):
        raise ModelError(f"{prefix}bandwidth: must be > 0 rad/s, got {bandwidth}")
    if not (gamma >= 0):
        raise ModelError(f"{prefix}gamma: must be >= 0, got {gamma}")


def track_header(arm, duration: float, dt: float, bandwidth: float, payload: float, reference: str = "",
                 simulator: str = "manipdyn") -> str:
    """The one-line header of a run (printed before the runs start); ``reference`` names the
    user's path (:func:`~manipdyn.control.reference.read_path`), "" the demo path; ``simulator``
    who steps the plant."""
    who = "MuJoCo's RK4 on the arm's MJCF, the torque as the actuators' control" if simulator == "mujoco" else "RK4"
    head = (f"manipdyn track {arm.name}: {reference or 'demo path'} {duration:g} s, {1 / dt:g} Hz {who} "
            f"(torque held over each step), bandwidth {bandwidth:g} rad/s")
    if payload > 0:
        head += (f"; plant carries {payload:g} kg at {list(DEFAULT_PAYLOAD_COM)} m in the last "
                 "link's frame, unknown to the controllers")
    return head


def _floats(x) -> list:
    return [float(v) for v in np.asarray(x).reshape(-1)]


@dataclass(frozen=True)
class TrackResult:
    """The runs of :func:`track`: one :class:`~manipdyn.control.simulate.SimulationLog` per
    controller label (:data:`~manipdyn.control.demo.CONTROLLERS`), or the divergence message.

    Errors are in rad (m for prismatic joints), torques in N m (N), time in s.
    """

    arm: object
    controllers: tuple
    duration: float
    dt: float
    bandwidth: float
    gamma: float
    payload: float
    logs: dict = field(default_factory=dict)       # label -> SimulationLog | str ("DIVERGED at t = ...")
    messages: dict = field(default_factory=dict)   # label -> the divergence's full message
    reference: str = ""                            # the user's path ("path FILE (N samples of q)"), "" the demo
    simulator: str = "manipdyn"                     # who stepped the plant ("manipdyn" or "mujoco")
    mujoco_plant: str = "file"                      # MuJoCo's plant (manipdyn.control.mjsim)

    @property
    def final(self) -> float:
        """Start of the final second, s: where the settled tracking error is read."""
        return max(0.0, self.duration - 1.0)

    @property
    def diverged(self) -> bool:
        """True when at least one controller drove the arm unstable."""
        return any(isinstance(v, str) for v in self.logs.values())

    def header(self) -> str:
        """One line: the arm, the path, the rate, and the payload the controllers do not know."""
        return track_header(self.arm, self.duration, self.dt, self.bandwidth, self.payload, self.reference,
                            self.simulator)

    def run_text(self, label: str) -> str:
        """The summary of one controller's run (or its divergence)."""
        log = self.logs[label]
        if isinstance(log, str):
            return f"{label}: {self.messages.get(label, log)}"
        return (log.summary() + f"\n  RMS error over the final second (t >= {self.final:g} s): "
                + " ".join(f"{x:.3e}" for x in log.rms_error(since=self.final)))

    def compare_table(self) -> str:
        """All controllers side by side (norms over joints)."""
        final = self.final
        rows = [f"{'controller':<24} {'RMS error':>11} {'max error':>11} {f'RMS t>={final:g}s':>12} "
                f"{'peak torque':>12}"]
        for label, log in self.logs.items():
            if isinstance(log, str):
                rows.append(f"{label:<24} {log}")
                continue
            rows.append(f"{label:<24} {np.linalg.norm(log.rms_error()):11.3e} {log.max_error().max():11.3e} "
                        f"{np.linalg.norm(log.rms_error(since=final)):12.3e} {log.peak_torque().max():12.4g}")
        rows.append("  (RMS: norm over joints of the per-joint RMS error; rad and m mixed for "
                    "arms with prismatic joints)")
        return "\n".join(rows)

    def to_dict(self, model: str | None = None, notes=()) -> dict:
        """Strict-JSON document: the settings and, per controller, its errors and torques per joint."""
        runs = {}
        for label, log in self.logs.items():
            if isinstance(log, str):
                runs[label] = {"diverged": True, "message": log}
                continue
            runs[label] = {"diverged": False, "rms_error": _floats(log.rms_error()),
                           "max_error": _floats(log.max_error()),
                           "rms_error_final_second": _floats(log.rms_error(since=self.final)),
                           "peak_torque": _floats(log.peak_torque())}
        return {"model": model if model is not None else self.arm.name, "name": self.arm.name, "n": self.arm.n,
                "duration": self.duration, "dt": self.dt, "bandwidth": self.bandwidth, "gamma": self.gamma,
                "payload": self.payload, "path": self.reference or "demo", "simulator": self.simulator,
                **({"mujoco_plant": self.mujoco_plant} if self.simulator == "mujoco" else {}), "notes": list(notes), "controllers": runs}

    def plot(self, path: str) -> str | None:
        """Write the figure (all controllers when more than one ran); returns None when written,
        else why not (the only run diverged).  Needs the ``plot`` extra (matplotlib)."""
        from .plots import plot_compare, plot_single

        title = f"{self.arm.name}: {self.reference or 'demo path'}, {self.duration:g} s at {1 / self.dt:g} Hz" + \
            (" in MuJoCo" if self.simulator == "mujoco" else "") + \
            (f", +{self.payload:g} kg payload unknown to the controller" if self.payload > 0 else "")
        if len(self.controllers) > 1:
            plot_compare(self.logs, self.arm, title, path)
            return None
        label = CONTROLLERS[self.controllers[0]]
        only = self.logs[label]
        if isinstance(only, str):
            return f"no figure: the run {only.lower()}"
        plot_single(only, self.arm, f"{title}\n{label}", path)
        return None


def reference_for(arm, trajectory=None, duration=None):
    """``(trajectory or None, duration, label)`` of a run: the demo path (``trajectory`` None: built
    by :func:`track`; ``duration`` default 8 s), or the user's (a CSV file name, read by
    :func:`~manipdyn.control.reference.read_path`, or a
    :class:`~manipdyn.control.trajectory.Trajectory`), ``duration`` default its length."""
    path = trajectory
    if path is None:
        return None, (8.0 if duration is None else duration), ""
    if isinstance(path, (str, os.PathLike)):
        path = read_path(path, arm)
    elif not (isinstance(path, Trajectory) and getattr(path, "n", None) == arm.n):
        raise ModelError(f"trajectory: expected a CSV file of t, q1..q{arm.n} or a Trajectory of {arm.n} joints, "
                         f"got {path!r:.80}")
    label = (f"path {path.source} ({path.samples} samples of {path.columns})" if isinstance(path, ReferencePath)
             else f"path {type(path).__name__}")
    return path, (path.t_end if duration is None else duration), label


def track(arm, controllers=("ct",), *, payload: float = 0.0, duration: float | None = None, dt: float = 1e-3,
          bandwidth: float = DEFAULT_BANDWIDTH, gamma: float = DEFAULT_GAMMA, progress=None,
          on_run=None, trajectory=None, simulator: str = "manipdyn", mujoco_plant: str = "file") -> TrackResult:
    """Run the demo path (or the user's ``trajectory``) with each controller of ``controllers`` on ``arm``.

    Parameters
    ----------
    arm : manipdyn.Arm
        The arm the controllers are built on.
    controllers : sequence of str
        Keys of :data:`~manipdyn.control.demo.CONTROLLERS` (``"pd"``, ``"pdg"``, ``"ct"``,
        ``"adaptive"``, ``"lqr"``; any case), or ``"all"``.
    payload : float
        kg carried by the simulated plant at ``DEFAULT_PAYLOAD_COM`` in the last link's
        frame, unknown to the controllers.
    duration, dt : float
        s; the run (default 8 s on the demo path, the path's length on the user's) and the
        control period (RK4 sub-steps as the plant needs).
    bandwidth : float
        Closed-loop bandwidth of the controllers, rad/s.
    gamma : float
        Adaptation gain of the adaptive controller.
    progress : callable, optional
        ``progress(label) -> callback(done, total)``: a progress reporter per run.
    on_run : callable, optional
        Called as ``on_run(result, label)`` after each run (the command line prints there).
    trajectory : str, os.PathLike or Trajectory, optional
        The reference to track instead of the demo path: a CSV file of ``t, q1..qn``
        (:func:`~manipdyn.control.reference.read_path`: times from the first row, positions
        within the joint limits, or ``excite``'s file with velocities and accelerations), or a
        :class:`~manipdyn.control.trajectory.Trajectory`.  The arm starts on it.
    simulator : "manipdyn" | "mujoco"
        Who steps the plant (:func:`~manipdyn.control.simulate.simulate`): manipdyn's RK4, or
        MuJoCo's RK4 on the plant's MJCF with the controller's torque as the actuators' control
        each period (the ``mujoco`` extra); same report and figure.
    mujoco_plant : "file" | "model"
        MuJoCo's plant (:mod:`manipdyn.control.mjsim`): the MJCF as MuJoCo loads it (default), or
        the same plant as manipdyn's own run (constraints off, the whole friction law applied).
    """
    path, duration, reference = reference_for(arm, trajectory, duration)
    check_track_options(duration=duration, dt=dt, payload=payload, bandwidth=bandwidth, gamma=gamma)
    path = demo_path(arm, duration) if path is None else path
    kinds = list(CONTROLLERS) if controllers == "all" else [str(k).lower() for k in controllers]
    unknown = [k for k in kinds if k not in CONTROLLERS]
    if not kinds or unknown:
        raise ModelError(f"controllers: expected keys of {list(CONTROLLERS)} or 'all', got {list(controllers)!r:.80}")
    if simulator not in ("manipdyn", "mujoco"):
        raise ModelError(f"simulator: expected 'manipdyn' or 'mujoco', got {simulator!r:.40}")
    if mujoco_plant not in ("file", "model"):
        raise ModelError(f"mujoco_plant: expected 'file' or 'model', got {mujoco_plant!r:.40}")
    plant = with_payload(arm, payload, com=DEFAULT_PAYLOAD_COM) if payload > 0 else arm
    result = TrackResult(arm, tuple(kinds), float(duration), float(dt), float(bandwidth), float(gamma),
                         float(payload), reference=reference, simulator=simulator, mujoco_plant=mujoco_plant)
    for kind in kinds:
        ctrl = make_controller(kind, arm, bandwidth, gamma, path=path, dt=dt)
        label = CONTROLLERS[kind]
        try:
            result.logs[label] = simulate(arm, ctrl, path, duration, dt=dt, plant=plant, simulator=simulator,
                                          mujoco_plant=mujoco_plant,
                                          progress=progress(label[:16]) if progress else None)
        except SimulationDiverged as exc:
            result.logs[label] = f"DIVERGED at t = {exc.t:.3g} s"
            result.messages[label] = str(exc)
        if on_run is not None:
            on_run(result, label)
    return result
