"""The one API that writes uhrisim's products as ROS 2 messages: :class:`RosWriter`.

Its ``write_*`` methods take uhrisim's products in uhrisim's frames (NED, FRD), check
them, and for each message whose topic is wanted translate them with
:mod:`uhrisim.ros.messages` / :mod:`uhrisim.ros.markers` and hand the bytes to
``_emit``. Two outputs subclass it and only say where the bytes go: the recording
(:class:`uhrisim.record.McapRecorder`, an MCAP file: every topic is wanted) and the live
bridge (:class:`uhrisim.bridges.ros2.Ros2Bridge`, DDS: a volatile topic is wanted while
someone subscribes). Names, types, frames and contents are therefore the same in both.

Topics are relative (``"videoray/odom"``, :mod:`uhrisim.ros.topics`). Time ``t`` is
simulation time (s), every stamp the same. A sensor frame placed by
:meth:`RosWriter.write_static_transforms` (a sonar's, a camera's optical frame: the
mounts) is not written on ``tf`` at each ping or picture; without one, each puts
``map -> sensor frame`` there.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from uhrisim.core.errors import ConfigError
from uhrisim.ros import messages as msg
from uhrisim.ros import uhrisim_msgs
from uhrisim.ros.convert import pose_enu_from_ned
from uhrisim.ros.markers import markers as marker_array
from uhrisim.ros.topics import (
    CAMERA_TOPICS,
    DESIRED_KEYS,
    GLOBAL_TOPICS,
    JOINT_STATE,
    SONAR_TOPICS,
    WORLD_FRAME,
    QosKind,
)


class RosWriter:
    """Writes uhrisim's products as ROS 2 messages (module docstring). Subclasses define
    :meth:`_emit` (where the bytes go) and may refine :meth:`wants`.

    ``world_frame``: the ENU world frame id (REP-105 ``map``); ``frame_prefix``: put
    before every agent's frames (``"sim_a/"``: ``sim_a/rov/base_link``)."""

    def __init__(self, world_frame: str = WORLD_FRAME, frame_prefix: str = "") -> None:
        self.world_frame = msg.check_frame(world_frame, type(self).__name__)
        self.frame_prefix = frame_prefix
        self._agents: dict[str, msg.AgentMessages] = {}
        self._static_children: set[str] = set()  # frames placed by /tf_static
        self._helm_modes: dict[str, str] = {}  # the last helm/mode written per agent

    # ------------------------------------------------------------------ the output
    def _emit(self, topic: str, typename: str, qos: QosKind, t_ns: int, data: bytes) -> None:
        """Write one serialised message ``data`` of ``typename`` on ``topic``."""
        raise NotImplementedError

    def wants(self, topic: str) -> bool:
        """Whether a message on ``topic`` would go anywhere (the recording: always)."""
        del topic
        return True

    def _check_open(self, where: str) -> None:
        """Raise if nothing can be written any more."""

    def agent(self, name: str, where: str = "RosWriter") -> msg.AgentMessages:
        """The message builder of the agent ``name`` (its ROS name)."""
        out = self._agents.get(name)
        if out is None:
            msg.check_name(name, "agent", where)
            out = self._agents[name] = msg.AgentMessages(name, self.world_frame,
                                                         self.frame_prefix)
        return out

    def frame(self, agent: str, name: str) -> str:
        """The full name of one of ``agent``'s frames (``"base_link"``, a sonar's name,
        a camera's ``"<camera>_optical"``)."""
        return self.agent(agent).frame(name)

    def _begin(self, where: str, t: float) -> tuple[int, int, int]:
        self._check_open(where)
        t_ns = msg.stamp_ns(t, f"{type(self).__name__}.{where}")
        sec, nanosec = msg.split_stamp(t_ns)
        return t_ns, sec, nanosec

    # ------------------------------------------------------------------ writers
    def write_clock(self, t: float) -> None:
        """``clock`` (rosgraph_msgs/Clock): simulation time ``t`` (s)."""
        t_ns, sec, nanosec = self._begin("write_clock", t)
        if self.wants("clock"):
            self._emit("clock", *GLOBAL_TOPICS["clock"], t_ns, msg.clock(sec, nanosec))

    def write_odometry(self, agent: str, t: float, position_ned: Any, yaw_rad: float,
                       velocity_body_frd: Any, yaw_rate: float) -> None:
        """An agent's pose and velocity: ``<agent>/odom`` (nav_msgs/Odometry),
        ``<agent>/pose`` (geometry_msgs/PoseStamped) and ``tf`` ``map`` ->
        ``<agent>/odom`` (identity) -> ``<agent>/base_link`` (REP 105).

        ``position_ned`` (m, world NED), ``yaw_rad`` (compass yaw, rad),
        ``velocity_body_frd`` (m/s, body FRD: surge, sway, heave), ``yaw_rate`` (rad/s,
        clockwise from above). Written as pose in ENU, twist in the FLU child frame
        (REP-103). Roll and pitch are zero (conventions); covariances 0 (ground truth).
        """
        where = f"{type(self).__name__}.write_odometry"
        t_ns, sec, nanosec = self._begin("write_odometry", t)
        a = self.agent(agent, where)
        f = msg.odometry_fields(position_ned, yaw_rad, velocity_body_frd, yaw_rate, where)
        if self.wants(odom := a.topic("odom")):
            self._emit(odom, "nav_msgs/msg/Odometry", "state", t_ns,
                       a.odometry(sec, nanosec, f))
        if self.wants(pose := a.topic("pose")):
            self._emit(pose, "geometry_msgs/msg/PoseStamped", "state", t_ns,
                       a.pose(sec, nanosec, f.position_enu, f.orientation_xyzw))
        if self.wants("tf"):
            self._emit("tf", *GLOBAL_TOPICS["tf"], t_ns, a.tf(sec, nanosec, f))

    def write_joint_state(self, agent: str, t: float, names: Sequence[str], position: Any,
                          velocity: Any) -> None:
        """An articulated diver's joints on ``<agent>/joint_states``
        (sensor_msgs/JointState, frame ``<agent>/base_link``): angles (rad) and rates
        (rad/s) in the order of ``names``."""
        where = f"{type(self).__name__}.write_joint_state"
        t_ns, sec, nanosec = self._begin("write_joint_state", t)
        a = self.agent(agent, where)
        if self.wants(topic := a.topic("joint_states")):
            self._emit(topic, JOINT_STATE, "state", t_ns,
                       msg.joint_state(sec, nanosec, a.frame("base_link"), names, position,
                                       velocity))

    def write_object_transforms(self, t: float,
                                objects: Iterable[tuple[str, Any, Any]]) -> None:
        """Where movable objects (tools, loads) are: ``tf`` ``map -> <object>``, one
        message of every ``(name, position_ned (3,) m, rotation (3x3) object -> NED)``
        (the object's own axes as FRD, written FLU as the scene markers are)."""
        where = f"{type(self).__name__}.write_object_transforms"
        t_ns, sec, nanosec = self._begin("write_object_transforms", t)
        rows = []
        for name, position_ned, rotation_ned in objects:
            frame = msg.check_frame(f"{self.frame_prefix}{name}", where)
            rows.append((sec, nanosec, self.world_frame, frame,
                         *pose_enu_from_ned(position_ned, rotation_ned)))
        if rows and self.wants("tf"):
            self._emit("tf", *GLOBAL_TOPICS["tf"], t_ns, msg.transforms(rows))

    def write_static_transforms(self, t: float,
                                transforms: Sequence[tuple[str, str, Any, Any]]) -> None:
        """``tf_static`` (one message with every static transform): each ``(parent,
        child, position_frd (3,) m, rotation_frd (3x3) child -> parent)`` in body FRD
        terms, written in FLU (e.g. a sonar mount ``("rov/base_link", "rov/sonar", ...)``;
        :func:`uhrisim.ros.markers.sensor_mounts`)."""
        where = f"{type(self).__name__}.write_static_transforms"
        t_ns, sec, nanosec = self._begin("write_static_transforms", t)
        data = msg.static_transforms(sec, nanosec, transforms, where)
        self._static_children |= {child for _, child, _, _ in transforms}
        self._emit("tf_static", *GLOBAL_TOPICS["tf_static"], t_ns, data)

    def _sensor_on_tf(self, t_ns: int, sec: int, nanosec: int, frame: str, p_enu: Any,
                      q: Any) -> None:
        """``map -> frame`` on ``tf`` unless the frame's mount is on ``tf_static``."""
        if frame not in self._static_children and self.wants("tf"):
            self._emit("tf", *GLOBAL_TOPICS["tf"], t_ns,
                       msg.sensor_to_world(sec, nanosec, self.world_frame, frame, p_enu, q))

    def write_sonar(self, agent: str, sonar: str, t: float, polar_u8: Any, fan_u8: Any,
                    points_sonar_frd: Any, intensity: Any,
                    sonar_pose_ned: tuple[Any, Any]) -> None:
        """One ping of the agent's sonar named ``sonar``, in its frame
        ``<agent>/<sonar>``: ``<agent>/<sonar>/polar`` (``(n_bins, n_beams)`` uint8, row =
        range bin, column = beam) and ``fan`` (``(H, W)`` uint8), both mono8
        sensor_msgs/Image, either may be None; ``points`` (sensor_msgs/PointCloud2, x y z
        intensity float32, sonar FLU) from ``(N, 3)`` sonar-frame FRD hits with
        ``intensity`` ``(N,)`` (None: zeros; None points: none); ``pose``
        (geometry_msgs/PoseStamped in the world frame) from ``sonar_pose_ned =
        (position (3,), rotation sonar FRD -> NED (3, 3))``, and ``map -> sonar`` on
        ``tf`` when the mount is not on ``tf_static``."""
        where = f"{type(self).__name__}.write_sonar"
        t_ns, sec, nanosec = self._begin("write_sonar", t)
        a = self.agent(agent, where)
        msg.check_name(sonar, "sensor", where)
        frame = a.frame(sonar)
        p_enu, q = pose_enu_from_ned(*msg.sensor_pose(sonar_pose_ned, "sonar", where))
        images = [(key, msg.mono8(image, f"{key}_u8", where))
                  for key, image in (("polar", polar_u8), ("fan", fan_u8)) if image is not None]
        self._sensor_on_tf(t_ns, sec, nanosec, frame, p_enu, q)
        if self.wants(topic := a.topic(f"{sonar}/pose")):
            self._emit(topic, *SONAR_TOPICS["pose"], t_ns, a.pose(sec, nanosec, p_enu, q))
        for key, image in images:
            if self.wants(topic := a.topic(f"{sonar}/{key}")):
                self._emit(topic, *SONAR_TOPICS[key], t_ns, a.image(sec, nanosec, frame, image))
        if points_sonar_frd is not None and self.wants(topic := a.topic(f"{sonar}/points")):
            self._emit(topic, *SONAR_TOPICS["points"], t_ns,
                       a.cloud(sec, nanosec, sonar, points_sonar_frd, intensity))

    def write_sonar_image(self, agent: str, sonar: str, t: float, polar_u8: Any,
                          beam_angles_rad: Any, ranges_m: Any, frequency_hz: float,
                          sound_speed_m_s: float) -> None:
        """One ping as ``<agent>/<sonar>/image`` (marine_acoustic_msgs/ProjectedSonarImage):
        the polar image ``(n_bins, n_beams)`` uint8, beam azimuths (rad, > 0 starboard)
        as directions ``(0, sin, cos)`` (the message's Z forward, X up), range-bin centres
        (m), centre frequency (Hz), sound speed (m/s)."""
        where = f"{type(self).__name__}.write_sonar_image"
        t_ns, sec, nanosec = self._begin("write_sonar_image", t)
        a = self.agent(agent, where)
        msg.check_name(sonar, "sensor", where)
        data = msg.sonar_image(sec, nanosec, a.frame(sonar), polar_u8, beam_angles_rad,
                               ranges_m, frequency_hz, sound_speed_m_s, where)
        if self.wants(topic := a.topic(f"{sonar}/image")):
            self._emit(topic, *SONAR_TOPICS["image"], t_ns, data)

    def write_camera(self, agent: str, camera: str, t: float, rgb_u8: Any, depth_m: Any,
                     labels_u8: Any, K: Any, camera_pose_ned: tuple[Any, Any]) -> None:
        """One frame of the agent's camera named ``camera``, in its optical frame
        ``<agent>/<camera>_optical`` (x right, y down, z forward): ``image_raw`` (rgb8),
        ``camera_info`` (pinhole ``K``, no distortion), ``depth`` (32FC1, m along the
        optical axis, NaN where nothing was hit; REP-118) and ``labels`` (mono8: label
        id + 1, 0 for open water), each optional but the image; ``pose`` (PoseStamped of
        the optical frame) from ``camera_pose_ned = (position (3,), rotation (3, 3))``,
        the camera frame x forward, y right, z down -> NED."""
        where = f"{type(self).__name__}.write_camera"
        t_ns, sec, nanosec = self._begin("write_camera", t)
        a = self.agent(agent, where)
        msg.check_name(camera, "sensor", where)
        rgb = msg.rgb8(rgb_u8, where)
        height, width = rgb.shape[:2]
        k = msg.intrinsics(K, where)
        frame = a.camera_frame(camera)
        position, rot = msg.sensor_pose(camera_pose_ned, "camera", where)
        pose, (p_enu, q) = a.camera_pose(sec, nanosec, (position, rot))
        depth = labels = None
        if depth_m is not None:
            depth = np.asarray(depth_m, dtype="<f4")
            if depth.shape != (height, width):
                raise ConfigError(f"depth_m must have shape {(height, width)}, got "
                                  f"{depth.shape}", where=where)
        if labels_u8 is not None:
            labels = msg.mono8(labels_u8, "labels_u8", where)
            if labels.shape != (height, width):
                raise ConfigError(f"labels_u8 must have shape {(height, width)}, got "
                                  f"{labels.shape}", where=where)
        self._sensor_on_tf(t_ns, sec, nanosec, frame, p_enu, q)
        products = (("pose", lambda: pose),
                    ("image_raw", lambda: a.image(sec, nanosec, frame, rgb, "rgb8")),
                    ("camera_info", lambda: msg.camera_info(sec, nanosec, frame,
                                                            (height, width), k)),
                    ("depth", None if depth is None else
                     lambda: a.image(sec, nanosec, frame, depth, "32FC1")),
                    ("labels", None if labels is None else
                     lambda: a.image(sec, nanosec, frame, labels)))
        for key, make in products:
            if make is not None and self.wants(topic := a.topic(f"{camera}/{key}")):
                self._emit(topic, *CAMERA_TOPICS[key], t_ns, make())

    def write_helm_topics(self, agent: str, t: float, heading_deg: float | None,
                          speed: float | None, depth: float | None, mode: str) -> None:
        """The helm's decision as ``<agent>/helm/desired_heading`` (compass deg),
        ``desired_speed`` (m/s), ``desired_depth`` (m, down) (std_msgs/Float64, each
        skipped when None) and ``<agent>/helm/mode`` (std_msgs/String, latched) when it
        changes."""
        where = f"{type(self).__name__}.write_helm_topics"
        t_ns, _, _ = self._begin("write_helm_topics", t)
        a = self.agent(agent, where)
        for key, value in zip(DESIRED_KEYS, (heading_deg, speed, depth), strict=True):
            if value is None:
                continue
            if not math.isfinite(float(value)):
                raise ConfigError(f"{key} must be finite, got {value!r}", where=where)
            if self.wants(topic := a.topic(f"helm/{key}")):
                self._emit(topic, "std_msgs/msg/Float64", "state", t_ns,
                           msg.float64(float(value)))
        mode = str(mode)
        if self._helm_modes.get(agent) != mode:
            self._helm_modes[agent] = mode
            self._emit(a.topic("helm/mode"), "std_msgs/msg/String", "latched", t_ns,
                       msg.string(mode))

    def write_helm_decision(self, agent: str, t: float, heading_deg: float | None,
                            speed: float | None, depth: float | None,
                            contributions: Mapping[str, float], mode: str,
                            active: Iterable[str], *, total: float | None = None,
                            all_stop_reason: str = "") -> None:
        """One helm cycle on ``<agent>/helm/decision`` (uhrisim_msgs/HelmDecision):
        ``heading_deg`` compass degrees, ``speed`` m/s, ``depth`` m, each None when not
        decided (its ``has_*`` flag false); ``contributions`` each behavior's objective
        value at the decision, ``total`` the helm's (default: their sum), ``mode``,
        ``active`` the behaviors that produced an objective, ``all_stop_reason`` why the
        helm stopped ("" if it did not)."""
        where = f"{type(self).__name__}.write_helm_decision"
        t_ns, _, _ = self._begin("write_helm_decision", t)
        a = self.agent(agent, where)
        if self.wants(topic := a.topic("helm/decision")):
            self._emit(topic, uhrisim_msgs.HELM_DECISION, "state", t_ns, a.helm_decision(
                t_ns, heading_deg, speed, depth, contributions, mode, active, total,
                all_stop_reason, where))

    def write_variable(self, agent: str, t: float, name: str, value: float | str,
                       source: str) -> None:
        """A community variable posting on ``<agent>/vars`` (uhrisim_msgs/Variable):
        numbers (and booleans, as 0/1) as ``double_value`` with ``kind = DOUBLE``,
        strings as ``string_value`` with ``kind = STRING``."""
        where = f"{type(self).__name__}.write_variable"
        t_ns, _, _ = self._begin("write_variable", t)
        a = self.agent(agent, where)
        if self.wants(topic := a.topic("vars")):
            self._emit(topic, uhrisim_msgs.VARIABLE, "state", t_ns,
                       a.variable(t_ns, name, value, source, where))

    def write_markers(self, topic: str, t: float, specs: Sequence[Mapping[str, Any]]) -> None:
        """Marker specs (:mod:`uhrisim.ros.markers`) as one
        visualization_msgs/MarkerArray on ``topic`` (relative, e.g.
        ``"rov/perception/tracks"``), in the world frame (ENU)."""
        where = f"{type(self).__name__}.write_markers({topic})"
        t_ns, _, _ = self._begin("write_markers", t)
        data = marker_array(t_ns, specs, self.world_frame, where)
        if self.wants(topic):
            self._emit(topic, "visualization_msgs/msg/MarkerArray", "markers", t_ns, data)

    def write_scene_markers(self, t: float, specs: Sequence[Mapping[str, Any]]) -> None:
        """The scene as ``scene/markers`` (latched; specs as :meth:`write_markers`)."""
        where = f"{type(self).__name__}.write_scene_markers"
        t_ns, _, _ = self._begin("write_scene_markers", t)
        self._emit("scene/markers", *GLOBAL_TOPICS["scene/markers"], t_ns,
                   marker_array(t_ns, specs, self.world_frame, where))

    def write_event(self, t: float, kind: str, detail: str) -> None:
        """Something that happened once (``"collision"``, ``"bridge"``) on ``events``
        (uhrisim_msgs/Event)."""
        t_ns, _, _ = self._begin("write_event", t)
        if self.wants("events"):
            self._emit("events", *GLOBAL_TOPICS["events"], t_ns,
                       uhrisim_msgs.event_bytes(t_ns, self.world_frame, kind, detail))
