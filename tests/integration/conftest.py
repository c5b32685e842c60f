"""Shared fixtures of the integration tests."""

from __future__ import annotations

import random

import pytest

from tests.support import ros2_shm
from tests.support.ros2_domains import worker_domain_ids


@pytest.fixture(scope="module")
def ros_env(tmp_path_factory: pytest.TempPathFactory):
    """Loopback discovery, a private random domain id (1-101, this worker's share:
    :func:`worker_domain_ids`), logs in a temp folder; afterwards, remove the Fast DDS
    shared-memory files this module's killed children left (new since the start, owner
    dead)."""
    before = ros2_shm.shm_snapshot()
    mp = pytest.MonkeyPatch()
    domain = random.SystemRandom().choice(worker_domain_ids())
    mp.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    mp.setenv("ROS_DOMAIN_ID", str(domain))
    mp.setenv("ROS_LOG_DIR", str(tmp_path_factory.mktemp("roslog")))
    yield domain
    mp.undo()
    ros2_shm.clean_zombie_shm(before)
