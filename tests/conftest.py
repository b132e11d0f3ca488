"""Shared test configuration: Hypothesis profiles and the random-arm fixture.

Hypothesis profiles, chosen with the environment variable ``HYPOTHESIS_PROFILE``:

* ``ci``: derandomised (the same examples on every run and every machine, so a
  CI failure reproduces locally), few examples so the whole suite stays within
  about a minute on two cores, no deadline (the plain-loop reference of an
  8-joint arm takes ~0.1 s per state), and the reproduction blob printed.
* ``dev`` (default): random examples, more of them, no deadline.

The arm builders themselves live in ``tests/arms.py`` so that the benchmark
can import them too; ``random_arm`` below is the same function as a fixture.
"""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, settings

import arms

settings.register_profile(
    "ci",
    derandomize=True,
    max_examples=25,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "dev",
    max_examples=100,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "dev"))


@pytest.fixture
def random_arm():
    """``random_arm(seed, n=None, convention=None, ...)``: see :func:`arms.random_arm`."""
    return arms.random_arm
