"""One agent's outgoing products: per product its publishers, rate gate and encoding.

Odometry and pose go out at the agent's odometry rate, the sonar products at its sonar
rate (both gated in simulated time), the helm's decision whenever the helm decides (its
own rate), the helm mode when it changes. Messages go out pre-serialised where that saves
time (the bytes of :mod:`.messages`' builders) and only to topics someone subscribes to
(:class:`~uhrisim.bridges.ros2.writer.TopicWriter`). Inputs are in uhrisim's frames
(NED, FRD); :mod:`.convert` turns them into ROS's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from rclpy.qos import QoSProfile

from uhrisim.record.cdr import (
    OdometryEncoder,
    PoseStampedEncoder,
    TransformEncoder,
    encode_image,
    encode_pointcloud2,
)

from .convert import (
    RateGate,
    cloud_xyzi_flu,
    odom_fields_from_ned,
    optical_rotation,
    pose_enu_from_ned,
    stamp_from_sim_time,
    tf_chain,
    tf_chain_frames,
)
from .messages import (
    WORLD_FRAME,
    camera_info_msg,
    float64_bytes,
    mono8,
    projected_sonar_image_bytes,
    string_bytes,
)
from .spec import AgentBridgeSpec
from .topics import agent_topics
from .writer import TopicWriter


class AgentPublishers:
    """The publishers, rate gates and encoders of one agent (``spec``), writing through
    ``writer``. The methods are those of :class:`~uhrisim.bridges.ros2.bridge.Ros2Bridge`
    (``publish_nav`` ...) for this agent, after the bridge has checked the call and
    advanced ``/clock``; see there for units and frames."""

    def __init__(self, spec: AgentBridgeSpec, writer: TopicWriter,
                 world_frame: str = WORLD_FRAME, frame_prefix: str = "") -> None:
        self.spec = spec
        self.writer = writer
        #: the agent's frames are ``<frame_base>/base_link``, ``/odom``, ``/sonar``
        self.frame_base = f"{frame_prefix}{spec.name}"
        self.world_frame = world_frame
        self.nav_gate = RateGate(spec.odom_rate_hz)
        self.sonar_gates = {sonar: RateGate(spec.sonar_rate_hz) for sonar in spec.sonars}
        # odometry and pose go out pre-serialised (a few us instead of ~30 us a message)
        self.odometry = OdometryEncoder(world_frame, f"{self.frame_base}/base_link")
        self.pose = PoseStampedEncoder(world_frame)
        first, *more = tf_chain_frames(self.frame_base, world_frame)
        self.tf = TransformEncoder(*first, *more)  # the /tf chain, one struct
        self.pubs: dict[str, Any] = {}  # key (the topic relative to the agent) -> publisher
        self.topics: dict[str, str] = {}  # key -> resolved topic name, once created
        self.mode_text: str | None = None  # the last helm mode published
        self.tf_pub: Any = None  # the bridge's /tf publisher (None: tf2_msgs not built)

    def create(self, node: Any, sensor_qos: QoSProfile, tf_pub: Any) -> None:
        """Create this agent's publishers on ``node`` (``sensor_qos``: sonar images, hits);
        its transforms go to ``tf_pub`` (the bridge's ``/tf``, or None)."""
        for key, topic, msg_type, qos in agent_topics(self.spec, sensor_qos):
            self.pubs[key] = self.writer.create(node, msg_type, topic, qos)
            self.topics[key] = self.pubs[key].topic_name
        self.tf_pub = tf_pub
        if tf_pub is not None:
            self.topics["tf"] = tf_pub.topic_name

    def _nav_wanted(self) -> tuple[bool, bool, bool]:
        """Whether odometry, pose and /tf have a subscriber."""
        wanted = self.writer.wanted
        tf = self.tf_pub is not None and wanted(self.tf_pub)
        return wanted(self.pubs["odom"]), wanted(self.pubs["pose"]), tf

    def nav(self, t_sim: float, position_ned: ArrayLike, yaw_rad: float,
            velocity_body_frd: ArrayLike, yaw_rate: float) -> bool:
        """Odometry and pose, if the odometry gate is due; True when they went out."""
        if not self.nav_gate.due(t_sim):
            return False
        f = odom_fields_from_ned(position_ned, yaw_rad, velocity_body_frd, yaw_rate)  # checks
        odom_wanted, pose_wanted, tf_wanted = self._nav_wanted()
        if not (odom_wanted or pose_wanted or tf_wanted):
            return False
        sec, nanosec = stamp_from_sim_time(t_sim)
        if odom_wanted:
            odom = self.odometry(sec, nanosec, f.position_enu, f.orientation_xyzw,
                                 f.linear_flu, f.angular_flu)  # the bytes of odometry_msg(...)
            self.writer.write(self.pubs["odom"], odom, self.topics["odom"])
        if pose_wanted:
            pose = self.pose(sec, nanosec, f.position_enu, f.orientation_xyzw)
            self.writer.write(self.pubs["pose"], pose, self.topics["pose"])
        if tf_wanted:
            (t0, q0), second = tf_chain(f.position_enu, f.orientation_xyzw)
            tf = self.tf(sec, nanosec, t0, q0, second)
            self.writer.write(self.tf_pub, tf, self.topics["tf"])
        return True

    def odometry_due(self, t_sim: float) -> bool:
        """Would :meth:`nav` publish at ``t_sim`` (s)? A due gate with nobody subscribed
        moves on to its next period, as if the odometry had gone out."""
        if not self.nav_gate.is_due(t_sim):
            return False
        if any(self._nav_wanted()):
            return True
        self.nav_gate.due(t_sim)  # nothing to send: pass the slot
        return False

    def sonar_subscribed(self, sonar: str) -> tuple[bool, bool, bool]:
        """Whether the polar image, the fan image and the points have a subscriber."""
        if sonar not in self.spec.sonars:
            return False, False, False
        p, wanted = self.pubs, self.writer.wanted
        return (wanted(p[f"{sonar}/polar"]), wanted(p[f"{sonar}/fan"]),
                wanted(p[f"{sonar}/points"]))

    def sonar(self, sonar: str, t_sim: float, polar_u8: np.ndarray | None,
              fan_u8: np.ndarray | None, points_sonar_frd: ArrayLike | None,
              intensity: ArrayLike | None,
              sonar_pose_ned: tuple[ArrayLike, ArrayLike] | None) -> bool:
        """The products given of the sonar named ``sonar``, if its gate is due; True when
        it was due."""
        if not self.sonar_gates[sonar].due(t_sim):
            return False
        frame = f"{self.frame_base}/{sonar}"
        # every product given is checked, whether or not someone subscribes to it
        images = [(f"{sonar}/{key}", mono8(image, f"Ros2Bridge.publish_sonar.{key}_u8"))
                  for key, image in (("polar", polar_u8), ("fan", fan_u8)) if image is not None]
        xyzi = None if points_sonar_frd is None else cloud_xyzi_flu(points_sonar_frd, intensity)
        pose = None if sonar_pose_ned is None else pose_enu_from_ned(*sonar_pose_ned)
        sec, nanosec = stamp_from_sim_time(t_sim)
        # pre-serialised, as image_msg / pointcloud_msg / PoseStamped would be: the
        # pixels and points are copied once, into the bytes handed to DDS
        pubs, write, wanted = self.pubs, self.writer.write, self.writer.wanted
        for key, image in images:
            if wanted(pubs[key]):
                write(pubs[key], encode_image(sec, nanosec, frame, image), self.topics[key])
        points, pose_key = f"{sonar}/points", f"{sonar}/pose"
        if xyzi is not None and wanted(pubs[points]):
            write(pubs[points], encode_pointcloud2(sec, nanosec, frame, xyzi),
                  self.topics[points])
        if pose is not None and wanted(pubs[pose_key]):
            write(pubs[pose_key], self.pose(sec, nanosec, *pose), self.topics[pose_key])
        return True

    def camera(self, camera: str, t_sim: float, rgb_u8: np.ndarray,
               depth_m: np.ndarray | None, labels_u8: np.ndarray | None, K: np.ndarray,
               camera_pose_ned: tuple[ArrayLike, ArrayLike]) -> None:
        """A frame of the camera named ``camera`` to its topics someone subscribes to: the
        rgb8 image, its CameraInfo (pinhole, no distortion), the 32FC1 depth image
        (REP-118), the mono8 label image and the optical frame's pose (x right, y down, z
        forward; frame ``<agent>/<camera>_optical``)."""
        frame = f"{self.frame_base}/{camera}_optical"
        sec, nanosec = stamp_from_sim_time(t_sim)
        pubs, write, wanted = self.pubs, self.writer.write, self.writer.wanted
        image, info, depth, labels, pose_key = (f"{camera}/{product}" for product in (
            "image_raw", "camera_info", "depth", "labels", "pose"))
        if wanted(pubs[image]):
            write(pubs[image], encode_image(sec, nanosec, frame, rgb_u8, "rgb8"),
                  self.topics[image])
        if wanted(pubs[info]):
            write(pubs[info], camera_info_msg(t_sim, frame, rgb_u8.shape[:2], K),
                  self.topics[info])
        if depth_m is not None and wanted(pubs[depth]):
            write(pubs[depth], encode_image(
                sec, nanosec, frame, np.asarray(depth_m, dtype="<f4"), "32FC1"),
                self.topics[depth])
        if labels_u8 is not None and wanted(pubs[labels]):
            write(pubs[labels], encode_image(sec, nanosec, frame, labels_u8),
                  self.topics[labels])
        if wanted(pubs[pose_key]):
            position, rotation = camera_pose_ned
            pose = pose_enu_from_ned(position, optical_rotation(rotation))
            write(pubs[pose_key], self.pose(sec, nanosec, *pose), self.topics[pose_key])

    def sonar_image_wanted(self, sonar: str) -> bool:
        """Does ``<sonar>/image`` (ProjectedSonarImage) exist and have a subscriber?"""
        pub = self.pubs.get(f"{sonar}/image")
        return pub is not None and self.writer.wanted(pub)

    def sonar_image(self, sonar: str, t_sim: float, polar_u8: np.ndarray,
                    beam_angles_rad: ArrayLike, ranges_m: ArrayLike, frequency_hz: float,
                    sound_speed_m_s: float) -> None:
        """``<sonar>/image`` (the bytes of :func:`~.messages.projected_sonar_image_msg`),
        if wanted."""
        if not self.sonar_image_wanted(sonar):
            return
        raw = projected_sonar_image_bytes(t_sim, f"{self.frame_base}/{sonar}", polar_u8,
                                          beam_angles_rad, ranges_m, frequency_hz,
                                          sound_speed_m_s)
        self.writer.write(self.pubs[f"{sonar}/image"], raw, self.topics[f"{sonar}/image"])

    def extra_wanted(self, key: str) -> bool:
        """Does the topic ``key`` (``"helm/decision"``, ``"vars"``) exist and have a
        subscriber?"""
        pub = self.pubs.get(key)
        return pub is not None and self.writer.wanted(pub)

    def write_extra(self, key: str, raw: bytes) -> None:
        """Serialised ``raw`` to the topic ``key`` (checked with :meth:`extra_wanted`)."""
        self.writer.write(self.pubs[key], raw, self.topics[key])

    def helm(self, heading_deg: float | None, speed: float | None, depth: float | None,
             mode: str) -> None:
        """The desired values given (to subscribers) and the mode when it changed."""
        # pre-serialised std_msgs/Float64 and String (the bytes rclpy would make)
        for key, value in (
            ("desired_heading", heading_deg),
            ("desired_speed", speed),
            ("desired_depth", depth),
        ):
            if value is None:
                continue
            raw = float64_bytes(float(value))  # a bad value fails, subscribed or not
            if self.writer.wanted(self.pubs[f"helm/{key}"]):
                self.writer.write(self.pubs[f"helm/{key}"], raw, self.topics[f"helm/{key}"])
        mode = str(mode)
        if mode != self.mode_text:
            self.mode_text = mode
            self.writer.write(self.pubs["helm/mode"], string_bytes(mode),
                              self.topics["helm/mode"])
