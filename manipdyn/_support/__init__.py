"""Support: what every layer may use, and which imports nothing of manipdyn.

Layer 0 (support), the bottom.  ``errors`` (``ModelError``, ``StateError``, the warnings),
``files`` (atomic writes), ``state`` (validation of ``q, qd, qdd, tau`` at the
boundary), ``limits`` (the caps that keep hostile input from exhausting the
process, public as ``md.limits``), ``threads`` (BLAS threads), ``deps`` (the
message of a missing optional extra), ``figures`` (matplotlib, atomic
saving) and ``interrupt`` (Ctrl-C while the command imports).  May import: the standard library, NumPy, and itself.
"""
