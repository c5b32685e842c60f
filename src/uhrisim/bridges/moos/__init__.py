"""MOOS-IvP bridge: the MOOS v10 wire protocol, a pure-Python client and the agent bridge.

No MOOS installation is needed. See ``docs/bridges-moos.md``. The simulation hook lives
in :mod:`uhrisim.bridges.moos.hook` (imported on demand: it pulls in the simulator).
"""

from uhrisim.bridges.moos.bridge import MoosAgentBridge
from uhrisim.bridges.moos.client import MoosClient
from uhrisim.bridges.moos.geodesy import latlon_from_local, local_from_latlon
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
    "MoosAgentBridge",
    "MoosClient",
    "MoosMessage",
    "MoosPacket",
    "MoosProtocolError",
    "MoosStreamParser",
    "decode_message",
    "decode_packet",
    "encode_message",
    "encode_packet",
    "latlon_from_local",
    "local_from_latlon",
]
