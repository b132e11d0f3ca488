"""Estimation: the parameters of an arm from its regressor and its torques.

Layer 5 (identification), room ``estimation`` (the bottom room).  May import: the layers below
identification (``check``, ``engines``, ``formats``, ``model``, ``_support``); no other room.

* ``base``: the identifiable combinations (QR with pivoting);
* ``fitting``: :func:`~manipdyn.identification.fit` (``ols``, ``wls``, ``consistent``), the joints' noise and weights;
* ``factors``: least squares on each joint's triangular factor (the small problems a fit solves);
* ``sdp``: the physically consistent fit (J_i >= 0, cvxpy with Clarabel or SCS);
* ``varpro``: friction shapes by variable projection;
* ``selection``: the prior weight chosen by blocked cross-validation;
* ``covariance``: the covariance of the base parameters and how it is read;
* ``model``: the identified arm (a DH arm with new links, a URDF arm with new inertials);
* ``report``: a fit's summary (the figures of ``--json`` and the text table).
"""
