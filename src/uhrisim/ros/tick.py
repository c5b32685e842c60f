"""What a simulation tick becomes in ROS: the one place both outputs turn a
:class:`~uhrisim.sim.hooks.TickFrame` into :class:`~uhrisim.ros.writer.RosWriter` calls.

The recording's hook (:class:`uhrisim.record.McapRecordingHook`) and the live bridge's
(:class:`uhrisim.bridges.ros2.Ros2BridgeHook`) each decide *when* (the recorder every
N-th tick and ping, the bridge at its rates in simulated time); :class:`TickWriter`
decides *what*: each agent under its ROS name (:func:`~uhrisim.ros.topics.ros_name`), each
sensor under its own name, the products of a ping formed only for a topic that is wanted
(the fan image and the hit cloud cost time). It reads the frame and the simulation by
attribute (duck typing), so it needs no simulation import.
"""

from __future__ import annotations

import logging
import numbers
from collections.abc import Iterable, Mapping
from typing import Any

from uhrisim.core.errors import ConfigError
from uhrisim.ros.convert import label_image_mono8
from uhrisim.ros.markers import (
    decimate_triangle_markers,
    perception_markers,
    scene_markers,
    sensor_mounts,
)
from uhrisim.ros.topics import ros_name
from uhrisim.ros.writer import RosWriter
from uhrisim.sensors.sonar.cloud import cloud_hits

log = logging.getLogger(__name__)


class TickWriter:
    """Writes the products of simulation ticks through ``out`` for the agents ``agents``
    (simulation names; None: every agent met), each under its ROS name."""

    def __init__(self, out: RosWriter, agents: Iterable[str] | None = None) -> None:
        self.out = out
        self.linked = None if agents is None else frozenset(agents)
        self._names: dict[str, str | None] = {}
        self._team: Any = None  # the teamwork stage (uhrisim.sim.teamwork)
        self._workspace: Any = None  # its objects

    def ros(self, agent: str) -> str | None:
        """The ROS name ``agent`` is written under (None: not written)."""
        try:
            return self._names[agent]
        except KeyError:
            pass
        name = None if self.linked is not None and agent not in self.linked else ros_name(agent)
        if name is not None and name in self._names.values():
            raise ConfigError(f"agent {agent!r} collides as ROS name {name!r} with another")
        if name is not None and name != agent:
            log.info("agent %r is written as %r (ROS name rules)", agent, name)
        self._names[agent] = name
        return name

    def start(self, sim: Any, scene: bool = True, max_triangles: int | None = None) -> None:
        """At the start of a run: every agent's sensor mounts on ``tf_static`` and, with
        ``scene``, the static scene on ``scene/markers`` (``max_triangles``: thinned to
        at most this many triangles per object, for live viewers)."""
        t = float(getattr(sim, "t", 0.0))
        agents = getattr(sim, "agents", {})
        self._team = getattr(sim, "team", None)
        self._workspace = getattr(self._team, "workspace", None)
        mounts = []
        for name, agent in agents.items():
            ros = self.ros(name)
            if ros is not None:
                mounts += sensor_mounts(agent, self.out.agent(ros).frame)
        if mounts:
            self.out.write_static_transforms(t, mounts)
        if scene and getattr(sim, "scene", None) is not None:
            markers = scene_markers(sim.scene)
            if max_triangles is not None:
                markers = decimate_triangle_markers(markers, max_triangles)
            if markers:
                self.out.write_scene_markers(t, markers)

    def odometry(self, t: float, agents: Mapping[str, Any],
                 which: Iterable[str] | None = None) -> None:
        """The odometry (and pose, tf) at ``t`` of the agents ``which`` (None: all
        written) from the frame's snapshots ``agents``."""
        for name in agents if which is None else which:
            ros = self.ros(name)
            if ros is not None:
                nav = agents[name].nav
                self.out.write_odometry(ros, t, nav.position_ned, nav.yaw,
                                        nav.velocity_body, nav.yaw_rate)

    def objects(self, t: float) -> None:
        """Every tool and load of the teamwork world (none without one) as a frame on
        ``tf``, ``map -> <object>``, where it is now: resting, falling, or carried; and
        every link of an articulated diver written, ``map -> <agent>/<link>``
        (``TeamStage.link_frames``)."""
        if self._workspace is None:
            return
        frames = [(ros_name(name), thing.pose[:3, 3], thing.pose[:3, :3])
                  for name, thing in self._workspace.things.items()]
        for frame, position, rotation in self._team.link_frames():
            agent, _, link = frame.partition("/")
            ros = self.ros(agent)
            if ros is not None:
                frames.append((f"{ros}/{link}", position, rotation))
        self.out.write_object_transforms(t, frames)

    def joints(self, t: float, joints: Mapping[str, Any]) -> None:
        """The articulated divers' joints (``TickFrame.joints``) on
        ``<agent>/joint_states``."""
        for name, sample in joints.items():
            ros = self.ros(name)
            if ros is not None:
                self.out.write_joint_state(ros, t, sample.names, sample.position,
                                           sample.velocity)

    def ping(self, key: str, ping: Any, images: bool = True, points: bool = True) -> None:
        """The ping of the sonar ``key`` (``"<agent>/<sonar>"``): its images (with
        ``images``: polar, fan, ProjectedSonarImage), hits (with ``points``) and pose;
        the fan and the hits formed only when their topics are wanted."""
        agent, _, sonar = key.partition("/")
        ros = self.ros(agent)
        if ros is None:
            return
        a, out = self.out.agent(ros), self.out
        polar = ping.polar_u8 if images and out.wants(a.topic(f"{sonar}/polar")) else None
        fan = ping.fan_u8 if images and out.wants(a.topic(f"{sonar}/fan")) else None
        hits, intensity = (cloud_hits(ping.cloud) if points
                           and out.wants(a.topic(f"{sonar}/points")) else (None, None))
        t = float(ping.t)
        out.write_sonar(ros, sonar, t, polar, fan, hits, intensity,
                        (ping.position_ned, ping.rotation_ned_from_sonar))
        if images and out.wants(a.topic(f"{sonar}/image")):
            out.write_sonar_image(ros, sonar, t, ping.polar_u8, ping.beam_angles_rad,
                                  ping.bin_ranges_m, ping.info.frequency_hz,
                                  ping.info.sound_speed_m_s)

    def perception(self, key: str, t: float, seen: Any, ping: Any) -> None:
        """What perception made of the ping ``key``: ``<agent>/perception/detections``
        and ``tracks`` at the sonar's depth (:func:`~uhrisim.ros.markers.perception_markers`)."""
        ros = self.ros(key.partition("/")[0])
        if ros is None:
            return
        detections, tracks = perception_markers(seen, float(ping.position_ned[2]))
        self.out.write_markers(f"{ros}/perception/detections", t, detections)
        self.out.write_markers(f"{ros}/perception/tracks", t, tracks)

    def image(self, key: str, image: Any) -> None:
        """The frame of the camera ``key`` (``"<agent>/<camera>"``)."""
        agent, _, camera = key.partition("/")
        ros = self.ros(agent)
        if ros is not None:
            self.out.write_camera(ros, camera, float(image.t), image.rgb, image.depth_m,
                                  label_image_mono8(image.labels), image.K,
                                  (image.position_ned, image.rotation_ned_from_camera))

    def helm(self, agent: str, t: float, h: Any) -> None:
        """A helm decision: the desired values and mode, and the whole decision."""
        ros = self.ros(agent)
        if ros is None:
            return
        self.out.write_helm_topics(ros, t, h.heading_deg, h.speed, h.depth, h.mode)
        self.out.write_helm_decision(ros, t, h.heading_deg, h.speed, h.depth,
                                     h.contributions, h.mode, h.active, total=h.total,
                                     all_stop_reason=h.all_stop_reason or "")

    def posts(self, posts: Iterable[Any]) -> None:
        """Community postings on ``<agent>/vars``."""
        for post in posts:
            ros = self.ros(post.community)
            if ros is not None:
                value = post.value  # a str or a float, as communities keep them
                if not isinstance(value, str | float):  # (the cheap test first)
                    value = value if isinstance(value, numbers.Real) else str(value)
                self.out.write_variable(ros, float(post.t), str(post.var), value,
                                        str(post.source))

    def events(self, events: Iterable[Any]) -> None:
        """Simulation events on ``events``."""
        for ev in events:
            self.out.write_event(float(ev.t), str(ev.kind), str(ev.detail))
