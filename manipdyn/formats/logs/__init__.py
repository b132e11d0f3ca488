"""Measurement logs as they come: :func:`read_log` and everything under it.

Layer 2 (formats: logs).  ``read`` (the one entry point), ``table`` (CSV streamed and
capped), ``columns`` (which header holds which signal), ``timebase`` (uneven
stamps to a uniform grid), ``filtering`` (zero-phase filters and derivatives),
``motor`` (motor-side signals brought to the joints), ``rosbag`` (JointState
messages without ROS), ``measurements`` (the samples of one experiment and
what was done to them), ``data`` (identification CSV files) and ``trajectory`` (the
``t,q1..qn[,qd..,qdd..]`` files of ``excite``, ``synthesize`` and ``track``).  These serve
identification, validation, payloads and Monte-Carlo alike.
May import: ``manipdyn.model``, ``manipdyn._support``.
"""

from .data import Measurements, read_measurements, write_measurements_csv
from .read import read_log
from .trajectory import Trajectory, read_trajectory

__all__ = ["Measurements", "Trajectory", "read_log", "read_measurements", "read_trajectory", "write_measurements_csv"]
