"""Guard: the test suite reads nothing beside the repository.

A bare clone (CI, a new user) has nothing next to it, so a test that reads a sibling
folder passes only on machines that happen to have one. An audit hook (PEP 578) watches
every ``open``, ``os.listdir`` and ``os.scandir`` of the test process; a path in the
repository's parent folder but outside the repository is recorded in :data:`offences`
(tests/conftest.py fails the test that did it). Paths elsewhere (the Python install,
/proc, the temporary folder) are not this guard's business.

When the repository sits directly in the temporary folder, everything temporary is
"beside" it too: only the names that were there when the session started, less pytest's
and tempfile's own (``pytest-of-*``, ``tmp*``), count then. A repository at the
filesystem root has no "beside": the runtime guard is off and the static scan in
tests/unit/test_repository_bounds.py remains.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
_INSIDE = str(REPO) + os.sep
_BESIDE = str(REPO.parent).rstrip(os.sep) + os.sep
_IN_TEMP = REPO.parent == Path(tempfile.gettempdir()).resolve()
_NEIGHBOURS = frozenset(
    n for n in (os.listdir(REPO.parent) if _IN_TEMP else ())
    if not n.startswith(("pytest-of-", "tmp")) and n != REPO.name
)
_WATCHED = frozenset({"open", "os.listdir", "os.scandir"})

offences: list[str] = []


def outside_repository(path: object) -> bool:
    """True for a path beside the repository (in its parent folder, not inside it)."""
    if isinstance(path, int) or path is None or REPO.parent == REPO:
        return False
    p = os.path.abspath(os.fsdecode(path))  # type: ignore[arg-type]
    if p == str(REPO) or p.startswith(_INSIDE) or not p.startswith(_BESIDE):
        return False
    return not _IN_TEMP or p[len(_BESIDE):].split(os.sep, 1)[0] in _NEIGHBOURS


def _audit(event: str, args: tuple) -> None:
    if event in _WATCHED and args and outside_repository(args[0]):
        offences.append(f"{event} {os.fsdecode(args[0])}")


def install() -> None:
    """Start watching this process (once; audit hooks cannot be removed)."""
    if not getattr(sys, "_uhrisim_bounds_installed", False):
        sys.addaudithook(_audit)
        sys._uhrisim_bounds_installed = True  # type: ignore[attr-defined]
