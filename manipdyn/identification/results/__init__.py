"""Results: an identification saved, reported, carried and scored on new data.

Layer 5 (identification), room ``results``, under ``pipeline`` and ``experiments``.  May import:
rooms ``uncertainty``, ``payload``, ``inputs`` and ``estimation`` and the layers below identification.

* ``result``: :class:`~manipdyn.identification.IdentifyResult` (save, report, score);
* ``provenance``: the trust data a model carries (band, fitted range, data);
* ``basemodel``: the base-model JSON; ``scoring`` and ``validation``: ``validate``;
* ``comparison``: several models side by side; ``logged``: a log's own torque (a controller's target) as one more;
* ``doubts``: what the fit should have doubted.
"""
