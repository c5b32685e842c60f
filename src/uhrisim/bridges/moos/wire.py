"""MOOS v10 wire protocol: messages, packets, the handshake and an incremental stream parser.

Facts (``docs/reference/moos-wire.md``; MOOS v10 ``MOOSCore/Core/libMOOS/Comms``:
CMOOSMsg, CMOOSCommPkt, MOOSAsyncCommClient), checked byte for byte against the real
MOOSDB traffic in ``moos-trace.jsonl``:

* all integers int32, all doubles float64, **little-endian**; a string is an int32 length
  followed by the raw bytes (no terminator);
* handshake: the client sends 32 bytes, ASCII ``ELKS CAN'T DANCE 2/8/10`` NUL-padded;
* packet: ``int32 total_bytes (header included) | int32 n_messages | uint8 compressed``
  (9-byte header), then the messages back to back;
* message: ``int32 length (including itself) | int32 id | char type | char data_type |
  str source | str source_aux | str community | str key | double time | double dval |
  double dval2 | str sval``.

Strings are carried as bytes on the wire. Text fields (source, key, ...) are decoded as
UTF-8 with ``surrogateescape`` so that *any* byte string survives a decode/encode round
trip unchanged; ``sval`` is kept as raw ``bytes``.

Malformed input raises :class:`MoosProtocolError` (a :class:`~uhrisim.core.errors.BridgeError`),
never ``struct.error``/``IndexError``/``UnicodeDecodeError``.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from uhrisim.core.errors import BridgeError

__all__ = [
    "DATA_TYPES",
    "DEFAULT_MAX_MESSAGES",
    "DEFAULT_MAX_PACKET_BYTES",
    "HANDSHAKE",
    "HANDSHAKE_LEN",
    "MESSAGE_MIN_LEN",
    "MSG_TYPES",
    "PACKET_HEADER_LEN",
    "MoosMessage",
    "MoosPacket",
    "MoosProtocolError",
    "MoosStreamParser",
    "NotifyEncoder",
    "decode_handshake",
    "decode_message",
    "decode_packet",
    "encode_handshake",
    "encode_message",
    "encode_notify",
    "encode_packet",
    "encode_packet_raw",
]


class MoosProtocolError(BridgeError):
    """A MOOS peer sent bytes that are not valid MOOS v10 wire protocol."""


#: Protocol string of MOOS v10 (``MOOS_PROTOCOL_STRING``), NUL-padded to 32 bytes.
HANDSHAKE_PROTOCOL = b"ELKS CAN'T DANCE 2/8/10"
HANDSHAKE_LEN = 32
HANDSHAKE = HANDSHAKE_PROTOCOL.ljust(HANDSHAKE_LEN, b"\x00")
#: ``int32 total | int32 n_messages | uint8 compressed``.
PACKET_HEADER_LEN = 9
#: Smallest message: length, id, 2 type chars, 5 empty strings (4 bytes each), 3 doubles.
MESSAGE_MIN_LEN = 4 + 4 + 2 + 5 * 4 + 24
#: Caps on what we accept from a peer (a sane MOOS packet is kilobytes; the C++ default
#: comms buffer is a few MB). A header beyond them is treated as corruption.
DEFAULT_MAX_PACKET_BYTES = 64 * 1024 * 1024
DEFAULT_MAX_MESSAGES = 1_000_000

#: Message types (CMOOSMsg ``m_cMsgType``).
MSG_TYPES: dict[str, str] = {
    "N": "notify",
    "R": "register",
    "U": "unregister",
    "*": "wildcard register",
    "/": "wildcard unregister",
    "C": "command",
    "A": "anonymous",
    ".": "null",
    "i": "data (handshake)",
    "K": "poison",
    "W": "welcome",
    "Q": "server request",
    "T": "timing",
    "^": "terminate",
    "~": "not set",
}
#: Data types (CMOOSMsg ``m_cDataType``): double, string, binary string.
DATA_TYPES: dict[str, str] = {"D": "double", "S": "string", "B": "binary"}

_I32 = struct.Struct("<i")
_HDR = struct.Struct("<iiB")
_ID_TYPES = struct.Struct("<icc")
_DOUBLES = struct.Struct("<ddd")
_ENC = "utf-8"
_ERRS = "surrogateescape"


def _text(value: str) -> bytes:
    return value.encode(_ENC, _ERRS)


@dataclass(frozen=True, slots=True)
class MoosMessage:
    """One CMOOSMsg, exactly as on the wire.

    Field names follow CMOOSMsg. ``time`` is MOOS time (seconds since the Unix epoch,
    time-warped); ``dval``/``dval2`` are the double payloads (unused = -1.0 by MOOS
    convention); ``sval`` the string/binary payload as raw bytes (a ``str`` given to the
    constructor is UTF-8 encoded). ``msg_type``/``data_type`` are single ASCII chars.
    """

    msg_id: int = -1
    msg_type: str = "~"
    data_type: str = "D"
    source: str = ""
    source_aux: str = ""
    community: str = ""
    key: str = ""
    time: float = -1.0
    dval: float = -1.0
    dval2: float = -1.0
    sval: bytes = field(default=b"")

    def __post_init__(self) -> None:
        if isinstance(self.sval, str):
            object.__setattr__(self, "sval", _text(self.sval))
        elif not isinstance(self.sval, bytes):
            object.__setattr__(self, "sval", bytes(self.sval))
        if self.msg_type not in MSG_TYPES:
            raise MoosProtocolError(f"MoosMessage: unknown message type {self.msg_type!r}")
        if self.data_type not in DATA_TYPES:
            raise MoosProtocolError(f"MoosMessage: unknown data type {self.data_type!r}")

    # -- convenience constructors -------------------------------------------------------
    @classmethod
    def notify(
        cls,
        key: str,
        value: float | str | bytes,
        time: float,
        source: str = "",
        *,
        msg_id: int = -1,
        community: str = "",
        source_aux: str = "",
    ) -> MoosMessage:
        """A notification ``N``: a double (``D``), a string (``S``) or binary data (``B``)."""
        dtype, dval, sval = _notify_data(key, value)
        return cls(msg_id, "N", dtype, source, source_aux, community, key, float(time),
                   dval, -1.0, sval)

    @classmethod
    def register(
        cls, key: str, interval: float, time: float, source: str = "", *, msg_id: int = -1
    ) -> MoosMessage:
        """A registration ``R`` for ``key`` (dval = minimum interval in s, 0 = every change)."""
        return cls(msg_id, "R", "D", source, "", "", key, float(time), float(interval), -1.0)

    # -- views --------------------------------------------------------------------------
    @property
    def is_double(self) -> bool:
        return self.data_type == "D"

    @property
    def string(self) -> str:
        """``sval`` decoded as UTF-8 (undecodable bytes kept as surrogate escapes)."""
        return self.sval.decode(_ENC, _ERRS)

    @property
    def value(self) -> float | str | bytes:
        """The payload: ``dval`` for doubles, ``str`` for strings, ``bytes`` for binary."""
        if self.data_type == "D":
            return self.dval
        if self.data_type == "S":
            return self.string
        return self.sval


@dataclass(frozen=True, slots=True)
class MoosPacket:
    """One CMOOSCommPkt: messages plus the (always 0 in practice) compression flag."""

    messages: tuple[MoosMessage, ...]
    compressed: int = 0


# -- encoding ---------------------------------------------------------------------------


def encode_message(msg: MoosMessage) -> bytes:
    """Serialise one message (CMOOSMsg::Serialize, little-endian)."""
    s = _text(msg.source)
    a = _text(msg.source_aux)
    c = _text(msg.community)
    k = _text(msg.key)
    v = msg.sval
    length = MESSAGE_MIN_LEN + len(s) + len(a) + len(c) + len(k) + len(v)
    return b"".join((
        _I32.pack(length),
        _ID_TYPES.pack(msg.msg_id, msg.msg_type.encode("ascii"), msg.data_type.encode("ascii")),
        _I32.pack(len(s)), s,
        _I32.pack(len(a)), a,
        _I32.pack(len(c)), c,
        _I32.pack(len(k)), k,
        _DOUBLES.pack(msg.time, msg.dval, msg.dval2),
        _I32.pack(len(v)), v,
    ))


def encode_packet(messages: list[MoosMessage] | tuple[MoosMessage, ...]) -> bytes:
    """Serialise messages into one packet (CMOOSCommPkt::Serialize, uncompressed)."""
    return encode_packet_raw([encode_message(m) for m in messages])


def encode_packet_raw(encoded: list[bytes]) -> bytes:
    """One packet from already-serialised messages (see :func:`encode_notify`)."""
    body = b"".join(encoded)
    return _HDR.pack(PACKET_HEADER_LEN + len(body), len(encoded), 0) + body


_NOTIFY_D = struct.Struct("<iicci")


def _notify_data(key: str, value: float | str | bytes) -> tuple[str, float, bytes]:
    """(data type, dval, sval) of a notification: a number -> ("D", value, b""), a string
    -> ("S", -1, UTF-8 bytes), binary -> ("B", -1, the bytes); anything else TypeError."""
    if isinstance(value, bool | int | float):
        return "D", float(value), b""
    if isinstance(value, str):
        return "S", -1.0, _text(value)
    if isinstance(value, bytes | bytearray | memoryview):
        return "B", -1.0, bytes(value)
    raise TypeError(f"MOOS notify {key!r}: value must be float, str or bytes, "
                    f"not {type(value).__name__}")


def encode_notify(key: str, value: float | str | bytes, time: float, source: str,
                  msg_id: int) -> bytes:
    """Fast path: the bytes of ``encode_message(MoosMessage.notify(key, value, time,
    source, msg_id=msg_id))`` without building the dataclass (the hot path of a bridge
    posting many variables per tick; equality is tested)."""
    s = _text(source)
    k = _text(key)
    dtype, dval, v = _notify_data(key, value)
    length = MESSAGE_MIN_LEN + len(s) + len(k) + len(v)
    return b"".join((
        _NOTIFY_D.pack(length, msg_id, b"N", dtype.encode("ascii"), len(s)), s,
        b"\x00\x00\x00\x00\x00\x00\x00\x00",  # empty source_aux and community
        _I32.pack(len(k)), k,
        _DOUBLES.pack(float(time), dval, -1.0),
        _I32.pack(len(v)), v,
    ))


class NotifyEncoder:
    """:func:`encode_notify` for one source, faster for numbers: the constant bytes of
    each variable's double notification (length, type, source, key) are laid out once
    in a precompiled ``struct``, so a post is one ``pack``. Strings and binary data take
    :func:`encode_notify`. Same bytes (tested)."""

    __slots__ = ("_doubles", "_source", "_src")

    def __init__(self, source: str) -> None:
        self._source = source
        self._src = _text(source)
        self._doubles: dict[str, tuple[struct.Struct, int, bytes]] = {}

    def __call__(self, key: str, value: float | str | bytes, time: float, msg_id: int
                 ) -> bytes:
        if type(value) is not float:  # int, bool, str, bytes: the general path
            return encode_notify(key, value, time, self._source, msg_id)
        laid = self._doubles.get(key)
        if laid is None:
            k, s = _text(key), self._src
            laid = self._doubles[key] = (
                struct.Struct(f"<iicci{len(s)}s8xi{len(k)}s3di"), MESSAGE_MIN_LEN + len(s)
                + len(k), k)
        st, length, k = laid
        s = self._src
        return st.pack(length, msg_id, b"N", b"D", len(s), s, len(k), k, time, value, -1.0, 0)


def encode_handshake() -> bytes:
    """The 32 bytes a v10 client sends first: the protocol string, NUL-padded."""
    return HANDSHAKE


# -- decoding ---------------------------------------------------------------------------


def decode_handshake(data: bytes) -> str:
    """Check a 32-byte handshake; return the protocol string it carries."""
    if len(data) != HANDSHAKE_LEN:
        raise MoosProtocolError(
            f"MOOS handshake: expected {HANDSHAKE_LEN} bytes, got {len(data)}")
    proto = bytes(data).rstrip(b"\x00")
    if proto != HANDSHAKE_PROTOCOL:
        raise MoosProtocolError(
            f"MOOS handshake: protocol {proto[:32]!r} is not {HANDSHAKE_PROTOCOL!r} "
            "(an old MOOS client, or not MOOS at all)")
    return proto.decode("ascii")


def _read_str(buf: bytes, pos: int, end: int, what: str, where: str) -> tuple[bytes, int]:
    if pos + 4 > end:
        raise MoosProtocolError(f"{where}: truncated before the length of {what}")
    (n,) = _I32.unpack_from(buf, pos)
    pos += 4
    if n < 0:
        raise MoosProtocolError(f"{where}: negative length {n} of {what}")
    if pos + n > end:
        raise MoosProtocolError(
            f"{where}: {what} of {n} bytes runs past the end of the message")
    return bytes(buf[pos:pos + n]), pos + n


def decode_message(buf: bytes, offset: int = 0, end: int | None = None) -> tuple[MoosMessage, int]:
    """Parse one message at ``offset`` (not past ``end``); return it and the next offset."""
    end = len(buf) if end is None else end
    where = f"MOOS message at byte {offset}"
    if offset + 4 > end:
        raise MoosProtocolError(f"{where}: truncated before its length field")
    (length,) = _I32.unpack_from(buf, offset)
    if length < MESSAGE_MIN_LEN:
        raise MoosProtocolError(
            f"{where}: length {length} is below the minimum {MESSAGE_MIN_LEN}")
    stop = offset + length
    if stop > end:
        raise MoosProtocolError(
            f"{where}: length {length} runs {stop - end} bytes past the available data")
    msg_id, t, d = _ID_TYPES.unpack_from(buf, offset + 4)
    try:
        msg_type = t.decode("ascii")
        data_type = d.decode("ascii")
    except UnicodeDecodeError:
        msg_type, data_type = repr(t), repr(d)
    if msg_type not in MSG_TYPES:
        raise MoosProtocolError(f"{where}: unknown message type {t!r}")
    if data_type not in DATA_TYPES:
        raise MoosProtocolError(f"{where}: unknown data type {d!r}")
    pos = offset + 10
    source, pos = _read_str(buf, pos, stop, "source", where)
    source_aux, pos = _read_str(buf, pos, stop, "source_aux", where)
    community, pos = _read_str(buf, pos, stop, "community", where)
    key, pos = _read_str(buf, pos, stop, "key", where)
    if pos + 24 > stop:
        raise MoosProtocolError(f"{where}: truncated in the time/dval/dval2 doubles")
    time, dval, dval2 = _DOUBLES.unpack_from(buf, pos)
    pos += 24
    sval, pos = _read_str(buf, pos, stop, "sval", where)
    if pos != stop:
        raise MoosProtocolError(
            f"{where}: declared length {length} but the fields use {pos - offset} bytes")
    msg = MoosMessage(
        msg_id, msg_type, data_type,
        source.decode(_ENC, _ERRS), source_aux.decode(_ENC, _ERRS),
        community.decode(_ENC, _ERRS), key.decode(_ENC, _ERRS),
        time, dval, dval2, sval,
    )
    return msg, stop


def _check_header(total: int, count: int, compressed: int, where: str,
                  max_packet_bytes: int, max_messages: int) -> None:
    if total < PACKET_HEADER_LEN:
        raise MoosProtocolError(
            f"{where}: packet size {total} is below the {PACKET_HEADER_LEN}-byte header")
    if total > max_packet_bytes:
        raise MoosProtocolError(
            f"{where}: packet size {total} exceeds the cap of {max_packet_bytes} bytes")
    if count < 0 or count > max_messages:
        raise MoosProtocolError(f"{where}: message count {count} out of range")
    if count * MESSAGE_MIN_LEN > total - PACKET_HEADER_LEN:
        raise MoosProtocolError(
            f"{where}: {count} messages cannot fit in a {total}-byte packet")
    if compressed not in (0, 1):
        raise MoosProtocolError(f"{where}: compression flag {compressed} is not 0 or 1")
    if compressed:
        raise MoosProtocolError(f"{where}: compressed packets are not supported")


def decode_packet(
    data: bytes,
    *,
    max_packet_bytes: int = DEFAULT_MAX_PACKET_BYTES,
    max_messages: int = DEFAULT_MAX_MESSAGES,
) -> MoosPacket:
    """Parse exactly one complete packet (``len(data)`` must equal its declared size)."""
    where = "MOOS packet"
    if len(data) < PACKET_HEADER_LEN:
        raise MoosProtocolError(f"{where}: {len(data)} bytes, shorter than the header")
    total, count, compressed = _HDR.unpack_from(data, 0)
    _check_header(total, count, compressed, where, max_packet_bytes, max_messages)
    if total != len(data):
        raise MoosProtocolError(f"{where}: declares {total} bytes but {len(data)} were given")
    return _decode_body(data, 0, total, count, compressed, where)


def _decode_body(buf: bytes, start: int, total: int, count: int, compressed: int,
                 where: str) -> MoosPacket:
    pos = start + PACKET_HEADER_LEN
    stop = start + total
    msgs = []
    for _ in range(count):
        m, pos = decode_message(buf, pos, stop)
        msgs.append(m)
    if pos != stop:
        raise MoosProtocolError(
            f"{where}: {stop - pos} trailing bytes after {count} messages")
    return MoosPacket(tuple(msgs), compressed)


class MoosStreamParser:
    """Incremental parser for one direction of a MOOS TCP stream.

    ``feed(chunk)`` accepts whatever ``recv`` returned and returns the packets it
    completed (zero, one or several); partial packets wait for the next chunk. With
    ``expect_handshake=True`` (the server side of a connection) the first 32 bytes must
    be the protocol handshake; it is checked and kept in :attr:`handshake`.

    Any malformed input raises :class:`MoosProtocolError`; the parser is then poisoned
    (every later ``feed`` raises the same error) because a byte stream cannot be
    re-synchronised - the caller should drop the connection.
    """

    def __init__(
        self,
        *,
        expect_handshake: bool = False,
        max_packet_bytes: int = DEFAULT_MAX_PACKET_BYTES,
        max_messages: int = DEFAULT_MAX_MESSAGES,
    ) -> None:
        self._buf = bytearray()
        self._need_handshake = expect_handshake
        self.handshake: str | None = None
        self._max_bytes = max_packet_bytes
        self._max_msgs = max_messages
        self._error: MoosProtocolError | None = None
        self._consumed = 0  # stream offset of _buf[0], for error messages

    @property
    def buffered(self) -> int:
        """Bytes received but not yet part of a complete packet."""
        return len(self._buf)

    def feed(self, chunk: bytes) -> list[MoosPacket]:
        if self._error is not None:
            raise self._error
        self._buf += chunk
        try:
            return self._drain()
        except MoosProtocolError as exc:
            self._error = exc
            raise

    def _drain(self) -> list[MoosPacket]:
        buf = self._buf
        out: list[MoosPacket] = []
        pos = 0
        if self._need_handshake:
            if len(buf) < HANDSHAKE_LEN:
                return out
            self.handshake = decode_handshake(bytes(buf[:HANDSHAKE_LEN]))
            self._need_handshake = False
            pos = HANDSHAKE_LEN
        view = buf  # parsed in place; only complete packets are sliced out
        n = len(view)
        while n - pos >= PACKET_HEADER_LEN:
            total, count, compressed = _HDR.unpack_from(view, pos)
            where = f"MOOS packet at stream byte {self._consumed + pos}"
            _check_header(total, count, compressed, where, self._max_bytes, self._max_msgs)
            if n - pos < total:
                break
            out.append(_decode_body(view, pos, total, count, compressed, where))
            pos += total
        if pos:
            del buf[:pos]
            self._consumed += pos
        return out
