"""Fast CDR (XCDR1, little endian) encoders for the message types recorded every tick.

ROS 2 serialises messages as OMG CDR: a 4-byte encapsulation header (``00 01 00 00`` =
CDR little endian), then each primitive aligned to its own size counted from the end
of that header; strings are a uint32 length that includes a trailing NUL, then the
bytes and the NUL; sequences are a uint32 count, then the elements; fixed arrays have
no count. (OMG DDS-XTypes 1.3 §7.4.3 "XCDR1"; the same rules as ``mcap_ros2._cdr``.)

``mcap_ros2``'s schema-driven encoder is general but pure Python per field
(~130 µs for an Odometry). These hand-laid encoders cover the hot types — Odometry,
TFMessage, Image, PointCloud2 and uhrisim's own Variable, HelmDecision and Event (a
community posting is the most frequent message of a recording) — in a few microseconds, and
``OdometryEncoder``/``TransformEncoder`` go further and pack a whole message with
one precompiled ``struct`` once the frame ids are known. ``tests/unit/test_record_cdr.py``
holds them all byte for byte to ``mcap_ros2``'s encoder,
which stays the slow, obviously-correct reference (and the encoder of every other type).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np

CDR_LE_HEADER = b"\x00\x01\x00\x00"
_ZERO_COV = b"\x00" * (36 * 8)

# sensor_msgs/PointField datatype constants
POINTFIELD_FLOAT32 = 7


def _byte_view(array: np.ndarray) -> memoryview:
    """A flat uint8 view of a C-contiguous copy-if-needed of ``array``."""
    return memoryview(np.ascontiguousarray(array).reshape(-1).view(np.uint8))


class CdrBuffer:
    """An append-only CDR little-endian buffer that tracks alignment."""

    __slots__ = ("_b",)

    def __init__(self) -> None:
        self._b = bytearray(CDR_LE_HEADER)

    def _align(self, size: int) -> None:
        pad = -(len(self._b) - 4) % size
        if pad:
            self._b += b"\x00" * pad

    def u8(self, value: int) -> None:
        self._b.append(value & 0xFF)

    def i32(self, value: int) -> None:
        self._align(4)
        self._b += struct.pack("<i", value)

    def u32(self, value: int) -> None:
        self._align(4)
        self._b += struct.pack("<I", value)

    def u32s(self, *values: int) -> None:
        self._align(4)
        self._b += struct.pack(f"<{len(values)}I", *values)

    def f64s(self, values: Sequence[float]) -> None:
        """Consecutive float64 values (a struct of doubles or a fixed array)."""
        self._align(8)
        self._b += struct.pack(f"<{len(values)}d", *values)

    def raw_f64(self, data: bytes) -> None:
        """Pre-packed little-endian float64 bytes (e.g. a zero covariance)."""
        self._align(8)
        self._b += data

    def string(self, text: str) -> None:
        raw = text.encode("utf-8")
        self._align(4)
        self._b += struct.pack("<I", len(raw) + 1)
        self._b += raw
        self._b.append(0)

    def u8_seq(self, data: bytes | memoryview) -> None:
        self._align(4)
        self._b += struct.pack("<I", len(data))
        self._b += data

    def stamp(self, sec: int, nanosec: int) -> None:
        self._align(4)
        self._b += struct.pack("<iI", sec, nanosec)

    def header(self, sec: int, nanosec: int, frame_id: str) -> None:
        """std_msgs/Header."""
        self.stamp(sec, nanosec)
        self.string(frame_id)

    def getvalue(self) -> bytes:
        return bytes(self._b)


def _string_fields(text: str, offset: int) -> tuple[str, tuple[Any, ...], int]:
    """struct format, values and new offset for a CDR string starting at ``offset``.

    ``offset`` counts from the end of the encapsulation header and must be 4-aligned.
    """
    raw = text.encode("utf-8") + b"\x00"
    return f"I{len(raw)}s", (len(raw), raw), offset + 4 + len(raw)


def _pad(offset: int, size: int) -> tuple[str, int]:
    pad = -offset % size
    return (f"{pad}x" if pad else ""), offset + pad


class OdometryEncoder:
    """nav_msgs/msg/Odometry for fixed frame ids, packed by one precompiled struct.

    With the two frame ids fixed, every field of an Odometry sits at a fixed offset, so
    the whole message is one ``struct.pack``. Covariances are zero (ground truth).
    """

    __slots__ = ("_prefix", "_struct")

    def __init__(self, frame_id: str, child_frame_id: str) -> None:
        f1, v1, o = _string_fields(frame_id, 8)  # after stamp (int32 sec, uint32 nanosec)
        p1, o = _pad(o, 4)
        f2, v2, o = _string_fields(child_frame_id, o)
        p2, o = _pad(o, 8)
        # pose: 7 doubles + 36 covariance; twist: 6 doubles + 36 covariance
        self._struct = struct.Struct(f"<4siI{f1}{p1}{f2}{p2}7d288x6d288x")
        self._prefix = (v1, v2)

    def __call__(
        self,
        sec: int,
        nanosec: int,
        position: Sequence[float],
        orientation_xyzw: Sequence[float],
        linear: Sequence[float],
        angular: Sequence[float],
    ) -> bytes:
        (v1, v2) = self._prefix
        return self._struct.pack(
            CDR_LE_HEADER, sec, nanosec, *v1, *v2, *position, *orientation_xyzw, *linear,
            *angular,
        )


class TransformEncoder:
    """tf2_msgs/msg/TFMessage of transforms between fixed frames, all with one stamp, packed
    by one precompiled struct: ``TransformEncoder(parent, child, *more_pairs)``, called
    with ``(sec, nanosec, translation, rotation_xyzw, *more (translation, rotation))``
    (one transform per frame pair, in order)."""

    __slots__ = ("_count", "_prefix", "_struct")

    def __init__(self, parent_frame_id: str, child_frame_id: str,
                 *more_pairs: tuple[str, str]) -> None:
        pairs = [(parent_frame_id, child_frame_id), *more_pairs]
        fmt, prefix, o = "<4sI", [], 4  # uint32 count at 0, then each transform
        for parent, child in pairs:
            _, o = _pad(o, 4)  # (8-aligned after the doubles: no padding needed)
            f1, v1, o = _string_fields(parent, o + 8)  # after the stamp
            p1, o = _pad(o, 4)
            f2, v2, o = _string_fields(child, o)
            p2, o = _pad(o, 8)
            fmt += f"iI{f1}{p1}{f2}{p2}7d"
            prefix.append((v1, v2))
            o += 7 * 8
        self._struct = struct.Struct(fmt)
        self._prefix = prefix
        self._count = len(pairs)

    def __call__(self, sec: int, nanosec: int, translation: Sequence[float],
                 rotation_xyzw: Sequence[float],
                 *more: tuple[Sequence[float], Sequence[float]]) -> bytes:
        values: list[Any] = [CDR_LE_HEADER, self._count]
        for (v1, v2), (t, q) in zip(self._prefix, [(translation, rotation_xyzw), *more],
                                    strict=True):
            values += [sec, nanosec, *v1, *v2, *t, *q]
        return self._struct.pack(*values)


class PoseStampedEncoder:
    """geometry_msgs/PoseStamped in a fixed frame, serialised (CDR, little endian) by one
    precompiled ``struct``: the bytes rclpy makes of the message, without building one.
    ``tests/integration/test_ros2_convert.py`` holds it to rclpy's serialisation."""

    __slots__ = ("_frame", "_struct")

    def __init__(self, frame_id: str) -> None:
        self._frame = frame_id.encode("utf-8") + b"\x00"
        end_of_frame = 8 + 4 + len(self._frame)  # stamp, string length, string (+ NUL)
        pad = -end_of_frame % 8  # the pose's doubles are 8-aligned
        self._struct = struct.Struct(f"<4siII{len(self._frame)}s{pad}x7d")

    def __call__(self, sec: int, nanosec: int, position: Sequence[float],
                 orientation_xyzw: Sequence[float]) -> bytes:
        return self._struct.pack(CDR_LE_HEADER, sec, nanosec, len(self._frame), self._frame,
                                 *position, *orientation_xyzw)


def encode_odometry(
    sec: int,
    nanosec: int,
    frame_id: str,
    child_frame_id: str,
    position: Sequence[float],
    orientation_xyzw: Sequence[float],
    linear: Sequence[float],
    angular: Sequence[float],
) -> bytes:
    """nav_msgs/msg/Odometry with zero covariances (simulated ground truth)."""
    b = CdrBuffer()
    b.header(sec, nanosec, frame_id)
    b.string(child_frame_id)
    b.f64s((*position, *orientation_xyzw))
    b.raw_f64(_ZERO_COV)
    b.f64s((*linear, *angular))
    b.raw_f64(_ZERO_COV)
    return b.getvalue()


def encode_tf_message(
    transforms: Sequence[tuple[int, int, str, str, Sequence[float], Sequence[float]]],
) -> bytes:
    """tf2_msgs/msg/TFMessage from ``(sec, nanosec, parent, child, xyz, quat_xyzw)`` tuples."""
    b = CdrBuffer()
    b.u32(len(transforms))
    for sec, nanosec, parent, child, xyz, quat in transforms:
        b.header(sec, nanosec, parent)
        b.string(child)
        b.f64s((*xyz, *quat))
    return b.getvalue()


def encode_image(
    sec: int,
    nanosec: int,
    frame_id: str,
    image: np.ndarray,
    encoding: str = "mono8",
) -> bytes:
    """sensor_msgs/msg/Image from a (H, W) or (H, W, C) array, row-major and little endian
    (``step`` = bytes per row: W for mono8, 3·W for rgb8, 4·W for 32FC1). The pixels are
    copied once, into the returned bytes."""
    height, width = image.shape[:2]
    pixels = _byte_view(image)
    b = CdrBuffer()
    b.header(sec, nanosec, frame_id)
    b.u32s(height, width)
    b.string(encoding)
    b.u8(0)  # is_bigendian
    b.u32s(len(pixels) // max(height, 1), len(pixels))  # step (bytes per row), data length
    return b"".join((b.getvalue(), pixels))


def encode_projected_sonar_image(
    sec: int,
    nanosec: int,
    frame_id: str,
    polar: np.ndarray,
    beam_directions: np.ndarray,
    ranges: np.ndarray,
    frequency_hz: float,
    sound_speed_m_s: float,
) -> bytes:
    """marine_acoustic_msgs/msg/ProjectedSonarImage: ``polar`` ``(n_ranges, n_beams)``
    uint8 (one row of beams per range), ``beam_directions`` ``(n_beams, 3)`` float64,
    ``ranges`` ``(n_ranges,)`` (written float32), no beam widths, dtype UINT8 (0). The
    pixels are copied once, into the returned bytes; tests hold it to rclpy's
    serialisation and mcap_ros2's."""
    pixels = _byte_view(polar)
    b = CdrBuffer()
    b.header(sec, nanosec, frame_id)
    b._align(4)
    b._b += struct.pack("<ffII", frequency_hz, sound_speed_m_s, 0, 0)  # PingInfo
    b.u32(len(beam_directions))
    b.raw_f64(np.ascontiguousarray(beam_directions, dtype="<f8").tobytes())
    b.u32(len(ranges))
    b._b += np.ascontiguousarray(ranges, dtype="<f4").tobytes()
    b.u8(0)  # is_bigendian
    b.u32s(0, polar.shape[1], len(pixels))  # dtype UINT8, beam_count, the data's length
    return b"".join((b.getvalue(), pixels))


def encode_pointcloud2(
    sec: int,
    nanosec: int,
    frame_id: str,
    points_xyzi: np.ndarray,
) -> bytes:
    """sensor_msgs/msg/PointCloud2, unorganised (height 1), fields x, y, z, intensity float32.

    ``points_xyzi`` has shape ``(N, 4)``; it is written little endian, 16 bytes a point
    (copied once, into the returned bytes).
    """
    pts = np.ascontiguousarray(points_xyzi, dtype="<f4")
    n = pts.shape[0]
    b = CdrBuffer()
    b.header(sec, nanosec, frame_id)
    b.u32s(1, n)  # height, width
    b.u32(4)  # fields
    for offset, name in ((0, "x"), (4, "y"), (8, "z"), (12, "intensity")):
        b.string(name)
        b.u32(offset)
        b.u8(POINTFIELD_FLOAT32)
        b.u32(1)
    b.u8(0)  # is_bigendian
    data = _byte_view(pts)
    b.u32s(16, 16 * n, len(data))  # point_step, row_step, then the data's length
    return b"".join((b.getvalue(), data, b"\x01"))  # is_dense: no NaN points


def encode_variable(sec: int, nanosec: int, name: str, source: str, kind: int,
                    double_value: float, string_value: str) -> bytes:
    """uhrisim_msgs/msg/Variable (header frame id ""): one community posting. The bytes
    between the stamp and the value depend only on ``name``, ``source`` and ``kind``, and
    are laid out once for each (a community posts a few dozen variables, over and over)."""
    middle = _variable_middle(name, source, kind)
    raw = string_value.encode("utf-8")
    return b"".join((CDR_LE_HEADER, struct.pack("<iI", sec, nanosec), middle,
                     struct.pack("<dI", double_value, len(raw) + 1), raw, b"\x00"))


@lru_cache(maxsize=4096)
def _variable_middle(name: str, source: str, kind: int) -> bytes:
    """A Variable's bytes after its stamp up to its ``double_value`` (8-aligned there, so
    the value and the string's length follow unpadded)."""
    b = CdrBuffer()
    b.header(0, 0, "")
    b.string(name)
    b.string(source)
    b.u8(kind)
    b._align(8)
    return bytes(b._b[12:])


def encode_helm_decision(sec: int, nanosec: int, decided: Sequence[float | None], mode: str,
                         active: Sequence[str], contributions: Sequence[tuple[str, float]],
                         total: float, all_stop_reason: str) -> bytes:
    """uhrisim_msgs/msg/HelmDecision (header frame id ""): ``decided`` is heading (deg),
    speed (m/s) and depth (m), each None when the helm left it undecided."""
    b = CdrBuffer()
    b.header(sec, nanosec, "")
    for value in decided:
        b.u8(value is not None)
        b.f64s((value or 0.0,))
    b.string(mode)
    b.u32(len(active))
    for name in active:
        b.string(name)
    b.u32(len(contributions))
    for name, value in contributions:
        b.string(name)
        b.f64s((value,))
    b.f64s((total,))
    b.string(all_stop_reason)
    return b.getvalue()


def encode_event(sec: int, nanosec: int, frame_id: str, kind: str, detail: str) -> bytes:
    """uhrisim_msgs/msg/Event."""
    b = CdrBuffer()
    b.header(sec, nanosec, frame_id)
    b.string(kind)
    b.string(detail)
    return b.getvalue()


def decode_odometry(data: bytes | memoryview) -> tuple[int, int, str, str, tuple[float, ...]]:
    """Parse a little-endian CDR nav_msgs/msg/Odometry (the inverse of the encoders).

    Returns ``(sec, nanosec, frame_id, child_frame_id, values)`` with the 13 values
    position (3), orientation xyzw (4), linear (3), angular (3); covariances skipped.
    Raises ``ValueError`` for anything but CDR little endian (use mcap_ros2 then).
    """
    buf = bytes(data[:4])
    if buf != CDR_LE_HEADER:
        raise ValueError(f"not little-endian CDR (encapsulation {buf.hex()})")
    sec, nanosec = struct.unpack_from("<iI", data, 4)
    o = 8  # offsets relative to the end of the encapsulation header
    strings = []
    for _ in range(2):
        o += -o % 4
        (n,) = struct.unpack_from("<I", data, 4 + o)
        strings.append(bytes(data[8 + o : 8 + o + n - 1]).decode("utf-8"))
        o += 4 + n
    o += -o % 8
    pose = struct.unpack_from("<7d", data, 4 + o)
    twist = struct.unpack_from("<6d", data, 4 + o + 56 + 288)
    return sec, nanosec, strings[0], strings[1], pose + twist


def _f64_seq_of_structs(b: CdrBuffer, rows: np.ndarray) -> None:
    """A sequence of structs of 3 float64 (e.g. geometry_msgs/Point[]), from (N, 3)."""
    n = rows.shape[0]
    b.u32(n)
    if n:
        b._align(8)
        b._b += np.ascontiguousarray(rows, dtype="<f8").tobytes()


def _f32_seq_of_structs(b: CdrBuffer, rows: np.ndarray) -> None:
    """A sequence of structs of float32 (e.g. std_msgs/ColorRGBA[]), from (N, k)."""
    n = rows.shape[0]
    b.u32(n)
    if n:
        b._b += np.ascontiguousarray(rows, dtype="<f4").tobytes()


def encode_marker_array(markers: Sequence[dict[str, Any]]) -> bytes:
    """visualization_msgs/msg/MarkerArray (Kilted layout) from plain marker dicts.

    Each dict: ``sec``, ``nanosec``, ``frame_id``, ``ns``, ``id``, ``type``, ``action``,
    ``pose`` (7 floats: position xyz, orientation xyzw), ``scale`` (3), ``color`` (4),
    ``points`` ((N, 3) array), ``colors`` ((M, 4) array), ``text``, ``mesh_resource``.
    Lifetime 0 (forever), not frame-locked, no texture, UVs or embedded mesh file.
    The point arrays are copied as whole blocks, so a mesh of 10⁵ triangles costs
    milliseconds rather than the seconds of the per-field reference encoder.
    """
    b = CdrBuffer()
    b.u32(len(markers))
    for m in markers:
        b.header(m["sec"], m["nanosec"], m["frame_id"])
        b.string(m["ns"])
        b._align(4)
        b._b += struct.pack("<iii", m["id"], m["type"], m["action"])
        b.f64s((*m["pose"], *m["scale"]))
        b._align(4)
        b._b += struct.pack("<4f", *m["color"])
        b._b += struct.pack("<iI", 0, 0)  # lifetime: already 4-aligned after 4 floats
        b.u8(0)  # frame_locked
        _f64_seq_of_structs(b, np.asarray(m["points"], dtype=float).reshape(-1, 3))
        _f32_seq_of_structs(b, np.asarray(m["colors"], dtype=float).reshape(-1, 4))
        b.string("")  # texture_resource
        b.header(0, 0, "")  # texture.header
        b.string("")  # texture.format
        b.u8_seq(b"")  # texture.data
        b.u32(0)  # uv_coordinates
        b.string(m["text"])
        b.string(m["mesh_resource"])
        b.string("")  # mesh_file.filename
        b.u8_seq(b"")  # mesh_file.data
        b.u8(0)  # mesh_use_embedded_materials
    return b.getvalue()
