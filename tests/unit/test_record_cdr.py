"""The hand-laid CDR encoders, byte for byte against mcap_ros2's schema-driven encoder.

``mcap_ros2`` (the reference) walks the ``.msg`` text field by field; ours are laid
out by hand for speed. Strings of varying length shift every later field's alignment,
so the property tests vary frame ids, sizes and values.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap_ros2._dynamic import serialize_dynamic

from uhrisim.ros import cdr
from uhrisim.ros.msgdefs import schema_text


def reference(typename: str, message: dict) -> bytes:
    return serialize_dynamic(typename, schema_text(typename))[typename](message)


frame_ids = st.text(alphabet="abcdefghij_/0123456789", min_size=0, max_size=17)
finite = st.floats(-1e6, 1e6, allow_nan=False)
stamps = st.tuples(st.integers(0, 2**31 - 1), st.integers(0, 999_999_999))


def header(sec: int, nsec: int, frame: str) -> dict:
    return {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": frame}


@settings(max_examples=60, deadline=None)
@given(stamps, frame_ids, frame_ids, st.lists(finite, min_size=13, max_size=13))
def test_odometry_matches_reference(stamp, frame, child, v) -> None:
    sec, nsec = stamp
    msg = {
        "header": header(sec, nsec, frame),
        "child_frame_id": child,
        "pose": {
            "pose": {
                "position": dict(zip("xyz", v[0:3], strict=True)),
                "orientation": dict(zip("xyzw", v[3:7], strict=True)),
            },
            "covariance": [0.0] * 36,
        },
        "twist": {
            "twist": {
                "linear": dict(zip("xyz", v[7:10], strict=True)),
                "angular": dict(zip("xyz", v[10:13], strict=True)),
            },
            "covariance": [0.0] * 36,
        },
    }
    fast = cdr.encode_odometry(sec, nsec, frame, child, v[0:3], v[3:7], v[7:10], v[10:13])
    assert fast == reference("nav_msgs/msg/Odometry", msg)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(stamps, frame_ids, frame_ids,
                          st.lists(finite, min_size=7, max_size=7)), max_size=4))
def test_tf_message_matches_reference(items) -> None:
    transforms, dicts = [], []
    for (sec, nsec), parent, child, v in items:
        transforms.append((sec, nsec, parent, child, v[:3], v[3:]))
        dicts.append({
            "header": header(sec, nsec, parent),
            "child_frame_id": child,
            "transform": {
                "translation": dict(zip("xyz", v[:3], strict=True)),
                "rotation": dict(zip("xyzw", v[3:], strict=True)),
            },
        })
    fast = cdr.encode_tf_message(transforms)
    assert fast == reference("tf2_msgs/msg/TFMessage", {"transforms": dicts})


@settings(max_examples=30, deadline=None)
@given(stamps, frame_ids, st.integers(1, 9), st.integers(1, 13), st.integers(0, 2**32 - 1))
def test_image_matches_reference(stamp, frame, h, w, seed) -> None:
    sec, nsec = stamp
    img = np.random.default_rng(seed).integers(0, 256, (h, w), dtype=np.uint8)
    msg = {
        "header": header(sec, nsec, frame),
        "height": h, "width": w, "encoding": "mono8", "is_bigendian": 0, "step": w,
        "data": img.tobytes(),
    }
    assert cdr.encode_image(sec, nsec, frame, img) == reference("sensor_msgs/msg/Image", msg)


def test_image_from_non_contiguous_view() -> None:
    img = np.arange(60, dtype=np.uint8).reshape(6, 10)[:, ::2]
    msg = {"header": header(1, 2, "s"), "height": 6, "width": 5, "encoding": "mono8",
           "is_bigendian": 0, "step": 5, "data": np.ascontiguousarray(img).tobytes()}
    assert cdr.encode_image(1, 2, "s", img) == reference("sensor_msgs/msg/Image", msg)


@settings(max_examples=30, deadline=None)
@given(stamps, frame_ids, st.integers(0, 20), st.integers(0, 2**32 - 1))
def test_pointcloud2_matches_reference(stamp, frame, n, seed) -> None:
    sec, nsec = stamp
    pts = np.random.default_rng(seed).normal(size=(n, 4)).astype("<f4")
    fields = [{"name": name, "offset": off, "datatype": 7, "count": 1}
              for off, name in ((0, "x"), (4, "y"), (8, "z"), (12, "intensity"))]
    msg = {
        "header": header(sec, nsec, frame), "height": 1, "width": n, "fields": fields,
        "is_bigendian": False, "point_step": 16, "row_step": 16 * n,
        "data": pts.tobytes(), "is_dense": True,
    }
    fast = cdr.encode_pointcloud2(sec, nsec, frame, pts)
    assert fast == reference("sensor_msgs/msg/PointCloud2", msg)


def test_cdr_header_and_string_layout_by_hand() -> None:
    # std_msgs/String "ab": encapsulation 00 01 00 00, length 3 (incl. NUL), 'a' 'b' NUL.
    b = cdr.CdrBuffer()
    b.string("ab")
    assert b.getvalue() == b"\x00\x01\x00\x00" + b"\x03\x00\x00\x00ab\x00"
    # A float64 after a 1-byte field is aligned to 8 counted from after the header.
    b = cdr.CdrBuffer()
    b.u8(7)
    b.f64s([1.0])
    assert b.getvalue() == b"\x00\x01\x00\x00\x07" + b"\x00" * 7 + np.float64(1.0).tobytes()


@settings(max_examples=60, deadline=None)
@given(stamps, frame_ids, frame_ids, st.lists(finite, min_size=13, max_size=13))
def test_precompiled_odometry_and_tf_encoders_match(stamp, frame, child, v) -> None:
    sec, nsec = stamp
    odom = cdr.OdometryEncoder(frame, child)(sec, nsec, v[0:3], v[3:7], v[7:10], v[10:13])
    assert odom == cdr.encode_odometry(sec, nsec, frame, child, v[0:3], v[3:7], v[7:10],
                                       v[10:13])
    tf = cdr.TransformEncoder(frame, child)(sec, nsec, v[0:3], v[3:7])
    assert tf == cdr.encode_tf_message([(sec, nsec, frame, child, v[0:3], v[3:7])])


@settings(max_examples=60, deadline=None)
@given(stamps, frame_ids, frame_ids, st.lists(finite, min_size=13, max_size=13))
def test_fast_odometry_decoder_agrees_with_mcap_ros2_decoder(stamp, frame, child, v) -> None:
    from mcap_ros2._dynamic import generate_dynamic

    sec, nsec = stamp
    data = cdr.encode_odometry(sec, nsec, frame, child, v[0:3], v[3:7], v[7:10], v[10:13])
    typename = "nav_msgs/msg/Odometry"
    m = generate_dynamic(typename, schema_text(typename))[typename](data)
    p, o = m.pose.pose.position, m.pose.pose.orientation
    lin, ang = m.twist.twist.linear, m.twist.twist.angular
    expected = (m.header.stamp.sec, m.header.stamp.nanosec, m.header.frame_id,
                m.child_frame_id,
                (p.x, p.y, p.z, o.x, o.y, o.z, o.w, lin.x, lin.y, lin.z, ang.x, ang.y, ang.z))
    assert cdr.decode_odometry(data) == expected
    assert expected[4] == tuple(v)


def marker_dict(m: dict) -> dict:
    """The same marker in mcap_ros2's nested-dict form (all defaults spelled out)."""
    return {
        "header": header(m["sec"], m["nanosec"], m["frame_id"]),
        "ns": m["ns"], "id": m["id"], "type": m["type"], "action": m["action"],
        "pose": {"position": dict(zip("xyz", m["pose"][:3], strict=True)),
                 "orientation": dict(zip("xyzw", m["pose"][3:], strict=True))},
        "scale": dict(zip("xyz", m["scale"], strict=True)),
        "color": dict(zip("rgba", m["color"], strict=True)),
        "lifetime": {"sec": 0, "nanosec": 0}, "frame_locked": False,
        "points": [dict(zip("xyz", p, strict=True)) for p in np.asarray(m["points"]).tolist()],
        "colors": [dict(zip("rgba", c, strict=True)) for c in np.asarray(m["colors"]).tolist()],
        "texture_resource": "",
        "texture": {"header": header(0, 0, ""), "format": "", "data": b""},
        "uv_coordinates": [], "text": m["text"], "mesh_resource": m["mesh_resource"],
        "mesh_file": {"filename": "", "data": b""}, "mesh_use_embedded_materials": False,
    }


f32 = st.floats(-1e3, 1e3, allow_nan=False, width=32)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.fixed_dictionaries({
    "stamp": stamps, "frame_id": frame_ids, "ns": frame_ids, "text": frame_ids,
    "mesh_resource": frame_ids, "id": st.integers(-2**31, 2**31 - 1),
    "type": st.integers(0, 12), "action": st.sampled_from([0, 2, 3]),
    "pose": st.lists(finite, min_size=7, max_size=7),
    "scale": st.lists(finite, min_size=3, max_size=3),
    "color": st.lists(f32, min_size=4, max_size=4),
    "n_points": st.integers(0, 7), "n_colors": st.integers(0, 3), "seed": st.integers(0, 99),
}), max_size=3))
def test_marker_array_matches_reference(specs) -> None:
    markers = []
    for s in specs:
        rng = np.random.default_rng(s["seed"])
        markers.append({
            "sec": s["stamp"][0], "nanosec": s["stamp"][1], "frame_id": s["frame_id"],
            "ns": s["ns"], "id": s["id"], "type": s["type"], "action": s["action"],
            "pose": tuple(s["pose"]), "scale": tuple(s["scale"]), "color": tuple(s["color"]),
            "points": rng.normal(size=(s["n_points"], 3)),
            "colors": rng.uniform(size=(s["n_colors"], 4)).astype(np.float32),
            "text": s["text"], "mesh_resource": s["mesh_resource"],
        })
    msg = {"markers": [marker_dict(m) for m in markers]}
    fast = cdr.encode_marker_array(markers)
    assert fast == reference("visualization_msgs/msg/MarkerArray", msg)


def test_projected_sonar_image_fast_path_equals_the_schema_driven_encoder() -> None:
    """encode_projected_sonar_image (one copy of the pixels) against mcap_ros2's encoder
    built from the embedded marine_acoustic_msgs definition, for frame ids of every
    length modulo 4 (the alignment after the header string)."""
    from mcap_ros2._dynamic import serialize_dynamic

    from uhrisim.ros import cdr
    from uhrisim.ros.msgdefs import schema_text

    typename = "marine_acoustic_msgs/msg/ProjectedSonarImage"
    reference = serialize_dynamic(typename, schema_text(typename))[typename]
    rng = np.random.default_rng(3)
    polar = rng.integers(0, 256, (7, 5), dtype=np.uint8)
    angles = np.linspace(-0.4, 0.4, 5)
    directions = np.stack([np.zeros(5), np.sin(angles), np.cos(angles)], -1)
    ranges = np.linspace(0.1, 45.0, 7)
    for frame in ("a", "ab", "abc", "rov/sonar"):
        msg = {"header": {"stamp": {"sec": 3, "nanosec": 5}, "frame_id": frame},
               "ping_info": {"frequency": 9e5, "sound_speed": 1500.5, "tx_beamwidths": [],
                             "rx_beamwidths": []},
               "beam_directions": [{"x": x, "y": y, "z": z} for x, y, z in directions.tolist()],
               "ranges": ranges.astype(np.float32).tolist(),
               "image": {"is_bigendian": False, "dtype": 0, "beam_count": 5,
                         "data": polar.tobytes()}}
        assert cdr.encode_projected_sonar_image(3, 5, frame, polar, directions, ranges, 9e5,
                                                1500.5) == reference(msg), frame


def test_transform_encoder_of_a_chain_equals_the_general_encoder() -> None:
    """The one-struct encoder of the /tf chain (two transforms, fixed frames) gives the
    bytes of encode_tf_message, for frame names of every length modulo 4 and 8."""
    from uhrisim.ros import cdr
    from uhrisim.ros.convert import tf_chain, tf_chain_frames

    for world in ("m", "ma", "map", "mapp", "world_ned"):
        for agent in ("a", "ab", "abc", "abcd", "videoray"):
            pairs = tf_chain_frames(agent, world)
            chain = tf_chain((1.0, -2.0, 3.5), (0.0, 0.0, 0.6, 0.8))
            general = cdr.encode_tf_message([(7, 9, p, c, t, q)
                                             for (p, c), (t, q) in zip(pairs, chain, strict=True)])
            (t0, q0), second = chain
            assert cdr.TransformEncoder(*pairs[0], pairs[1])(7, 9, t0, q0, second) == general


names = st.text(min_size=0, max_size=12)  # any unicode: utf-8 lengths shift alignment
maybe = st.one_of(st.none(), finite, st.just(-0.0))


@settings(max_examples=60, deadline=None)
@given(stamps, names, names, st.one_of(finite, names))
def test_variable_matches_reference(stamp, name, source, value) -> None:
    sec, nsec = stamp
    kind, number, text = (1, 0.0, value) if isinstance(value, str) else (0, value, "")
    fast = cdr.encode_variable(sec, nsec, name, source, kind, number, text)
    assert fast == reference("uhrisim_msgs/msg/Variable", {
        "header": header(sec, nsec, ""), "name": name, "source": source, "kind": kind,
        "double_value": number, "string_value": text})


@settings(max_examples=60, deadline=None)
@given(stamps, st.tuples(maybe, maybe, maybe), names, st.lists(names, max_size=3),
       st.lists(st.tuples(names, finite), max_size=3), finite, names)
def test_helm_decision_matches_reference(stamp, decided, mode, active, contributions,
                                         total, reason) -> None:
    sec, nsec = stamp
    fast = cdr.encode_helm_decision(sec, nsec, decided, mode, active, contributions, total,
                                    reason)
    assert fast == reference("uhrisim_msgs/msg/HelmDecision", {
        "header": header(sec, nsec, ""),
        **{key: value for (has, field), x in zip(
            (("has_heading", "heading_deg"), ("has_speed", "speed"), ("has_depth", "depth")),
            decided, strict=True) for key, value in ((has, x is not None), (field, x or 0.0))},
        "mode": mode, "active_behaviors": active,
        "contributions": [{"name": n, "value": v} for n, v in contributions],
        "total": total, "all_stop_reason": reason})


@settings(max_examples=40, deadline=None)
@given(stamps, frame_ids, names, names)
def test_event_matches_reference(stamp, frame, kind, detail) -> None:
    sec, nsec = stamp
    assert cdr.encode_event(sec, nsec, frame, kind, detail) == reference(
        "uhrisim_msgs/msg/Event", {"header": header(sec, nsec, frame), "kind": kind,
                                   "detail": detail})
