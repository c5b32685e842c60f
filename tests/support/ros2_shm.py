"""Fast DDS shared-memory hygiene for the ROS 2 tests (standard library only).

A ROS 2 process that is killed cannot remove its Fast DDS files in ``/dev/shm``; a
participant that closes while a dead peer still "uses" a port may leave the port file.
Fast DDS keeps an ``flock`` on ``<name>_el`` while the owner of ``<name>`` is alive, so
a file whose lock can be taken belongs to nobody.

    before = shm_snapshot()
    ...                     # run tests that start and kill ROS processes
    clean_zombie_shm(before)
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

SHM = Path("/dev/shm")


def shm_snapshot() -> set[str]:
    """Names of the Fast DDS files in /dev/shm now."""
    try:
        return {n for n in os.listdir(SHM) if "fastdds" in n}
    except FileNotFoundError:
        return set()


def owner_alive(el_path: Path) -> bool:
    """True while some process holds the Fast DDS lock file ``el_path``."""
    try:
        fd = os.open(el_path, os.O_RDWR)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)  # closing drops our lock
    return False


def clean_zombie_shm(before: set[str]) -> list[str]:
    """Remove Fast DDS files created since ``before`` whose owner is gone: a segment or
    port whose ``_el`` lock nobody holds, and a port file left without any ``_el``.
    Returns the names removed."""
    new = shm_snapshot() - before
    doomed: set[str] = set()
    for name in new:
        if name.endswith("_el") and not owner_alive(SHM / name):
            base = name[: -len("_el")]
            doomed |= {name, base, f"sem.{base}_mutex"}
        elif (
            name.startswith("fastdds_port")
            and not name.endswith("_el")
            and not (SHM / f"{name}_el").exists()
        ):
            doomed |= {name, f"sem.{name}_mutex"}
    removed = []
    for name in sorted(doomed & new):
        try:
            (SHM / name).unlink()
            removed.append(name)
        except OSError:
            pass
    return removed
