"""Identification of an arm's inertial parameters from its own joint data.

Layer: application (identification).

* :func:`base_parameters`: the identifiable combinations (QR with pivoting);
* :func:`excitation`: an optimised Fourier-series excitation trajectory;
* :func:`fit`: ``ols``, ``wls`` and the physically consistent ``consistent``
  (J_i >= 0, cvxpy with Clarabel or SCS), returning the identified arm;
* :func:`read_log`: measurement logs as they come (CSV with any column names,
  degrees, motor side, uneven time stamps; ROS bags), with zero-phase
  derivatives of q and notes on what was done; :func:`read_measurements` is
  its CSV shorthand.

Needs the ``identify`` extra (scipy, cvxpy, clarabel, scs):
``pip install 'manipdyn[identify]'``.
"""

from ._deps import INSTALL, MissingExtraError
from .base import BaseParameters, base_parameters
from .data import Measurements, read_measurements, write_measurements_csv
from .estimation import METHODS, FitResult, fit
from .logs import read_log
from .report import format_report
from .sdp import Bounds
from .trajectory import Excitation, excitation

__all__ = ["BaseParameters", "Bounds", "Excitation", "FitResult", "INSTALL", "METHODS",
           "Measurements", "MissingExtraError", "base_parameters", "excitation", "fit",
           "format_report", "read_log", "read_measurements", "write_measurements_csv"]
