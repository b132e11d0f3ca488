"""Measurement logs as they come: :func:`read_log` and everything under it.

Layer 2 (formats: logs).  ``read`` (the one entry point), ``table`` (CSV streamed and
capped), ``columns`` (which header holds which signal), ``timebase`` (uneven
stamps to a uniform grid), ``filtering`` (zero-phase filters and derivatives),
``motor`` (motor-side signals brought to the joints), ``rosbag`` (JointState
messages without ROS), ``measurements`` (the samples of one experiment and
what was done to them) and ``data`` (identification CSV files).  These serve
identification, validation, payloads and Monte-Carlo alike.
May import: ``manipdyn.model``, ``manipdyn._support``.
"""

from .data import Measurements, read_measurements, write_measurements_csv
from .read import read_log

__all__ = ["Measurements", "read_log", "read_measurements", "write_measurements_csv"]
