"""Wait until a MOOS client's registrations are in place at the DB, by an echo.

A client sends its registrations and notifications over one socket, in order, and the DB
handles them in order; so when a probe variable the client registered and then posted
comes back, every registration sent before it is in place. Waiting for that echo replaces
a fixed sleep (a guess at how long the DB takes, which fails on a busy machine).
"""

from __future__ import annotations

import time

from uhrisim.bridges.moos.client import MoosClient
from uhrisim.bridges.moos.wire import MoosMessage


def wait_registered(client: MoosClient, timeout_s: float = 30.0) -> list[MoosMessage]:
    """Block until ``client``'s registrations so far have reached the DB (at most
    ``timeout_s`` s, then AssertionError); returns the other mail drained meanwhile,
    oldest first."""
    probe = f"{client.name.upper()}_REGISTERED"
    client.register(probe)
    client.notify(probe, "true")
    other: list[MoosMessage] = []
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        mail = client.drain()
        other += [m for m in mail if m.key != probe]
        if len(other) < len(mail):
            return other
        time.sleep(0.005)
    raise AssertionError(f"MOOS client {client.name!r}: its registrations did not reach "
                         f"the DB within {timeout_s:.0f} s ({client.status})")


def wait_for_clients(port: int, names: set[str], timeout_s: float = 300.0) -> None:
    """Block until the DB on ``port`` (127.0.0.1) lists every one of ``names`` among its
    clients (its ``DB_CLIENTS``, posted once a second); AssertionError after ``timeout_s``
    (generous: a child process's start on a busy machine)."""
    with MoosClient() as watcher:
        watcher.connect("127.0.0.1", port, "client_watcher", strict=True)
        watcher.register("DB_CLIENTS")
        listed: set[str] = set()
        deadline = time.monotonic() + timeout_s
        while not names <= listed:
            assert time.monotonic() < deadline, (
                f"MOOS clients {sorted(names - listed)} not at the DB within {timeout_s:.0f} s")
            for m in watcher.drain():
                if m.key == "DB_CLIENTS":
                    listed = set(str(m.value).split(","))
            time.sleep(0.05)
