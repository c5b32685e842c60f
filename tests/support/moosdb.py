"""Test MOOSDB: the implementation ships in :mod:`uhrisim.bridges.moos.testdb`.

Tests use ``uhrisim.bridges.moos.testdb.spawn()`` (a child process on 127.0.0.1, ephemeral
port). This file re-exports it and can run it directly: ``python tests/support/moosdb.py
--port 9000``.
"""

from uhrisim.bridges.moos.testdb import MoosTestDB, TestDBProcess, main, spawn

__all__ = ["MoosTestDB", "TestDBProcess", "main", "spawn"]

if __name__ == "__main__":
    raise SystemExit(main())
