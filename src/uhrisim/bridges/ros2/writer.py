"""Handing messages to DDS, and the bridge's statistics: messages and failures per topic.

A volatile topic nobody subscribes to is skipped (no subscriber could receive what it
missed; the conversion and the DDS write are saved) unless the bridge publishes
unsubscribed topics too. A write that fails (the context shut down by someone else, a
full history in asynchronous publication mode) is counted per topic and logged, the
first of each topic and then every :data:`FAILURE_LOG_EVERY`-th; the simulation goes on
(nothing in the loop waits for or depends on ROS).
"""

from __future__ import annotations

import logging
from typing import Any

log = logging.getLogger(__name__)

#: A failing topic is logged on its first failed write and then on every this many.
FAILURE_LOG_EVERY = 100


class TopicWriter:
    """Writes messages to publishers and counts them, per topic; used by the simulation's
    thread only (``stats`` copies the counts)."""

    def __init__(self, publish_unsubscribed: bool = False) -> None:
        self.publish_unsubscribed = publish_unsubscribed
        self._counts: dict[str, int] = {}
        self._failed: dict[str, int] = {}

    def wanted(self, pub: Any) -> bool:
        """Should a message go to ``pub``'s topic: someone subscribed (well under 1 us)?
        A publisher that cannot tell (ROS shut down under the bridge) says yes: the write
        then fails and is counted by :meth:`write`."""
        if self.publish_unsubscribed:
            return True
        try:
            return pub.handle.get_subscription_count() > 0
        except Exception:
            return True

    def write(self, pub: Any, msg: Any, key: str) -> None:
        """Hand one message (an rclpy message, or its serialised ``bytes``) to DDS on
        ``pub``, counted under ``key`` (the topic); see the module docstring."""
        try:
            if type(msg) is bytes:  # serialised: straight to rcl (what publish() calls)
                pub.handle.publish_raw(msg)
            else:
                pub.publish(msg)
        except Exception as exc:
            failed = self._failed[key] = self._failed.get(key, 0) + 1
            if failed == 1 or failed % FAILURE_LOG_EVERY == 0:
                log.warning("ROS 2 bridge: publishing %s failed (%d so far; the simulation "
                            "goes on): %s", key, failed, exc)
            return
        counts = self._counts
        counts[key] = counts.get(key, 0) + 1

    def stats(self) -> dict[str, dict[str, int]]:
        """Messages published and writes failed per topic (copies)."""
        return {"published": self._counts.copy(), "failed": self._failed.copy()}

    @property
    def failing_topics(self) -> tuple[str, ...]:
        """The topics on which a write has failed so far, in the order they first failed."""
        return tuple(self._failed)
