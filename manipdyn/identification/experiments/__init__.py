"""Experiments: trajectories to log, and logs made without a robot.

Layer 5 (identification), room ``experiments``, beside the door ``pipeline``: its demo runs
the whole chain (fit, then score on held-out data).  May import: every room but ``pipeline`` and the
layers below identification.

* ``trajectory``: optimised Fourier-series excitation (Swevers et al. 1997);
* ``synthesize``: torques of a model along a trajectory, with noise;
* ``hardlog``: synthetic logs with the traps of real ones (motor side, coupling, currents);
* ``demo``: the seeded identification demo; ``calibration``: are the error bars right.
"""
