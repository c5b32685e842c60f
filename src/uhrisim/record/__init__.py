"""Recording runs: MCAP files with ROS 2 message schemas, and reading them back.

``McapRecorder`` is the MCAP output of the ROS translation (:mod:`uhrisim.ros`),
``McapRecordingHook`` the simulation's read-only recording hook; ``reader`` reads the
files back (tolerating a run killed half-way). Frames: ROS REP-103 (ENU world, FLU
body) inside the files, converted from uhrisim's NED/FRD by :mod:`uhrisim.ros.convert`.
"""

from uhrisim.record.hook import McapRecordingHook
from uhrisim.record.mcap_recorder import McapRecorder
from uhrisim.record.reader import (
    DecodedMessage,
    OdometryTrack,
    RecordingSummary,
    iter_messages,
    iter_raw_messages,
    read_odometry,
    summarize,
)
from uhrisim.record.recover import is_complete, recover, recover_in_place

__all__ = [
    "DecodedMessage",
    "McapRecorder",
    "McapRecordingHook",
    "OdometryTrack",
    "RecordingSummary",
    "is_complete",
    "iter_messages",
    "iter_raw_messages",
    "read_odometry",
    "recover",
    "recover_in_place",
    "summarize",
]
