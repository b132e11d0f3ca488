"""The checks that hold the engines and the descriptions to each other.

Layer 4 (checks).  ``crosscheck`` (``md.crosscheck``: every engine against every other,
through the :class:`~manipdyn.engines.protocol.DynamicsEngine` protocol only),
``scale`` (arms as text for Dask workers, and the chunk engine shared by big
cross-checks and Monte-Carlo studies) and ``compare/`` (``md.compare``: are two
descriptions the same arm?).
May import: ``manipdyn.engines``, ``manipdyn.formats``, ``manipdyn.model``, ``manipdyn._support``.
"""
