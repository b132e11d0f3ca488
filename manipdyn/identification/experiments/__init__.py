"""Experiments: trajectories to log, and logs made without a robot.

Layer 5 (identification), room ``experiments``, beside the door ``pipeline``: its demo runs
the whole chain (fit, then score on held-out data).  May import: every room but ``pipeline`` and the
layers below identification.

* ``trajectory``: optimised Fourier-series excitation (Swevers et al. 1997); ``ptp``: point-to-point
  runs with rests; ``motion_limits``: the limits both keep;
* ``synthesize``: torques of a model along a trajectory, with noise; ``static_friction``: a truth that
  holds a torque within its static band at rest;
* ``hardlog``: synthetic logs with the traps of real ones (motor side, coupling, currents);
* ``demo``: the seeded identification demo; ``calibration``: are the error bars right.
"""
