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
os.environ.setdefault("MPLBACKEND", "Agg")

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
