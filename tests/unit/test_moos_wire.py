"""MOOS v10 wire protocol: the real MOOSDB trace, byte-exact round trips, malformed input.

Provenance: ``tests/data/moos/moos-trace.jsonl`` holds the raw bytes of two real client
connections to a real MOOSDB (its README says where they came from). The expected values below
(DESIRED_HEADING = 123.5, NODE_NOTE = "hello world", NAV_X = 42.25, community "trace",
client name "uPokeDB") are the ones that note says were posted.
"""

from __future__ import annotations

import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.support.moos_trace import trace_chunks, trace_streams
from uhrisim.bridges.moos.wire import (
    HANDSHAKE,
    MESSAGE_MIN_LEN,
    MSG_TYPES,
    MoosMessage,
    MoosProtocolError,
    MoosStreamParser,
    NotifyEncoder,
    decode_handshake,
    decode_message,
    decode_packet,
    encode_message,
    encode_notify,
    encode_packet,
)
from uhrisim.core.errors import BridgeError


def _message_spans(stream: bytes, start: int) -> list[tuple[int, int]]:
    """(offset, length) of every message, walking the framing independently of the parser."""
    spans = []
    pos = start
    while pos < len(stream):
        total, count = struct.unpack_from("<ii", stream, pos)
        p = pos + 9
        for _ in range(count):
            (n,) = struct.unpack_from("<i", stream, p)
            spans.append((p, n))
            p += n
        assert p == pos + total
        pos += total
    return spans


def test_trace_parses_every_byte_and_reserialises_identically():
    chunks = trace_chunks()
    streams = trace_streams()
    assert set(streams) == {(1, "c2s"), (1, "s2c"), (2, "c2s"), (2, "s2c")}
    n_msgs = 0
    for (conn, direction), data in streams.items():
        parser = MoosStreamParser(expect_handshake=direction == "c2s")
        packets = []
        for chunk in chunks[(conn, direction)]:  # exactly what each recv() returned
            packets += parser.feed(chunk)
        assert parser.buffered == 0, f"{conn}/{direction}: bytes left over"
        head = HANDSHAKE if direction == "c2s" else b""
        assert data.startswith(head)
        # every packet re-serialises to the same bytes, and together they are the stream
        assert head + b"".join(encode_packet(p.messages) for p in packets) == data
        # every message re-serialises to its own bytes
        msgs = [m for p in packets for m in p.messages]
        spans = _message_spans(data, len(head))
        assert len(spans) == len(msgs)
        for m, (off, n) in zip(msgs, spans, strict=True):
            assert encode_message(m) == data[off:off + n]
            assert decode_message(data, off)[0] == m
        n_msgs += len(msgs)
    # conn 1: 14 client + 7 DB messages; conn 2: 11 + 10 (handshake hello and welcome included)
    assert n_msgs == 42


def test_trace_semantics():
    streams = trace_streams()
    c2s1 = MoosStreamParser(expect_handshake=True).feed(streams[(1, "c2s")])
    s2c1 = MoosStreamParser().feed(streams[(1, "s2c")])
    hello = c2s1[0].messages[0]
    assert (hello.msg_type, hello.data_type, hello.key, hello.sval) == (
        "i", "S", "asynchronous", b"uPokeDB")
    welcome = s2c1[0].messages[0]
    assert (welcome.msg_type, welcome.sval, welcome.community) == ("W", b"asynchronous", "trace")
    assert welcome.source_aux.startswith("hostname=")
    fwd = {m.key: m for p in s2c1 for m in p.messages if m.msg_type == "N"}
    assert fwd["DESIRED_HEADING"].value == 123.5
    assert fwd["NODE_NOTE"].value == "hello world"
    assert fwd["NODE_NOTE"].dval == -1.0  # unused doubles are -1
    assert fwd["DESIRED_HEADING"].community == "trace"  # the DB fills in the community
    # the DB forwards the poster's message id, source and time unchanged
    posted = {m.key: m for p in c2s1 for m in p.messages if m.msg_type == "N"}
    for k in ("DESIRED_HEADING", "NODE_NOTE"):
        assert (fwd[k].msg_id, fwd[k].source, fwd[k].time) == (
            posted[k].msg_id, posted[k].source, posted[k].time)
    s2c2 = MoosStreamParser().feed(streams[(2, "s2c")])
    nav = [m for p in s2c2 for m in p.messages if m.key == "NAV_X"]
    assert [m.value for m in nav] == [42.25]
    # timing: the DB echoes the client's time and puts its own in dval
    timing = [m for p in s2c1 for m in p.messages if m.msg_type == "T"]
    sent_t = [m for p in c2s1 for m in p.messages if m.msg_type == "T"]
    assert [m.time for m in timing] == [m.time for m in sent_t]
    assert all(m.key == "_async_timing" and m.dval > 1.7e9 for m in timing)


def test_trace_byte_by_byte_and_all_at_once_agree():
    streams = trace_streams()
    for (_, direction), data in streams.items():
        hs = direction == "c2s"
        whole = MoosStreamParser(expect_handshake=hs).feed(data)
        p = MoosStreamParser(expect_handshake=hs)
        single = [pk for i in range(len(data)) for pk in p.feed(data[i:i + 1])]
        assert single == whole


def test_encoding_matches_struct_layout_from_the_spec():
    m = MoosMessage(7, "N", "S", "src", "aux", "comm", "KEY", 1.5, -1.0, -1.0, b"hello")
    expected_body = (struct.pack("<i", 7) + b"NS"
                     + struct.pack("<i", 3) + b"src" + struct.pack("<i", 3) + b"aux"
                     + struct.pack("<i", 4) + b"comm" + struct.pack("<i", 3) + b"KEY"
                     + struct.pack("<ddd", 1.5, -1.0, -1.0) + struct.pack("<i", 5) + b"hello")
    msg = struct.pack("<i", 4 + len(expected_body)) + expected_body
    assert encode_message(m) == msg
    pkt = encode_packet([m, m])
    assert pkt == struct.pack("<iiB", 9 + 2 * len(msg), 2, 0) + msg + msg
    assert decode_packet(pkt).messages == (m, m)
    assert len(encode_message(MoosMessage())) == MESSAGE_MIN_LEN


def test_handshake():
    assert len(HANDSHAKE) == 32 and HANDSHAKE.startswith(b"ELKS CAN'T DANCE 2/8/10\x00")
    assert decode_handshake(HANDSHAKE) == "ELKS CAN'T DANCE 2/8/10"
    with pytest.raises(MoosProtocolError, match="not b\"ELKS"):
        decode_handshake(b"GET / HTTP/1.1\r\n".ljust(32, b"\0"))
    with pytest.raises(MoosProtocolError, match="expected 32 bytes"):
        decode_handshake(HANDSHAKE[:10])


def test_notify_constructor_types():
    assert MoosMessage.notify("A", 3, 1.0).data_type == "D"
    assert MoosMessage.notify("A", 3, 1.0).value == 3.0
    assert MoosMessage.notify("A", "x=1", 1.0).value == "x=1"
    assert MoosMessage.notify("A", b"\x00\xff", 1.0).data_type == "B"
    with pytest.raises(TypeError):
        MoosMessage.notify("A", [1], 1.0)  # type: ignore[arg-type]


# -- malformed input --------------------------------------------------------------------

_GOOD = encode_packet([MoosMessage.notify("NAV_X", 42.25, 1.0, "sim"),
                       MoosMessage.notify("NOTE", "hi", 2.0, "sim")])


def _patch_i32(buf: bytes, off: int, value: int) -> bytes:
    return buf[:off] + struct.pack("<i", value) + buf[off + 4:]


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (_patch_i32(_GOOD, 0, 4), "below the 9-byte header"),
        (_patch_i32(_GOOD, 0, -5), "below the 9-byte header"),
        (_patch_i32(_GOOD, 0, 2**31 - 1), "exceeds the cap"),
        (_patch_i32(_GOOD, 4, -1), "message count -1"),
        (_patch_i32(_GOOD, 4, 3), "cannot fit|past the available|trailing|truncated"),
        (_patch_i32(_GOOD, 4, 1), "trailing bytes"),
        (_GOOD[:8] + b"\x01" + _GOOD[9:], "compressed packets are not supported"),
        (_GOOD[:8] + b"\x07" + _GOOD[9:], "compression flag 7"),
        (_patch_i32(_GOOD, 9, 10), "below the minimum"),
        (_patch_i32(_GOOD, 9, 10_000), "runs .* past"),
        (_GOOD[:17] + b"Z" + _GOOD[18:], "unknown message type b'Z'"),
        (_GOOD[:18] + b"Q" + _GOOD[19:], "unknown data type b'Q'"),
        (_patch_i32(_GOOD, 19, -3), "negative length -3 of source"),
        (_patch_i32(_GOOD, 19, 500), "source of 500 bytes runs past"),
    ],
)
def test_malformed_packets_raise_typed_errors(data, match):
    with pytest.raises(MoosProtocolError, match=match):
        decode_packet(data)
    # the stream parser may wait for more bytes first; given them, it must fail too
    with pytest.raises(MoosProtocolError):
        MoosStreamParser().feed(data + bytes(4096))
    assert issubclass(MoosProtocolError, BridgeError)


def test_stream_parser_is_poisoned_after_an_error():
    p = MoosStreamParser()
    with pytest.raises(MoosProtocolError):
        p.feed(_patch_i32(_GOOD, 0, -5))
    with pytest.raises(MoosProtocolError):
        p.feed(_GOOD)  # cannot resynchronise a byte stream


def test_absurd_size_rejected_from_header_alone():
    # 9 header bytes announcing 1 GB: rejected before any payload arrives (no buffering)
    p = MoosStreamParser(max_packet_bytes=1 << 20)
    with pytest.raises(MoosProtocolError, match="exceeds the cap"):
        p.feed(struct.pack("<iiB", 1 << 30, 1, 0))


def test_several_packets_in_one_chunk_and_split_over_chunks():
    a = encode_packet([MoosMessage.notify("A", 1.0, 1.0)])
    b = encode_packet([MoosMessage.notify("B", "two", 2.0), MoosMessage.notify("C", 3.0, 3.0)])
    p = MoosStreamParser()
    out = p.feed(a + b + a[:5])
    assert [m.key for pk in out for m in pk.messages] == ["A", "B", "C"]
    assert p.buffered == 5
    out = p.feed(a[5:])
    assert [m.key for pk in out for m in pk.messages] == ["A"] and p.buffered == 0


def _parse_or_typed_error(data: bytes) -> None:
    """Parse ``data`` both ways; a success must re-serialise to exactly the same bytes."""
    try:
        pkt = decode_packet(data)
    except MoosProtocolError:
        pass
    else:
        assert encode_packet(pkt.messages) == data
    for hs in (False, True):
        parser = MoosStreamParser(expect_handshake=hs)
        try:
            got = parser.feed(data)
        except MoosProtocolError:
            continue
        body = b"".join(encode_packet(p.messages) for p in got)
        assert data.startswith((HANDSHAKE if parser.handshake else b"") + body)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300))
def test_fuzz_random_bytes_only_typed_errors(data):
    _parse_or_typed_error(data)


@settings(max_examples=300, deadline=None)
@given(st.integers(0, len(_GOOD) - 1), st.integers(0, 255), st.integers(1, 40))
def test_fuzz_corrupted_valid_packet_only_typed_errors(pos, byte, cut):
    bad = _GOOD[:pos] + bytes([byte]) + _GOOD[pos + 1:]
    _parse_or_typed_error(bad)
    _parse_or_typed_error(bad[:-cut])


_text = st.text(max_size=20)
_msg = st.builds(
    MoosMessage,
    msg_id=st.integers(-(2**31), 2**31 - 1),
    msg_type=st.sampled_from(sorted(MSG_TYPES)),
    data_type=st.sampled_from(["D", "S", "B"]),
    source=_text, source_aux=_text, community=_text, key=_text,
    time=st.floats(allow_nan=False), dval=st.floats(allow_nan=False),
    dval2=st.floats(allow_nan=False), sval=st.binary(max_size=40),
)


@settings(max_examples=200, deadline=None)
@given(st.lists(_msg, max_size=5), st.integers(1, 50))
def test_roundtrip_random_messages_any_chunking(msgs, chunk):
    data = encode_packet(msgs) * 2
    p = MoosStreamParser()
    got = [pk for i in range(0, len(data), chunk) for pk in p.feed(data[i:i + chunk])]
    assert [pk.messages for pk in got] == [tuple(msgs)] * 2


@settings(max_examples=200, deadline=None)
@given(_text, st.one_of(st.floats(allow_nan=False), st.integers(-10**6, 10**6), _text,
                        st.binary(max_size=30)),
       st.floats(allow_nan=False), _text, st.integers(-(2**31), 2**31 - 1))
def test_fast_notify_encoding_equals_the_dataclass_path(key, value, t, source, msg_id):
    assert encode_notify(key, value, t, source, msg_id) == encode_message(
        MoosMessage.notify(key, value, t, source, msg_id=msg_id))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(_text, st.one_of(st.floats(), st.integers(-10**6, 10**6), _text,
                                           st.binary(max_size=30))), max_size=6),
       st.floats(allow_nan=False), _text, st.integers(-(2**31), 2**31 - 1))
def test_notify_encoder_equals_encode_notify(posts, t, source, msg_id):
    """The cached per-variable layout gives encode_notify's bytes, for every value type
    and for a variable posted again (the cache hit); NaN and infinities too."""
    enc = NotifyEncoder(source)
    for key, value in posts + posts:
        assert enc(key, value, t, msg_id) == encode_notify(key, value, t, source, msg_id)
