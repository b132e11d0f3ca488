"""Identification of an arm's inertial parameters from its own joint data.

Layer 5 (identification).  May import: ``manipdyn.check``, ``manipdyn.engines``,
``manipdyn.formats`` (the log readers), ``manipdyn.model``, ``manipdyn._support``; never ``control``.

* :func:`base_parameters`: the identifiable combinations (QR with pivoting);
* :func:`excitation`: an optimised Fourier-series excitation trajectory;
  :func:`point_to_point`: a run through postures with rests (``manipdyn excite --ptp``);
* :func:`fit`: ``ols``, ``wls`` and the physically consistent ``consistent``
  (J_i >= 0, cvxpy with Clarabel or SCS), returning the identified arm;
* :func:`read_log`: measurement logs as they come (CSV with any column names,
  degrees, motor side, uneven time stamps; ROS bags), with zero-phase
  derivatives of q and notes on what was done; :func:`read_measurements` is
  its CSV shorthand.
* :func:`identify_payload`: the ten parameters of a payload carried by a known arm
  (J >= 0), :class:`PayloadResult`; :func:`write_payload_report` its HTML page;
* :func:`bootstrap`: a moving-block bootstrap of a fit (refits on data resampled in
  blocks of time), in this process or on Dask, bit-identical;
* :func:`calibrate_band` (:class:`PredictionBand`): a 95 % band from blocked hold-outs of
  the fit data; :func:`fitted_range` (:class:`StateRange`): the states a fit saw, against
  which new data is checked for extrapolation;
* :func:`identify` and :func:`validate`: the pipelines of ``manipdyn identify`` and
  ``manipdyn validate`` (several logs, RUNS.toml, known payloads, torque constants from
  currents), with the command line's options and defaults; :class:`IdentifyResult`
  saves, reports and scores itself;
* :func:`synthesize`: torques of a model along a trajectory, with noise (a log
  without a robot; ``manipdyn synthesize``).

Needs the ``identify`` extra (scipy, cvxpy, clarabel, scs):
``pip install 'manipdyn[identify]'``.
"""

from .._support.deps import INSTALL, MissingExtraError
from .uncertainty.bands import PredictionBand, calibrate_band
from .estimation.base import BaseParameters, base_parameters
from .uncertainty.coverage import StateRange, fitted_range
from .uncertainty.bootstrap import BootstrapResult, bootstrap
from ..formats.logs.data import Measurements, read_measurements, write_measurements_csv
from .estimation.fitting import METHODS, FitResult, fit
from .experiments.hardlog import HardLog, hard_log
from ..formats.logs.read import read_log
from .payload.fit import PayloadResult, identify_payload
from .estimation.report import format_report
from .estimation.sdp import Bounds
from .experiments.synthesize import Trajectory, read_trajectory, synthesize
from .experiments.trajectory import Excitation, excitation
from .experiments.ptp import PointToPoint, point_to_point
from .estimation.varpro import fit_friction_shapes
from .pipeline import identify
from .results.result import IdentifyResult
from .inputs.runs import LogSpec, Payload, read_runs_file
from .results.scoring import Validation, validate
from .results.payload_html import write_payload_report
from .payload.torque_constants import TorqueConstants, identify_torque_constants

__all__ = ["BaseParameters", "BootstrapResult", "Bounds", "Excitation", "FitResult", "INSTALL", "METHODS",
           "Measurements", "MissingExtraError", "PayloadResult", "base_parameters", "bootstrap", "excitation", "fit",
           "format_report", "fit_friction_shapes", "HardLog", "hard_log", "identify_payload", "write_payload_report", "read_log",
           "read_measurements", "write_measurements_csv",
           "Trajectory", "read_trajectory", "synthesize", "PointToPoint", "point_to_point", "PredictionBand", "calibrate_band", "StateRange",
           "fitted_range", "identify", "IdentifyResult", "LogSpec", "Payload",
           "read_runs_file", "Validation", "validate", "TorqueConstants", "identify_torque_constants"]
