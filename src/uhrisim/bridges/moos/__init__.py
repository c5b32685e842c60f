"""MOOS-IvP bridge: the MOOS v10 wire protocol, a pure-Python client and the agent bridge.

No MOOS installation is needed. See ``docs/bridges-moos.md``.
"""

from uhrisim.bridges.moos.wire import (
    MoosMessage,
    MoosPacket,
    MoosProtocolError,
    MoosStreamParser,
    decode_message,
    decode_packet,
    encode_message,
    encode_packet,
)

__all__ = [
    "MoosMessage",
    "MoosPacket",
    "MoosProtocolError",
    "MoosStreamParser",
    "decode_message",
    "decode_packet",
    "encode_message",
    "encode_packet",
]
