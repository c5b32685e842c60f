"""Ray for sweeps and datasets: connect (or start a loopback-only local Ray), run tasks.

This module is the only place that imports Ray (docs/design.md: ``batch/`` sits above ``sim/``
and ``envs/``; Ray is imported only there). Addresses (``--address``):

* none: a local Ray started here, loopback only (node IP 127.0.0.1, so every Ray server
  binds 127.0.0.1), dashboard off, usage stats off, ``workers`` CPUs; stopped at the end;
* ``auto``: the Ray already running on this machine (``ray start --head`` earlier);
* ``ray://host:port``: a Ray Client server (a remote cluster's head, port 10001 usually);
* ``host:port``: a cluster's GCS address, from a node of that cluster.

A reachable, well-formed address is checked before Ray is touched, so a typo is a
one-line :class:`~uhrisim.core.errors.ConfigError`, not a minute of retries.
"""

from __future__ import annotations

import contextlib
import importlib
import ipaddress
import logging
import os
import re
import socket
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from uhrisim.core.errors import ConfigError, MissingExtraError, first_line

#: Environment of a local Ray: no usage statistics; on Linux, Ray replaces a node IP of
#: 127.0.0.1 by the machine's address unless clusters are declared unsupported, which
#: keeps the node (and so every gRPC server of it) on loopback.
LOCAL_RAY_ENV = {"RAY_USAGE_STATS_ENABLED": "0", "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}
#: Ray's logger that says, at every local start, that token authentication is on (its
#: default, which we keep).
_TOKEN_NOTICE_LOGGER = "ray._private.authentication.authentication_token_setup"
LOOPBACK = "127.0.0.1"
#: Times Ray runs a task again whose worker or node died (Ray's own default, said here).
TASK_RETRIES = 3
#: Longest wait (s) for cancelled tasks to end after an interruption (their workers are
#: killed; this bounds only a Ray that no longer answers).
CANCEL_WAIT_S = 60.0
#: Seconds a TCP connection to ``--address`` may take before it counts as unreachable.
CONNECT_TIMEOUT_S = 5.0

_HOST_PORT = re.compile(r"^(?P<host>[A-Za-z0-9._-]+|\[[0-9A-Fa-f:]+\]):(?P<port>\d{1,5})$")


def _ray(local: bool = False) -> Any:
    """The ray module; ``local``: set up for a loopback-only Ray first (a local one, or a
    cluster reached on a loopback address, which Ray would otherwise replace by this
    machine's network address)."""
    if local:
        os.environ.update(LOCAL_RAY_ENV)  # read when Ray is first imported
    try:
        import ray
        from ray._private import ray_constants
    except ImportError:
        raise MissingExtraError('sweeps and datasets run on Ray: pip install "uhrisim[batch]"'
                                ) from None
    if local:  # Ray imported before (a notebook, a test): the constant the variable set
        ray_constants.ENABLE_RAY_CLUSTER = False
    return ray


def check_address(address: str | None) -> tuple[str, int] | None:
    """(host, port) that ``address`` names (None for a local Ray); a ConfigError naming
    ``--address`` if it is malformed or nothing listens there. ``auto`` is the address Ray
    itself would pick (``RAY_ADDRESS``, the last ``ray start`` on this machine, a running
    GCS), checked the same way: Ray would otherwise retry a stale one for minutes."""
    if address is None:
        return None
    if address == "auto":
        services = importlib.import_module("ray._private.services", _ray().__name__)
        try:
            found = services.get_ray_address_from_environment("auto", None)
        except (ConnectionError, RuntimeError, ValueError) as error:
            raise ConfigError(f"auto: no Ray found on this machine ({first_line(error)})",
                              where="--address") from None
        if found in (None, "auto"):
            raise ConfigError("auto: no Ray found on this machine (start one with "
                              "`ray start --head`)", where="--address")
        return check_address(found)
    rest = address.removeprefix("ray://")
    match = _HOST_PORT.match(rest)
    if not match or not 0 < int(match["port"]) <= 65535:
        raise ConfigError(f"{address!r} is not 'auto', 'ray://host:port' or 'host:port'",
                          where="--address")
    host, port = match["host"].strip("[]"), int(match["port"])
    try:
        with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S):
            pass
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise ConfigError(f"cannot reach Ray at {address} ({reason})", where="--address") from None
    return host, port


@contextlib.contextmanager
def ray_session(address: str | None = None, workers: int | None = None) -> Iterator[int]:
    """Ray for the duration of the block; yields how many tasks to keep in flight.

    Reuses a Ray this process already initialised (a test module's, a notebook's) and
    leaves it running; otherwise connects to ``address`` or starts a local, loopback-only
    Ray with ``workers`` CPUs (default: this machine's), and shuts it down at the end.
    """
    if workers is not None and workers < 1:
        raise ConfigError(f"must be an integer >= 1, got {workers!r}", where="--workers")
    where = check_address(address)
    ray = _ray(local=where is None or is_loopback(where[0]))
    owned = not ray.is_initialized()
    if owned:
        _init(ray, address, workers)
    try:
        yield workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
    finally:
        if owned:
            ray.shutdown()


def is_loopback(host: str) -> bool:
    """Is ``host`` (an IP address or a name) this machine's loopback?"""
    try:
        return ipaddress.ip_address(socket.gethostbyname(host)).is_loopback
    except (OSError, ValueError):
        return False


def start_local_ray(workers: int) -> None:
    """Start a local, loopback-only Ray with ``workers`` CPUs (tests start one per module)."""
    _init(_ray(local=True), None, workers)


def _init(ray: Any, address: str | None, workers: int | None) -> None:
    """Start a local Ray (``address`` None) or connect; the tasks' output stays in Ray's
    logs (``/tmp/ray/session_*/logs``), not on this terminal."""
    quiet = {"log_to_driver": False, "logging_level": logging.ERROR,
             "configure_logging": False}
    if address is None:
        logging.getLogger(_TOKEN_NOTICE_LOGGER).setLevel(logging.ERROR)
        ray.init(num_cpus=workers or os.cpu_count() or 1, _node_ip_address=LOOPBACK,
                 include_dashboard=False, **quiet)
        return
    try:
        ray.init(address=address, **quiet)
    except (ConnectionError, RuntimeError, ValueError) as error:
        raise ConfigError(f"cannot connect to Ray at {address}: {first_line(error)}",
                          where="--address") from None


def run_tasks(function: Callable[[Any], Any], items: Sequence[Any], in_flight: int,
              on_result: Callable[[int, Any], None],
              on_error: Callable[[int, BaseException], None] | None = None) -> Counter[str]:
    """Run ``function(item)`` as one Ray task (1 CPU) per item, at most ``in_flight`` at a
    time, and call ``on_result(index, result)`` in the driver as each one finishes (in
    completion order). A task that raises, or whose worker or node died (Ray retries those
    elsewhere first, up to 3 times), goes to ``on_error(index, error)`` — the task's own
    exception — and the others go on; without ``on_error`` that exception is raised here.
    Interrupted (Ctrl-C, an exception from a callback), the tasks still running are
    cancelled, and waited for: none of them writes on after this returns. Returns how many
    tasks finished on each Ray node (by node id)."""
    ray = _ray()
    remote = ray.remote(num_cpus=1, max_retries=TASK_RETRIES)(_on_node(function))
    nodes: Counter[str] = Counter()
    pending: dict[Any, int] = {}
    queue = iter(enumerate(items))

    def submit() -> None:
        for index, item in queue:
            pending[remote.remote(item)] = index
            return

    try:
        for _ in range(in_flight):
            submit()
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            index = pending.pop(done[0])
            submit()
            try:
                node, result = ray.get(done[0])
            except ray.exceptions.RayError as error:
                cause = error.cause if isinstance(error, ray.exceptions.RayTaskError) else error
                if on_error is None:
                    raise cause from None
                on_error(index, cause)
                continue
            nodes[node] += 1
            on_result(index, result)
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
        if pending:  # a cancel is asynchronous: the worker may still be writing its files
            ray.wait(list(pending), num_returns=len(pending), timeout=CANCEL_WAIT_S)
    return nodes


def _on_node(function: Callable[[Any], Any]) -> Callable[[Any], tuple[str, Any]]:
    """``function`` returning ``(id of the Ray node it ran on, its result)``."""

    def run(item: Any) -> tuple[str, Any]:
        return _ray().get_runtime_context().get_node_id(), function(item)

    run.__name__ = run.__qualname__ = getattr(function, "__name__", "task")
    return run
