"""Sweeps and datasets past one machine: a real two-node Ray cluster on loopback.

A head started with ``ray start --head`` and a second node joined with ``ray start
--address``, one CPU each, every process on this machine's loopback. ``uhrisim sweep`` and
``uhrisim dataset`` run on it as drivers in other processes (by GCS address and through
the ``ray://`` client); their work is spread over both nodes and their results equal a
single-node run's. Killing the second node mid-sweep loses nothing: Ray runs its tasks
again on the head. The tests share one cluster (started once, in file order the kill
comes last); a test that finds its second node killed gets a new one. They also share one
single-node sweep, the reference both compare with.

Each single-node run comes before the two-node runs it is compared with: its one worker
compiles uhrisim's kernels into the suite's numba cache (``NUMBA_CACHE_DIR``, set by
tests/conftest.py and handed to both nodes and every driver in their environment), and
the two nodes' workers load them from there instead of each compiling them at once.

Two Ray details shape the set-up (docs/scaling.md):

* token authentication (Ray's default): every process gets the cluster's token in
  ``RAY_AUTH_TOKEN`` (made here, kept in the environment only);
* Ray replaces a node address of 127.0.0.1 by the machine's network address whenever
  multi-node clusters are enabled, and refuses ``ray start --address`` when they are not.
  The head runs with them disabled (it stays on 127.0.0.1); the second node's ``ray start``
  runs Ray's own command with that one replacement turned off, so that it too stays on
  127.0.0.1. The drivers (``uhrisim``) keep a loopback address as it is themselves.
"""

from __future__ import annotations

import contextlib
import csv
import filecmp
import os
import secrets
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

pytest.importorskip("ray")
pytest.importorskip("grpc", reason="the ray:// client needs ray[client] (the [batch] extra)")
psutil = pytest.importorskip("psutil")
pytest.importorskip("pycocotools")

from tests.support.time_limit import time_limit  # noqa: E402

pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings(
    "ignore:__array__ implementation doesn't accept a copy keyword:DeprecationWarning")]

#: Ray's ``ray start`` for a node that joins on loopback (module docstring).
JOIN_ON_LOOPBACK = (
    "import sys, ray._private.services as services\n"
    "services.resolve_ip_for_localhost = lambda host: host  # keep 127.0.0.1\n"
    "from ray.scripts.scripts import main\n"
    "sys.argv = ['ray', *sys.argv[1:]]\n"
    "main()\n")
NODE_PORTS = ("--node-manager-port", "--object-manager-port", "--metrics-export-port",
              "--dashboard-agent-listen-port", "--dashboard-agent-grpc-port",
              "--runtime-env-agent-port")
START_TIMEOUT_S = 120
#: Connections through the ray:// client: Ray's client proxy starts a server process per
#: client, and on a machine whose cores are all busy that start now and then fails at once
#: ("Initialization failure from server", the process gone, its logs empty); a new
#: connection gets a new one.
CLIENT_ATTEMPTS = 3
DRIVER_TIMEOUT_S = 300


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@dataclass
class Cluster:
    """A two-node loopback cluster: addresses, environment and its processes."""

    gcs: str
    client: str
    env: dict[str, str]
    temp_dir: str
    second_node_ports: list[int]
    head_ports: list[int]
    #: True once a test killed the second node: the next test needs a new cluster.
    spent: bool = False

    def processes(self, *marks: str) -> list[psutil.Process]:
        """This cluster's processes whose command line holds any of ``marks``."""
        found = []
        for proc in psutil.process_iter(["cmdline"]):
            line = " ".join(proc.info["cmdline"] or [])
            if proc.pid != os.getpid() and any(m in line for m in marks):
                found.append(proc)
        return found

    def second_node(self) -> list[psutil.Process]:
        """The second node's processes: those started with its ports and their children
        (Ray's workers retitle themselves ``ray::<task>``, dropping the ports)."""
        found = {p.pid: p for p in self.processes(*(f"={port}"
                                                    for port in self.second_node_ports))}
        for proc in list(found.values()):
            with contextlib.suppress(psutil.NoSuchProcess):
                found |= {child.pid: child for child in proc.children(recursive=True)}
        return list(found.values())

    def kill(self, procs: list[psutil.Process]) -> None:
        for proc in procs:
            with contextlib.suppress(psutil.NoSuchProcess):
                proc.kill()
        psutil.wait_procs(procs, timeout=30)

    def run(self, *args: str) -> subprocess.CompletedProcess:
        """``uhrisim ARGS`` in another process with the cluster's environment."""
        return _uhrisim(self.env, *args)


def _uhrisim(env: dict[str, str], *args: str) -> subprocess.CompletedProcess:
    """``uhrisim ARGS`` in another process with the environment ``env``."""
    return subprocess.run([sys.executable, "-m", "uhrisim", *args], capture_output=True,
                          text=True, timeout=DRIVER_TIMEOUT_S, env=env)


def _ray_start(args: list[str], env: dict[str, str], join: bool) -> None:
    command = ([sys.executable, "-c", JOIN_ON_LOOPBACK, "start"] if join
               else [sys.executable, "-m", "ray.scripts.scripts", "start"])
    done = subprocess.run(command + args, capture_output=True, text=True, env=env,
                          timeout=START_TIMEOUT_S)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]


def _ray_env() -> dict[str, str]:
    """This process's environment for Ray's processes and uhrisim's drivers: token
    authentication with a new token, no usage statistics, no inherited ``RAY_ADDRESS``."""
    env = os.environ | {"RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "token",
                        "RAY_AUTH_TOKEN": secrets.token_hex(16)}
    env.pop("RAY_ADDRESS", None)
    return env


def _start_cluster() -> Cluster:
    """Start a head and join a second node; stop both with ``_stop_cluster``."""
    env = _ray_env()
    temp_dir = tempfile.mkdtemp(prefix="uhr-ray-")  # short: Ray's socket paths live here
    gcs, client = _free_port(), _free_port()
    head_ports = [_free_port() for _ in NODE_PORTS]
    second_ports = [_free_port() for _ in NODE_PORTS]
    made = Cluster(f"127.0.0.1:{gcs}", f"ray://127.0.0.1:{client}", env, temp_dir,
                   second_ports, head_ports)
    common = ["--node-ip-address", "127.0.0.1", "--num-cpus", "1", "--disable-usage-stats"]
    try:
        _ray_start(["--head", "--port", str(gcs), "--ray-client-server-port", str(client),
                    "--include-dashboard", "false", "--temp-dir", temp_dir, *common,
                    *(f"{flag}={port}" for flag, port in zip(NODE_PORTS, head_ports,
                                                              strict=True))],
                   env | {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}, join=False)
        _ray_start(["--address", made.gcs, *common,
                    *(f"{flag}={port}" for flag, port in zip(NODE_PORTS, second_ports,
                                                              strict=True))],
                   env | {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "1"}, join=True)
    except BaseException:
        _stop_cluster(made)
        raise
    return made


def _stop_cluster(made: Cluster) -> None:
    made.kill(made.processes(made.temp_dir, *(f"={p}" for p in [*made.head_ports,
                                                                   *made.second_node_ports])))
    shutil.rmtree(made.temp_dir, ignore_errors=True)


@pytest.fixture(scope="module")
def _clusters():
    """This module's clusters: one, started by the first test that needs it, serves every
    test until a test kills its second node (``Cluster.spent``); the next test then gets
    a new one. All are stopped once, after the module."""
    started: list[Cluster] = []
    yield started
    for made in started:
        _stop_cluster(made)


@pytest.fixture
def cluster(_clusters: list[Cluster]) -> Cluster:
    """A two-node cluster with both nodes alive (shared by this module's tests)."""
    if not _clusters or _clusters[-1].spent:
        _clusters.append(_start_cluster())
    return _clusters[-1]


def _nodes(cluster: Cluster) -> list[tuple[str, float, bool]]:
    """(address, CPUs, alive) of every node, asked by a driver in another process."""
    code = ("import json, ray\n"
            f"ray.init(address={cluster.gcs!r}, log_to_driver=False)\n"
            "print(json.dumps([(n['NodeManagerAddress'], n['Resources'].get('CPU', 0),"
            " n['Alive']) for n in ray.nodes()]))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=cluster.env | {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"},
                          timeout=DRIVER_TIMEOUT_S)
    assert done.returncode == 0, done.stderr[-2000:]
    import json

    return [tuple(n) for n in json.loads(done.stdout.strip().splitlines()[-1])]


def _write_sweep(folder: Path, duration: float, values: list[float], figures: bool) -> Path:
    """The sweep file; ``figures`` (each run's, which no test reads) changes no result."""
    from uhrisim.scenario.shipped import shipped_scenario

    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "sweep.yaml"
    path.write_text(
        f"scenario: {shipped_scenario()}\nduration: {duration}\nraycast_sensors: false\n"
        f"figures: {str(figures).lower()}\n"
        "set: {recording.enabled: false}\nseeds: [1, 2]\n"
        f"grid: {{agents.videoray.controller.heading: {values}}}\n")
    return path


def _write_dataset(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "dataset.yaml"
    path.write_text(
        "name: cluster-set\nframes: 8\nseed: 5\n"
        "objects: {count: [1, 2], kinds: [{type: diver, altitude: [0.3, 1.0]},"
        " {type: cylinder, class: piling, radius: [0.2, 0.4], height: [1, 3]}]}\n"
        "sonar: {preset: [P900-45], range_max_m: [8, 10], settings: {rays_per_beam: 8,"
        " fan_size_px: 128, range_resolution_m: 0.1}}\n")
    return path


@dataclass
class Reference:
    """The sweep both tests run and its table from a single-node run."""

    sweep: Path
    table: list[dict[str, str]]


@pytest.fixture(scope="module")
def one_node(tmp_path_factory) -> Reference:
    """The sweep of 6 runs, run once by a single-node Ray (``--workers 1``)."""
    folder = tmp_path_factory.mktemp("one-node")
    sweep = _write_sweep(folder, 10.0, [1.0, 2.0, 3.0], figures=False)
    one = _uhrisim(_ray_env(), "sweep", str(sweep), "--out", str(folder / "one"),
                   "--workers", "1")
    assert one.returncode == 0, one.stderr[-3000:]
    assert "6 runs: 6 ok (0 already done), 0 failed; on 1 Ray node" in one.stdout
    return Reference(sweep, _table(folder / "one"))


#: Columns of a sweep's table that measure the machine, not the run.
TIMING_COLUMNS = ("run_wall_s", "wall_s", "real_time_factor")


def _table(out: Path) -> list[dict[str, str]]:
    """The sweep's results.csv without the columns that measure wall time."""
    with (out / "results.csv").open() as handle:
        return [{k: v for k, v in row.items() if k not in TIMING_COLUMNS}
                for row in csv.DictReader(handle)]


def _same_tree(a: Path, b: Path) -> None:
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    _, mismatch, errors = filecmp.cmpfiles(a, b, [str(f) for f in files], shallow=False)
    assert not mismatch and not errors, mismatch + errors


def test_sweeps_and_datasets_spread_over_two_nodes_and_equal_one_node(one_node, cluster,
                                                                       tmp_path):
    with time_limit(900, "the two-node cluster test"):
        nodes = _nodes(cluster)
        assert sorted(nodes) == [("127.0.0.1", 1.0, True)] * 2
        listening = {c.laddr.ip for c in psutil.net_connections("inet")
                     if c.status == psutil.CONN_LISTEN
                     and c.pid in {p.pid for p in cluster.processes(cluster.temp_dir)}}
        assert listening and listening <= {"127.0.0.1", "::ffff:127.0.0.1"}, listening

        two = cluster.run("sweep", str(one_node.sweep), "--out", str(tmp_path / "two"),
                          "--address", cluster.gcs)
        assert two.returncode == 0, two.stderr[-3000:]
        assert "6 runs: 6 ok (0 already done), 0 failed; on 2 Ray nodes" in two.stdout
        assert _table(tmp_path / "two") == one_node.table

        for _ in range(CLIENT_ATTEMPTS):
            client = cluster.run("sweep", str(one_node.sweep), "--out",
                                 str(tmp_path / "client"), "--address", cluster.client)
            if "Initialization failure from server" not in client.stderr:
                break
        assert client.returncode == 0, client.stderr[-3000:]
        assert "6 runs: 6 ok (0 already done), 0 failed; on 2 Ray nodes" in client.stdout
        assert _table(tmp_path / "client") == one_node.table

        data = _write_dataset(tmp_path)
        one = cluster.run("dataset", str(data), "--out", str(tmp_path / "d_one"),
                          "--workers", "1", "--shard-frames", "4")
        assert one.returncode == 0, one.stderr[-3000:]
        two = cluster.run("dataset", str(data), "--out", str(tmp_path / "d_two"),
                          "--address", cluster.gcs, "--shard-frames", "1")
        assert two.returncode == 0, two.stderr[-3000:]
        assert "; on 2 Ray nodes" in two.stdout
        _same_tree(tmp_path / "d_two", tmp_path / "d_one")


def _running(procs: list[psutil.Process], task: str) -> bool:
    """Whether one of ``procs`` is a Ray worker executing ``task`` (titled ``ray::task``)."""
    for proc in procs:
        with contextlib.suppress(psutil.NoSuchProcess):
            if " ".join(proc.cmdline()).startswith(f"ray::{task}"):
                return True
    return False


def test_a_node_killed_mid_sweep_loses_no_run(one_node, cluster, tmp_path):
    """The second node is killed (its raylet, workers and agents, SIGKILL) while it works
    on a run (a worker of it titled ``ray::execute_run``), and Ray runs its task again on
    the head: every run is in the table, equal to the one-node run's. The runs draw their
    figures here: a run without them lasts ~0.05 s of CPU, too short a while to be seen."""
    with time_limit(900, "the node-kill test"):
        out = tmp_path / "killed"
        sweep = _write_sweep(tmp_path, 10.0, [1.0, 2.0, 3.0], figures=True)
        driver = subprocess.Popen(
            [sys.executable, "-m", "uhrisim", "sweep", str(sweep), "--out", str(out),
             "--address", cluster.gcs], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True, env=cluster.env)
        try:
            deadline = time.monotonic() + DRIVER_TIMEOUT_S
            while not _running(second := cluster.second_node(), "execute_run"):
                assert driver.poll() is None, ("the sweep ended before the second node ran"
                                               " a run", driver.communicate())
                assert time.monotonic() < deadline, "the second node never ran a run"
                time.sleep(0.05)
            cluster.spent = True
            cluster.kill(second)
            stdout, stderr = driver.communicate(timeout=DRIVER_TIMEOUT_S)
        finally:
            if driver.poll() is None:
                driver.kill()
                driver.communicate()
        assert driver.returncode == 0, stderr[-3000:]
        assert "6 runs: 6 ok (0 already done), 0 failed" in stdout
        assert _table(out) == one_node.table
