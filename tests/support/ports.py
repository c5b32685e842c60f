"""Loopback ports for tests of refused connections."""

from __future__ import annotations

import socket


def held_port() -> socket.socket:
    """A loopback port nothing listens on, held bound (not listening: a connection is
    refused) until the socket is closed, so no other process starts listening there."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    return s
