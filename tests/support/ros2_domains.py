"""The ROS 2 domain ids a test module may draw (tests/integration/conftest.py, ros_env)."""

from __future__ import annotations

import os


def worker_domain_ids() -> range:
    """The ROS domain ids this pytest-xdist worker draws from: its own share of 1-101
    (above 101 Fast DDS's ports fall in the ephemeral range), so that two modules running
    at once in two workers never share a domain: in one they would read each other's
    topics (two simulators' /videoray/sonar/* stamps mixed in one listener). Without
    xdist: all of 1-101."""
    worker = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw"))
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    return range(1 + worker, 102, workers)


def spare_domain_id(domain: int) -> int:
    """Another id of this worker's share than ``domain`` (its module's, from ``ros_env``):
    for a test that needs a domain where no reader of its module's other tests is."""
    ids = worker_domain_ids()
    return ids[(ids.index(domain) + 1) % len(ids)]
