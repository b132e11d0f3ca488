"""The engines: the same calls answered by independent formulations.

Layer 3 (engines).  ``protocol`` (:class:`DynamicsEngine`, what every engine answers),
``lagrange/`` (the trace form of chapter II, its closed-form derivatives and
its own coding of the drive) and ``pinocchio/`` (RNEA, CRBA, ABA and their
analytical derivatives, the fast path, and the proof that Pinocchio read the
same arm as manipdyn before it is used), ``c/`` (the generated C: the recursive
algorithms as CasADi graphs, emitted as C99, compiled and called as an engine), ``mujoco/`` (MuJoCo on the
arm's own MJCF), and ``linearize`` (``arm.linearize``:
A and B of x = (q, qd) from any engine's forward-dynamics derivatives).  The engines share no code with each
other: ``lagrange``, ``pinocchio``, ``c`` and ``mujoco`` never import one another.
May import: ``manipdyn.formats`` (the URDF and MJCF writers), ``manipdyn.model``,
``manipdyn._support``.
"""
