"""Creating publishers, handing messages to DDS, and the bridge's statistics: messages,
failures and incompatible subscribers per topic.

A subscriber whose QoS cannot match a publisher's (a reliable subscription to a
best-effort topic, the ROS default meeting the sensor-data convention) receives nothing;
DDS only tells the publisher. Every publisher made here counts such subscribers per topic
and says so through the node's logger (so on ``/rosout``), with what to do.

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
        self._incompatible: dict[str, int] = {}  # counted on the executor thread
        self._matched: dict[str, int] = {}  # readers matched now, set on the executor thread

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

    def create(self, node: Any, msg_type: type, topic: str, qos: Any) -> Any:
        """A publisher on ``node`` whose incompatible subscribers are counted and reported
        (see the module docstring)."""
        from rclpy.event_handler import PublisherEventCallbacks
        from rclpy.qos import ReliabilityPolicy

        resolved = node.resolve_topic_name(topic)
        hint = ("; it should subscribe best effort (rclpy's qos_profile_sensor_data), or "
                "start the bridge with -p sensor_qos:=reliable (sonar) or -p "
                "clock_qos:=reliable (/clock)"
                if qos.reliability == ReliabilityPolicy.BEST_EFFORT else "")
        logger = node.get_logger()

        def incompatible(info: Any) -> None:
            self._incompatible[resolved] = self._incompatible.get(resolved, 0) + 1
            logger.warning(f"a subscriber to {resolved} asks for a QoS this publisher cannot "
                           f"offer ({info.last_policy_kind.name}): it receives nothing{hint}")

        def matched(info: Any) -> None:
            self._matched[resolved] = info.current_count

        return node.create_publisher(msg_type, topic, qos, event_callbacks=
                                     PublisherEventCallbacks(incompatible_qos=incompatible,
                                                             matched=matched))

    def matched_readers(self, topic: str) -> int:
        """How many subscriptions DDS has matched with the publisher of ``topic`` (resolved
        name): later than the graph shows them; a message written before is lost to them."""
        return self._matched.get(topic, 0)

    def stats(self) -> dict[str, dict[str, int]]:
        """Messages published, writes failed and incompatible subscribers seen, per topic
        (copies)."""
        return {"published": self._counts.copy(), "failed": self._failed.copy(),
                "incompatible_qos": self._incompatible.copy()}

    @property
    def failing_topics(self) -> tuple[str, ...]:
        """The topics on which a write has failed so far, in the order they first failed."""
        return tuple(self._failed)
