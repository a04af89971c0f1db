"""Hypothesis profiles (registered and loaded by tests/conftest.py).

* ``ci`` (default): derandomized, no example database, no deadline: every run of the
  suite draws the same examples, so CI is reproducible and a failure is a regression.
* ``random``: 10^4 fresh random examples per property (``make test-random``); a failure
  prints the reproducing blob.

Select with the environment variable HYPOTHESIS_PROFILE.  ``examples(n)`` is a test's
example count: n under ``ci`` (its CI budget), the profile's count otherwise (capped
per test for slow references, e.g. ``examples(6, cap=200)``).
"""
from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

PROFILE = os.environ.get("HYPOTHESIS_PROFILE", "ci")
_HEALTH = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much]

settings.register_profile("ci", max_examples=50, derandomize=True, database=None, deadline=None,
                          suppress_health_check=_HEALTH)
settings.register_profile("random", max_examples=10_000, derandomize=False, database=None, deadline=None,
                          suppress_health_check=_HEALTH, print_blob=True)


def load():
    settings.load_profile(PROFILE)


def examples(n_ci: int, cap: int | None = None) -> int:
    if PROFILE == "ci":
        return n_ci
    n = settings.get_profile(PROFILE).max_examples
    return min(n, cap) if cap else n
