"""URDF: safe XML with URDF's number grammar (``xml``), the link/joint tree
(``tree``), chains read from a file (``reader``) and arms written as URDF (``writer``).

Layer 2 (formats: urdf).  May import: ``manipdyn.model``, ``manipdyn._support``.
"""
