"""Inputs: the runs a fit reads and the options it is given.

Layer 5 (identification), room ``inputs``.  May import: room ``estimation`` and the layers below
identification.

* ``runs``: several logs, RUNS.toml, known payloads (:class:`~manipdyn.identification.LogSpec`,
  :class:`~manipdyn.identification.Payload`);
* ``options``: the options checked, friction specs and bounds;
* ``choices``: what the log decides when the user does not (friction side, Coulomb smoothing);
* ``smoothing``: the Coulomb smoothing chosen by blocked held-out error;
* ``rest``: the joints at rest (a threshold from the velocity's noise) and their static friction levels.
"""
