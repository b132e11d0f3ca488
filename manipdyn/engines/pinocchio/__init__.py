"""The fast path: Pinocchio's RNEA, CRBA and ABA on the arm's URDF.

Layer 3 (engines: pinocchio).  ``engine`` (``PinocchioEngine``), ``fast`` (the unchecked
view for control loops), ``derivatives`` (Pinocchio's analytical derivatives),
``urdf_model`` (Pinocchio's model of an arm), ``threads`` (one thread or all for a batch)
and ``agree`` (Pinocchio's reading of the URDF compared with manipdyn's own
before the engine serves: an engine that read another arm must refuse, so this
check is part of building the engine, not of the cross-check above it).
May import: ``manipdyn.engines.protocol``, ``manipdyn.formats``, ``manipdyn.model``,
``manipdyn._support``.
"""
