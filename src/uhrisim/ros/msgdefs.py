"""ROS 2 message definitions (``.msg`` text) embedded in uhrisim's MCAP recordings.

MCAP's ``ros2`` profile stores, for each schema, the ``ros2msg`` text of the type
followed by every type it depends on, each introduced by a line of 80 ``=`` and a
``MSG: pkg/Type`` line — the layout ``ros2 bag record`` writes and that Foxglove,
Lichtblick, ``rosbags`` and ``mcap_ros2`` parse (MCAP spec, "ros2msg" schema encoding).

The standard definitions below are those of ROS 2 Kilted (std_msgs, geometry_msgs,
nav_msgs, sensor_msgs, visualization_msgs, tf2_msgs 2025 releases), stripped of
comments; ``tests/unit/test_record_msgdefs.py`` holds them, and the concatenation
order, to the Kilted type store shipped with ``rosbags``. The ``uhrisim_msgs`` types
are ours: typed, flat-ish messages that Foxglove can plot field by field.
"""

from __future__ import annotations

import re

from uhrisim.core.errors import ConfigError

SEPARATOR = "=" * 80

# Each entry: the type's own fields (and constants), one per line, no dependencies.
_OWN: dict[str, str] = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "builtin_interfaces/msg/Duration": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "std_msgs/msg/String": "string data\n",
    "std_msgs/msg/Float64": "float64 data\n",
    "rosgraph_msgs/msg/Clock": "builtin_interfaces/Time clock\n",
    "std_msgs/msg/ColorRGBA": "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
    "geometry_msgs/msg/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
    "geometry_msgs/msg/Pose": (
        "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n"
    ),
    "geometry_msgs/msg/PoseStamped": "std_msgs/Header header\ngeometry_msgs/Pose pose\n",
    "geometry_msgs/msg/PoseWithCovariance": (
        "geometry_msgs/Pose pose\nfloat64[36] covariance\n"
    ),
    "geometry_msgs/msg/Twist": "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n",
    "geometry_msgs/msg/TwistWithCovariance": (
        "geometry_msgs/Twist twist\nfloat64[36] covariance\n"
    ),
    "geometry_msgs/msg/Transform": (
        "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"
    ),
    "geometry_msgs/msg/TransformStamped": (
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n"
    ),
    "nav_msgs/msg/Odometry": (
        "std_msgs/Header header\n"
        "string child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\n"
        "geometry_msgs/TwistWithCovariance twist\n"
    ),
    "tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
    "sensor_msgs/msg/Image": (
        "std_msgs/Header header\n"
        "uint32 height\n"
        "uint32 width\n"
        "string encoding\n"
        "uint8 is_bigendian\n"
        "uint32 step\n"
        "uint8[] data\n"
    ),
    "sensor_msgs/msg/RegionOfInterest": (
        "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n"
    ),
    "sensor_msgs/msg/CameraInfo": (
        "std_msgs/Header header\n"
        "uint32 height\n"
        "uint32 width\n"
        "string distortion_model\n"
        "float64[] d\n"
        "float64[9] k\n"
        "float64[9] r\n"
        "float64[12] p\n"
        "uint32 binning_x\n"
        "uint32 binning_y\n"
        "sensor_msgs/RegionOfInterest roi\n"
    ),
    "sensor_msgs/msg/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort\n"
    ),
    "sensor_msgs/msg/CompressedImage": "std_msgs/Header header\nstring format\nuint8[] data\n",
    "sensor_msgs/msg/PointField": (
        "uint8 INT8=1\n"
        "uint8 UINT8=2\n"
        "uint8 INT16=3\n"
        "uint8 UINT16=4\n"
        "uint8 INT32=5\n"
        "uint8 UINT32=6\n"
        "uint8 FLOAT32=7\n"
        "uint8 FLOAT64=8\n"
        "string name\n"
        "uint32 offset\n"
        "uint8 datatype\n"
        "uint32 count\n"
    ),
    "sensor_msgs/msg/PointCloud2": (
        "std_msgs/Header header\n"
        "uint32 height\n"
        "uint32 width\n"
        "sensor_msgs/PointField[] fields\n"
        "bool is_bigendian\n"
        "uint32 point_step\n"
        "uint32 row_step\n"
        "uint8[] data\n"
        "bool is_dense\n"
    ),
    "visualization_msgs/msg/UVCoordinate": "float32 u\nfloat32 v\n",
    "visualization_msgs/msg/MeshFile": "string filename\nuint8[] data\n",
    "visualization_msgs/msg/Marker": (
        "int32 ARROW=0\n"
        "int32 CUBE=1\n"
        "int32 SPHERE=2\n"
        "int32 CYLINDER=3\n"
        "int32 LINE_STRIP=4\n"
        "int32 LINE_LIST=5\n"
        "int32 CUBE_LIST=6\n"
        "int32 SPHERE_LIST=7\n"
        "int32 POINTS=8\n"
        "int32 TEXT_VIEW_FACING=9\n"
        "int32 MESH_RESOURCE=10\n"
        "int32 TRIANGLE_LIST=11\n"
        "int32 ARROW_STRIP=12\n"
        "int32 ADD=0\n"
        "int32 MODIFY=0\n"
        "int32 DELETE=2\n"
        "int32 DELETEALL=3\n"
        "std_msgs/Header header\n"
        "string ns\n"
        "int32 id\n"
        "int32 type\n"
        "int32 action\n"
        "geometry_msgs/Pose pose\n"
        "geometry_msgs/Vector3 scale\n"
        "std_msgs/ColorRGBA color\n"
        "builtin_interfaces/Duration lifetime\n"
        "bool frame_locked\n"
        "geometry_msgs/Point[] points\n"
        "std_msgs/ColorRGBA[] colors\n"
        "string texture_resource\n"
        "sensor_msgs/CompressedImage texture\n"
        "visualization_msgs/UVCoordinate[] uv_coordinates\n"
        "string text\n"
        "string mesh_resource\n"
        "visualization_msgs/MeshFile mesh_file\n"
        "bool mesh_use_embedded_materials\n"
    ),
    "visualization_msgs/msg/MarkerArray": "visualization_msgs/Marker[] markers\n",
    # --- marine_acoustic_msgs 2.1.0 (not in Kilted's core; the same files the bridge
    # builds its live types from: uhrisim/bridges/ros2/interfaces, PROVENANCE.md)
    "marine_acoustic_msgs/msg/PingInfo": (
        "float32 frequency\n"
        "float32 sound_speed\n"
        "float32[] tx_beamwidths\n"
        "float32[] rx_beamwidths\n"
    ),
    "marine_acoustic_msgs/msg/SonarImageData": (
        "uint32 DTYPE_UINT8=0\n"
        "uint32 DTYPE_INT8=1\n"
        "uint32 DTYPE_UINT16=2\n"
        "uint32 DTYPE_INT16=3\n"
        "uint32 DTYPE_UINT32=4\n"
        "uint32 DTYPE_INT32=5\n"
        "uint32 DTYPE_UINT64=6\n"
        "uint32 DTYPE_INT64=7\n"
        "uint32 DTYPE_FLOAT32=8\n"
        "uint32 DTYPE_FLOAT64=9\n"
        "bool is_bigendian\n"
        "uint32 dtype\n"
        "uint32 beam_count\n"
        "uint8[] data\n"
    ),
    "marine_acoustic_msgs/msg/ProjectedSonarImage": (
        "std_msgs/Header header\n"
        "marine_acoustic_msgs/PingInfo ping_info\n"
        "geometry_msgs/Vector3[] beam_directions\n"
        "float32[] ranges\n"
        "marine_acoustic_msgs/SonarImageData image\n"
    ),
    # --- uhrisim_msgs: our own types -----------------------------------------------
    # One behavior's share of the helm's objective at the chosen decision.
    "uhrisim_msgs/msg/BehaviorContribution": "string name\nfloat64 value\n",
    # One helm cycle: the decision (compass heading, speed, depth; each may be absent,
    # e.g. all-stop), the helm mode, the active behaviors and each behavior's
    # contribution with their total (docs/design.md habit 8).
    "uhrisim_msgs/msg/HelmDecision": (
        "std_msgs/Header header\n"
        "bool has_heading\n"
        "float64 heading_deg\n"
        "bool has_speed\n"
        "float64 speed\n"
        "bool has_depth\n"
        "float64 depth\n"
        "string mode\n"
        "string[] active_behaviors\n"
        "uhrisim_msgs/BehaviorContribution[] contributions\n"
        "float64 total\n"
        "string all_stop_reason\n"
    ),
    # A community variable posting (MOOS-like): numeric or string, with its source.
    "uhrisim_msgs/msg/Variable": (
        "uint8 DOUBLE=0\n"
        "uint8 STRING=1\n"
        "std_msgs/Header header\n"
        "string name\n"
        "string source\n"
        "uint8 kind\n"
        "float64 double_value\n"
        "string string_value\n"
    ),
    # Something that happened once (collision, mode change, scenario end).
    "uhrisim_msgs/msg/Event": "std_msgs/Header header\nstring kind\nstring detail\n",
}

_PRIMITIVES = frozenset(
    {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
     "uint64", "float32", "float64", "string", "wstring"}
)
_FIELD_TYPE = re.compile(r"^([A-Za-z0-9_]+(?:/[A-Za-z0-9_]+)?)(\[[^\]]*\])?(<=\d+)?$")


def _full_name(short: str) -> str:
    pkg, name = short.split("/")
    return f"{pkg}/msg/{name}"


def _dependencies(typename: str) -> list[str]:
    """Direct non-primitive field types of ``typename`` (full names), in field order."""
    deps: list[str] = []
    for line in _OWN[typename].splitlines():
        ftype, rest = line.split(" ", 1)
        if "=" in rest:  # constant
            continue
        base = _FIELD_TYPE.match(ftype)
        if base is None:
            raise ConfigError(f"bad field type {ftype!r}", where=f"msgdefs {typename}")
        name = base.group(1)
        if name in _PRIMITIVES or name.split("<=")[0] in _PRIMITIVES:
            continue
        deps.append(_full_name(name))
    return deps


def schema_text(typename: str) -> str:
    """The concatenated ``ros2msg`` text of ``typename`` (e.g. ``"nav_msgs/msg/Odometry"``).

    Dependencies follow in depth-first pre-order of first use, each once, each behind
    a separator line and ``MSG: pkg/Type`` — the order ``rosbag2`` uses.
    """
    if typename not in _OWN:
        raise ConfigError(f"no embedded message definition for {typename!r}", where="msgdefs")
    seen: list[str] = []

    def visit(t: str) -> None:
        for dep in _dependencies(t):
            if dep not in seen:
                seen.append(dep)
                visit(dep)

    visit(typename)
    parts = [_OWN[typename]]
    for dep in seen:
        pkg, _, name = dep.split("/")
        parts.append(f"{SEPARATOR}\nMSG: {pkg}/{name}\n{_OWN[dep]}")
    return "".join(parts)


def own_definition(typename: str) -> str:
    """The fields and constants of ``typename`` alone (its ``.msg`` text, dependencies
    named, not included)."""
    if typename not in _OWN:
        raise ConfigError(f"no embedded message definition for {typename!r}", where="msgdefs")
    return _OWN[typename]


def known_types() -> tuple[str, ...]:
    """Every type whose definition is embedded here (full ``pkg/msg/Type`` names)."""
    return tuple(_OWN)
