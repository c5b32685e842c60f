"""MOOS bridge throughput and cost, on loopback through the pure-Python test MOOSDB.

* ``notify_throughput``: notifications per second from one client, through the DB (in its
  own process), into a second client's inbox (end to end: encode, TCP, DB parse and
  fan-out, TCP, decode).
* ``publish_nav``: caller-side cost of one :meth:`MoosAgentBridge.publish_nav` (8 MOOS
  variables incl. NODE_REPORT and the lat/long conversion), connected and disconnected.
  This is what the simulation loop pays; the I/O happens on the client's thread.
* ``wire``: encode/decode rates of the protocol code itself.
* ``burst_latency``: per ``coalesce_s`` of the posting client, the time from the last post
  of a burst of 200 (nothing posted after it) to its arrival in the other client, and
  from a lone post after a quiet spell to its arrival (the test suite checks that both
  arrive without a later post; this measures how soon).

Targets: a 10 Hz bridge for a handful of agents needs well under 1 % of a core
(publish_nav < 100 us), and a MOOS community's traffic (a few thousand
notifications/s for a vehicle with pHelmIvP, pMarineViewer, pNodeReporter) fits with a
margin (> 10 000 notifications/s through the test DB).
"""

from __future__ import annotations

import logging
import time
from typing import Any

from uhrisim.bench import best_rate
from uhrisim.bridges.moos.bridge import MoosAgentBridge
from uhrisim.bridges.moos.client import MoosClient
from uhrisim.bridges.moos.testdb import spawn
from uhrisim.bridges.moos.wire import MoosMessage, MoosStreamParser, encode_packet

PUBLISH_NAV_TARGET_US = 100.0
THROUGHPUT_TARGET_PER_S = 10_000.0


def _throughput(port: int, n: int, batch: int) -> dict[str, Any]:
    pub, sub = MoosClient(max_inbox=n + 1000), MoosClient(max_inbox=n + 1000)
    try:
        pub.connect("127.0.0.1", port, "bench_pub", strict=True)
        sub.connect("127.0.0.1", port, "bench_sub", strict=True)
        sub.register("BENCH_X")
        pub.register("BENCH_ACK")
        # make sure the registration is in place: wait for a first value to come through
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            pub.notify("BENCH_X", -1.0)
            time.sleep(0.01)
            if any(m.key == "BENCH_X" for m in sub.drain()):
                break
        got = 0
        t0 = time.perf_counter()
        for i in range(0, n, batch):
            pub.notify_many([("BENCH_X", float(j)) for j in range(i, min(n, i + batch))])
            got += sum(1 for m in sub.drain() if m.key == "BENCH_X")
        deadline = time.monotonic() + 30.0
        while got < n and time.monotonic() < deadline:
            time.sleep(0.001)
            got += sum(1 for m in sub.drain() if m.key == "BENCH_X")
        elapsed = time.perf_counter() - t0
        return {"notifications": n, "batch": batch, "received": got, "seconds": elapsed,
                "per_s": got / elapsed, "lost": n - got, "dropped_out": pub.dropped_out}
    finally:
        pub.close()
        sub.close()


def _latency(port: int, coalesce_s: float) -> dict[str, float]:
    """Seconds from the last post of a burst, and from a lone post, to their arrival."""
    pub, sub = MoosClient(coalesce_s=coalesce_s), MoosClient()
    key = f"LAT_{int(coalesce_s * 1000)}"
    try:
        pub.connect("127.0.0.1", port, f"lat_pub_{key}", strict=True)
        sub.connect("127.0.0.1", port, f"lat_sub_{key}", strict=True)
        sub.register(key)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and not any(m.key == key for m in sub.drain()):
            pub.notify(key, -1.0)
            time.sleep(0.01)

        def arrival(value: float) -> float:
            """Seconds until ``value`` arrives (after the post just made)."""
            start = time.perf_counter()
            while not any(m.key == key and m.dval == value for m in sub.drain()):
                time.sleep(0.0002)
            return time.perf_counter() - start

        time.sleep(coalesce_s + 0.05)
        for i in range(199):
            pub.notify(key, float(i))
        pub.notify(key, 199.0)
        burst = arrival(199.0)
        time.sleep(coalesce_s + 0.05)
        pub.notify(key, 1e6)
        return {"last_of_burst_s": burst, "lone_post_s": arrival(1e6)}
    finally:
        pub.close()
        sub.close()


def run(quick: bool = False) -> dict[str, Any]:
    n = 5_000 if quick else 100_000
    min_time = 0.05 if quick else 0.5
    out: dict[str, Any] = {"config": {"host": "127.0.0.1", "db": "uhrisim testdb (Python)",
                                      "notifications": n}}
    with spawn(community="bench") as db:
        out["notify_throughput"] = {
            "batched_8": _throughput(db.port, n, 8),
            "single": _throughput(db.port, n // 5, 1),
        }
        out["burst_latency"] = {f"coalesce_{c:g}_s": _latency(db.port, c)
                                for c in (0.0, 0.005, 0.2)}
        bridge = MoosAgentBridge("bench", port=db.port, strict=True)
        try:
            k = [0]

            def call() -> None:
                k[0] += 1
                bridge.publish_nav(k[0] * 0.1, 10.0, -3.0, 2.0, 87.0, 1.2)

            rate = best_rate(call, repeats=200, min_time=min_time)
        finally:
            bridge.close()
    # disconnected: the latest values are kept per variable, nothing is sent
    client_log = logging.getLogger("uhrisim.bridges.moos.client")
    level = client_log.level
    client_log.setLevel(logging.ERROR)  # the expected "cannot connect" warning is noise here
    down = MoosAgentBridge("bench", port=db.port)
    try:
        rate_down = best_rate(lambda: down.publish_nav(0.0, 10.0, -3.0, 2.0, 87.0, 1.2),
                              repeats=200, min_time=min_time)
    finally:
        down.close()
        client_log.setLevel(level)
    out["publish_nav"] = {"connected_us": 1e6 / rate, "disconnected_us": 1e6 / rate_down,
                          "variables_per_call": 8}

    msgs = [MoosMessage.notify(f"NAV_{i}", float(i), 1.7e9, "bench") for i in range(8)]
    pkt = encode_packet(msgs)
    enc = best_rate(lambda: encode_packet(msgs), repeats=500, min_time=min_time)
    dec = best_rate(lambda: MoosStreamParser().feed(pkt), repeats=500, min_time=min_time)
    out["wire"] = {"encode_messages_per_s": enc * 8, "decode_messages_per_s": dec * 8,
                   "packet_bytes_8_doubles": len(pkt)}

    thr = out["notify_throughput"]["batched_8"]["per_s"]
    out["targets"] = {
        "publish_nav_us": PUBLISH_NAV_TARGET_US,
        "notifications_per_s": THROUGHPUT_TARGET_PER_S,
        "meets_target": bool(out["publish_nav"]["connected_us"] < PUBLISH_NAV_TARGET_US
                             and thr > THROUGHPUT_TARGET_PER_S),
    }
    return out


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))
