"""Pure conversions from uhrisim's frames and time to what ROS 2 messages carry.

No rclpy here: these are plain numpy functions, tested on their own, so the
conventions of the ROS 2 bridge can be checked without a ROS installation.

Frames (docs/conventions.md, REP-103/REP-105):

* uhrisim world NED (x north, y east, z down) -> ROS world ENU, frame ``"map"``
  (x east, y north, z up);
* uhrisim body FRD (x forward, y starboard, z down) -> ROS body FLU,
  frame ``"<agent>/base_link"`` (x forward, y port, z up);
* uhrisim yaw psi (compass heading, 0 north, clockwise positive) -> ENU yaw
  ``pi/2 - psi`` (0 east, counter-clockwise positive), carried as a quaternion.

Every conversion goes through :mod:`uhrisim.core.frames`; nothing else in the
bridge rotates a vector.

Time: ``header.stamp`` is the simulation time (seconds since the start of the run),
split into whole seconds and nanoseconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import ConfigError, NumericalError
from uhrisim.core.frames import (
    enu_from_ned,
    enu_rotation_from_ned,
    flu_from_frd,
    quaternion_from_matrix,
    rot_z,
)

_NS_PER_S = 1_000_000_000


def stamp_from_sim_time(t_sim: float) -> tuple[int, int]:
    """``(sec, nanosec)`` of a ``builtin_interfaces/Time`` for simulation time ``t_sim`` (s).

    Rounded to the nearest nanosecond; ``nanosec`` is always in ``[0, 1e9)``.
    """
    t = float(t_sim)
    if not math.isfinite(t):
        raise NumericalError(f"simulation time {t_sim!r} is not finite (ROS 2 stamp)")
    sec, nanosec = divmod(round(t * _NS_PER_S), _NS_PER_S)
    return int(sec), int(nanosec)


@dataclass(frozen=True)
class OdomFields:
    """The numbers of a ``nav_msgs/Odometry`` in ROS frames (REP-103/105).

    ``position_enu`` (m) and ``orientation_xyzw`` (body FLU -> world ENU) are in
    the ``"map"`` frame; ``linear_flu`` (m/s) and ``angular_flu`` (rad/s) are the body
    twist in the child frame ``"<agent>/base_link"``, as nav_msgs/Odometry specifies.
    """

    position_enu: tuple[float, float, float]
    orientation_xyzw: tuple[float, float, float, float]
    linear_flu: tuple[float, float, float]
    angular_flu: tuple[float, float, float]


def _vec3(value: ArrayLike, name: str) -> NDArray[np.float64]:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,):
        raise ConfigError(f"expected shape (3,), got {v.shape}", where=name)
    x, y, z = v.tolist()  # three math.isfinite calls: cheaper than a ufunc on 3 values
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise NumericalError(f"{name} is not finite: {v.tolist()}")
    return v


def _xyz(value: ArrayLike, name: str) -> tuple[float, float, float]:
    """Three finite floats of a (3,) vector (a float64 array or anything array-like)."""
    if type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (3,):
        x, y, z = value.tolist()
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
            raise NumericalError(f"{name} is not finite: {[x, y, z]}")
        return x, y, z
    x, y, z = _vec3(value, name).tolist()
    return x, y, z


def odom_fields_from_ned(
    position_ned: ArrayLike,
    yaw_rad: float,
    velocity_body_frd: ArrayLike,
    yaw_rate: float,
) -> OdomFields:
    """Odometry numbers in ENU/FLU from a NED position (m), compass yaw (rad),
    FRD body velocity (m/s) and yaw rate (rad/s, clockwise from above positive).

    Roll and pitch are zero (docs/conventions.md). Example: north 3, east 4, depth 2,
    heading 90 deg gives position (4, 3, -2) and the identity quaternion (the vehicle
    faces east, which is ENU yaw 0); a starboard turn (r > 0) is a negative ENU
    angular z.

    The maps of :func:`odom_fields_from_ned_reference` written out on plain floats
    (~5 us instead of ~30 us), with the same operations in the same order, so the
    numbers are identical to the last bit, signed zeros included: ENU (e, n, -d) and
    FLU (u, -v, -w) are the axis swaps and sign flips (a matrix product's zero is +0,
    hence ``x + 0.0`` and ``0.0 - x``); body FLU -> world ENU for a yaw psi is
    ``[[s, -c, 0], [c, s, 0], [0, 0, 1]]`` (c, s = cos psi, sin psi), whose
    quaternion by :func:`~uhrisim.core.frames.quaternion_from_matrix` has x = y = 0
    and one of its two branches (trace 2s + 1 > 0, or the m22 branch); the same numpy
    trigonometry and norm keep the rounding.
    """
    p0, p1, p2 = _xyz(position_ned, "position_ned")
    v0, v1, v2 = _xyz(velocity_body_frd, "velocity_body_frd")
    psi = float(yaw_rad)
    r = float(yaw_rate)
    if not (math.isfinite(psi) and math.isfinite(r)):
        raise NumericalError(f"yaw {yaw_rad!r} or yaw rate {yaw_rate!r} is not finite")
    c, s = float(np.cos(psi)), float(np.sin(psi))
    tr = s + s + 1.0
    if tr > 0.0:
        k = 2.0 * math.sqrt(tr + 1.0)
        q = [0.0 / k, 0.0 / k, (c + c) / k, 0.25 * k]
    else:  # the other branches need m00 > m11 or m11 > m22, i.e. s > s or s > 1: never
        k = 2.0 * math.sqrt(1.0 + 1.0 - s - s)
        q = [0.0 / k, 0.0 / k, 0.25 * k, (c + c) / k]
    n = float(np.linalg.norm(q))
    qx, qy, qz, qw = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    if qw < 0.0:
        qx, qy, qz, qw = -qx, -qy, -qz, -qw
    return OdomFields(
        position_enu=(p1 + 0.0, p0 + 0.0, 0.0 - p2),
        orientation_xyzw=(qx, qy, qz, qw),
        linear_flu=(v0 + 0.0, 0.0 - v1, 0.0 - v2),
        angular_flu=(0.0, 0.0, 0.0 - r),
    )


def odom_fields_from_ned_reference(
    position_ned: ArrayLike,
    yaw_rad: float,
    velocity_body_frd: ArrayLike,
    yaw_rate: float,
) -> OdomFields:
    """The slow, obviously-correct reference of :func:`odom_fields_from_ned` (rotation
    matrices and vector maps of :mod:`uhrisim.core.frames`); the fast one is held to it
    bit for bit (tests/unit/test_ros2_odom_fast.py).

    Odometry numbers in ENU/FLU from a NED position (m), compass yaw (rad),
    FRD body velocity (m/s) and yaw rate (rad/s, clockwise from above positive).

    Roll and pitch are zero (docs/conventions.md). Example: north 3, east 4, depth 2,
    heading 90 deg gives position (4, 3, -2) and the identity quaternion (the vehicle
    faces east, which is ENU yaw 0); a starboard turn (r > 0) is a negative ENU
    angular z.
    """
    p = _vec3(position_ned, "position_ned")
    v = _vec3(velocity_body_frd, "velocity_body_frd")
    psi = float(yaw_rad)
    r = float(yaw_rate)
    if not (math.isfinite(psi) and math.isfinite(r)):
        raise NumericalError(f"yaw {yaw_rad!r} or yaw rate {yaw_rate!r} is not finite")
    pos = enu_from_ned(p)
    quat = quaternion_from_matrix(enu_rotation_from_ned(rot_z(psi)))
    lin = flu_from_frd(v)
    ang = flu_from_frd(np.array([0.0, 0.0, r]))
    return OdomFields(
        position_enu=tuple(pos.tolist()),
        orientation_xyzw=tuple(quat.tolist()),
        linear_flu=tuple(lin.tolist()),
        angular_flu=tuple(ang.tolist()),
    )


_IDENTITY = np.eye(3)
#: ``np.allclose(r @ r.T, I, atol=1e-6)`` written out: |r r^T - I| <= 1e-6 + 1e-5 |I|.
_ORTHONORMAL_TOLERANCE = 1e-6 + 1e-5 * _IDENTITY


#: Columns: the optical frame's axes (x right, y down, z forward) in a camera frame that is
#: FRD-like (x forward, y right, z down), times the FRD→FLU flip that
#: :func:`pose_enu_from_ned` applies to its child frame (so that it is undone).
_OPTICAL_FROM_CAMERA_FRD = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]) @ (
    np.diag([1.0, -1.0, -1.0]))


def optical_rotation(rotation_from_camera: ArrayLike) -> NDArray[np.float64]:
    """What to hand a conversion that flips its child frame from FRD to FLU, for a
    camera's optical frame (REP-103 optical: x right, y down, z forward), given the
    rotation camera frame (x forward, y right, z down) → an FRD-style parent: with the
    camera → NED rotation, :func:`pose_enu_from_ned` then gives the optical frame → ENU
    rotation; with the mount (camera → body FRD), :func:`mount_transform` gives
    ``<agent>/base_link`` (FLU) → ``<agent>/camera_optical``."""
    return np.asarray(rotation_from_camera, dtype=float) @ _OPTICAL_FROM_CAMERA_FRD


def label_image_mono8(labels: ArrayLike) -> NDArray[np.uint8] | None:
    """A camera's label image ``(H, W)`` (index into the scene's labels, -1 for open
    water) as a ``mono8`` image: label index + 1, 0 for open water; ``None`` when an index
    does not fit in 8 bits (a scene with more than 254 labels: no label image then)."""
    arr = np.asarray(labels)
    if arr.max(initial=-1) >= 255:
        return None
    return (arr + 1).astype(np.uint8)


def pose_enu_from_ned(
    position_ned: ArrayLike, rotation_ned: ArrayLike | None = None
) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    """``(position_enu, orientation_xyzw)`` of an object placed in the NED world.

    ``rotation_ned`` is the 3x3 rotation from the object's own frame (treated as FRD)
    to NED; ``None`` means identity. The object frame becomes FLU in ROS, so a box's
    half-extents along its own axes are unchanged (only signs of axes flip).
    """
    p = _vec3(position_ned, "position_ned")
    r = _IDENTITY if rotation_ned is None else np.asarray(rotation_ned, dtype=float)
    if r.shape != (3, 3):
        raise ConfigError(f"expected a 3x3 rotation, got shape {r.shape}", where="rotation")
    if not (np.abs(r @ r.T - _IDENTITY) <= _ORTHONORMAL_TOLERANCE).all() or _det3(r) < 0.0:
        raise ConfigError("matrix is not a proper rotation", where="rotation")
    pos = enu_from_ned(p)
    q = quaternion_from_matrix(enu_rotation_from_ned(r))
    return (
        (float(pos[0]), float(pos[1]), float(pos[2])),
        (float(q[0]), float(q[1]), float(q[2]), float(q[3])),
    )


def _det3(m: NDArray[np.float64]) -> float:
    """Determinant of a 3x3 matrix (the triple product of its rows)."""
    (a, b, c), (d, e, f), (g, h, i) = m.tolist()
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


#: ``sensor_msgs/PointCloud2`` layout written by :func:`cloud_xyzi_flu`:
#: (name, byte offset) of four FLOAT32 fields, 16 bytes per point, little-endian.
CLOUD_FIELDS: tuple[tuple[str, int], ...] = (("x", 0), ("y", 4), ("z", 8), ("intensity", 12))
CLOUD_POINT_STEP = 16


def cloud_xyzi_flu(
    points_frd: ArrayLike, intensity: ArrayLike | None = None
) -> NDArray[np.float32]:
    """``(N, 4)`` little-endian float32 rows ``x, y, z, intensity`` in FLU: the data of a
    PointCloud2 with :data:`CLOUD_FIELDS`.

    ``points_frd`` is ``(N, 3)`` in the sensor's FRD frame (m); it is converted to the
    sensor's FLU frame (y and z negated). ``intensity`` is ``(N,)`` (any unit the sonar
    model uses, float32 on the wire), or ``None`` for zeros.
    """
    pts = np.asarray(points_frd, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ConfigError(f"expected shape (N, 3), got {pts.shape}", where="points_sonar_frd")
    n = pts.shape[0]
    packed = np.empty((n, 4), dtype="<f4")
    packed[:, :3] = flu_from_frd(pts)
    if intensity is None:
        packed[:, 3] = 0.0
    else:
        inten = np.asarray(intensity, dtype=float).reshape(-1)
        if inten.shape[0] != n:
            raise ConfigError(f"{inten.shape[0]} intensities for {n} points", where="intensity")
        packed[:, 3] = inten
    return packed


class RateGate:
    """Decides, in simulation time, whether a topic at ``rate_hz`` is due.

    Call :meth:`due` with every tick's ``t_sim``; it answers True at most once per
    period, at the first tick at or after each multiple of the period (0, 0.1, 0.2 ... s
    at 10 Hz), so the long-run average rate is exact on a tick grid (a 15 Hz topic on a
    100 Hz tick publishes at intervals 0.07, 0.07, 0.06 s ...) and gates of the same rate
    fire on the same ticks. A time within 1e-9 (relative) of a multiple counts as on it
    (tick times are products and sums of floats). ``rate_hz=None`` answers True on every
    call. A time that goes backwards (a reset run) restarts the gate.
    """

    def __init__(self, rate_hz: float | None) -> None:
        if rate_hz is not None and not (math.isfinite(rate_hz) and rate_hz > 0.0):
            raise ConfigError(f"rate must be a positive number of Hz, got {rate_hz!r}", "rate_hz")
        self._period = None if rate_hz is None else 1.0 / float(rate_hz)
        self._next: float | None = None  # the multiple of the period due next
        self._due_from = -math.inf  # the earliest time that counts as reaching it
        self._last = -math.inf

    @property
    def wake_time(self) -> float:
        """Before this simulation time (s) the gate is surely not due (``-inf``: it may be
        due at any time); lets a caller skip whole ticks."""
        return self._due_from

    def _aim(self, multiple: float) -> None:
        self._next = multiple
        self._due_from = multiple - 1e-9 * max(1.0, abs(multiple))

    def is_due(self, t_sim: float) -> bool:
        """Would :meth:`due` answer True at ``t_sim``? Notes the time (as ``due`` does) but
        uses up nothing: a caller can skip preparing a message that will not go out."""
        t = float(t_sim)
        period = self._period
        if period is None:
            return True
        if self._next is None or t < self._last:  # first call, or a reset run
            self._aim(math.ceil(t / period - 1e-9) * period)
        self._last = t
        return t >= self._due_from

    def due(self, t_sim: float) -> bool:
        """True when a message stamped ``t_sim`` (s) should go out."""
        if not self.is_due(t_sim):
            return False
        period = self._period
        if period is not None:
            assert self._next is not None
            t = float(t_sim)
            if t - self._next >= period:  # fell behind: aim at the multiple after t
                self._aim((math.floor(t / period + 1e-9) + 1) * period)
            else:
                self._aim(self._next + period)
        return True


#: Identity transform: translation (m) and rotation (x, y, z, w).
_IDENTITY_TF = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))


def agent_frames(agent: str) -> tuple[str, str]:
    """An agent's REP-105 frames: ``(<agent>/odom, <agent>/base_link)``."""
    return f"{agent}/odom", f"{agent}/base_link"


def tf_chain_frames(agent: str, world_frame: str = "map") -> tuple[tuple[str, str], ...]:
    """The ``(parent, child)`` pairs of one agent's REP-105 chain on ``/tf``: ``map`` ->
    ``<agent>/odom`` (the identity: ground truth does not drift) -> ``<agent>/base_link``
    (its odometry pose); :func:`tf_chain` gives the transforms."""
    odom, base = agent_frames(agent)
    return (world_frame, odom), (odom, base)


def tf_chain(position_enu: Sequence[float], orientation_xyzw: Sequence[float]
             ) -> tuple[tuple[Sequence[float], Sequence[float]], ...]:
    """``(translation, rotation_xyzw)`` of each pair of :func:`tf_chain_frames` for an
    odometry pose (ENU position, FLU body orientation)."""
    return _IDENTITY_TF, (position_enu, orientation_xyzw)


def mount_transform(position_frd: ArrayLike, rotation_frd: ArrayLike
                    ) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    """``(translation, rotation_xyzw)`` in FLU of a sensor mounted at ``position_frd`` (m,
    body FRD) with ``rotation_frd`` (3x3, sensor FRD -> body FRD): the transform
    ``<agent>/base_link`` -> sensor frame, both FLU (FLU = diag(1, -1, -1) FRD)."""
    flip = np.diag([1.0, -1.0, -1.0])
    r = flip @ np.asarray(rotation_frd, dtype=float) @ flip
    t = flu_from_frd(_vec3(position_frd, "position_frd"))
    q = quaternion_from_matrix(r)
    return ((float(t[0]), float(t[1]), float(t[2])),
            (float(q[0]), float(q[1]), float(q[2]), float(q[3])))
