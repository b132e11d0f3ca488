"""The model: what an arm is, in the chapter's terms, and nothing about files or engines.

Layer 1 (model).  ``kinematics`` (eq. 2.1 to 2.8), ``inertia`` (``LinkInertia``, the
pseudo-inertia ``J`` of eq. 2.20/2.21 and every conversion between inertia
conventions), ``links`` (``DHLink``, ``ChainJoint``), ``arm`` (``Arm``,
``Manipulator``, ``URDFArm``: immutable descriptions) with ``registry`` (the
registry the engines plug into) and ``dh_chain`` (a DH table as a URDF-ready chain), ``parameters`` (the vector ``pi`` of ``tau = Y pi``),
``drive`` and ``friction`` (motors to joints; the friction law in
``friction_law``, the joint at rest in ``friction_rest``) with ``friction_jacobian``, ``variants`` (an arm with a payload or scaled inertias)
and ``random_arms`` (seeded physical arms for tests and benchmarks).
May import: ``manipdyn._support``.
"""
