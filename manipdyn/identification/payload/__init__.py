"""Payload and torque constants: what an identified arm carries, and what its motors deliver.

Layer 5 (identification), room ``payload``.  May import: rooms ``inputs`` and ``estimation`` and
the layers below identification; not ``uncertainty`` (its sibling).

* ``fit``: the ten parameters of a payload carried by a known arm (J >= 0);
* ``torque_constants``: k_t per motor from currents, fitted with the arm;
* ``gravity_scale``: their scale from the prior's gravity when no payload run or k_t gives it.
"""
