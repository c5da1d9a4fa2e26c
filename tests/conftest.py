"""Test-suite configuration shared by every test.

- DDS stays on loopback and each run uses its own ROS_DOMAIN_ID (set by ``./run test``;
  set here too so a bare ``pytest`` behaves the same).
- hypothesis: a derandomised profile without deadlines (the machines are shared and
  noisy, so no test may depend on wall time). ``HYPOTHESIS_PROFILE=dev`` explores more.
"""

from __future__ import annotations

import os
import random

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(100 + random.randrange(100)))
_BASE_DOMAIN = int(os.environ["ROS_DOMAIN_ID"])
os.environ.setdefault("MPLBACKEND", "Agg")

import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

settings.register_profile(
    "ci",
    derandomize=True,
    deadline=None,
    max_examples=200,
    suppress_health_check=[HealthCheck.too_slow],
    print_blob=True,
)
settings.register_profile("dev", deadline=None, max_examples=2000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(autouse=True, scope="module")
def _ros_domain_per_module(request):
    """Each test module talks in its own ROS domain (the run's base + a per-module offset),
    so a node that another module left shutting down can never answer in its place."""
    import zlib

    offset = zlib.crc32(request.module.__name__.encode()) % 29
    previous = os.environ["ROS_DOMAIN_ID"]
    os.environ["ROS_DOMAIN_ID"] = str((_BASE_DOMAIN + offset) % 230 + 1)
    yield
    os.environ["ROS_DOMAIN_ID"] = previous
