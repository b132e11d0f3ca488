"""Uncertainty: how far a fit's parameters and predictions can be trusted.

Layer 5 (identification), room ``uncertainty``.  May import: rooms ``inputs`` and ``estimation``
and the layers below identification; not ``payload`` (its sibling).

* ``bootstrap``: a moving-block bootstrap of a fit, locally or on Dask;
* ``bands``: prediction bands from blocked hold-outs of the fit data;
* ``coverage``: the states a fit saw, and the joints new data extrapolates.
"""
