"""What the plain-rclpy listeners of tests/support make of stamps and tf2_msgs/TFMessage
(imported by those scripts from their own folder; no uhrisim, no rclpy imports)."""

from __future__ import annotations


def stamp_key(header) -> str:
    """A header's stamp as ``"sec.nanosec"`` (nanoseconds zero-padded to 9 digits)."""
    return f"{header.stamp.sec}.{header.stamp.nanosec:09d}"


def transform_rows(msg) -> list:
    """A TFMessage's transforms as ``[parent, child, [tx, ty, tz], [qx, qy, qz, qw]]``."""
    out = []
    for ts in msg.transforms:
        t, q = ts.transform.translation, ts.transform.rotation
        out.append([ts.header.frame_id, ts.child_frame_id, [t.x, t.y, t.z],
                    [q.x, q.y, q.z, q.w]])
    return out
