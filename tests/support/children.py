"""Helper scripts of tests/support run as child processes, their output read line by line."""

from __future__ import annotations

import json
import os
import queue
import secrets
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

SUPPORT = Path(__file__).resolve().parent
#: The longest a listener waits for the counts of a ``STOP {counts}`` (s;
#: tests/support/listener_loop.py): far beyond any lag measured under load (1 s with the
#: load average at 22 on 2 cores); reached only when a best-effort message was lost.
STOP_WAIT_S = 30.0
#: The longest :meth:`Child.expect` waits by default: only against a child that hangs (a
#: line that never comes from a child that ended ends the wait at once). A ``READY``
#: comes once Python, rclpy and DDS discovery are up, seconds on a busy machine; the
#: 20-60 s bounds it had were guesses of that.
HUNG_CHILD_S = 300.0


class Child:
    """A helper script in its own process, its stdout read line by line on a thread."""

    def __init__(self, script: str, args: list[str], log_dir: Path) -> None:
        self.stderr_path = log_dir / f"{script}.{secrets.token_hex(3)}.stderr"
        self._stderr = open(self.stderr_path, "w")  # noqa: SIM115 - closed in finish()
        self.proc = subprocess.Popen(
            [sys.executable, str(SUPPORT / script), *args],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._stderr,
            text=True,
            env=dict(os.environ),
        )
        self.lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.put(line.rstrip("\n"))
        self.lines.put(None)

    def expect(self, prefix: str, timeout: float = HUNG_CHILD_S) -> str:
        end = time.monotonic() + timeout
        while True:
            try:
                line = self.lines.get(timeout=max(0.01, end - time.monotonic()))
            except queue.Empty:
                line = None
                if time.monotonic() < end:
                    continue
            if line is None:
                self.finish()
                raise AssertionError(
                    f"no {prefix!r} line; stderr: {self.stderr_path.read_text()[-2000:]}"
                )
            if line.startswith(prefix):
                return line[len(prefix):].strip()

    def poll_line(self, prefix: str) -> str | None:
        """A line starting with ``prefix`` if one is waiting (non-blocking)."""
        while True:
            try:
                line = self.lines.get_nowait()
            except queue.Empty:
                return None
            if line is not None and line.startswith(prefix):
                return line[len(prefix):].strip()

    def send(self, text: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(text + "\n")
        self.proc.stdin.flush()

    def result(self, timeout: float = 15.0, counts: dict[str, int] | None = None) -> Any:
        """A listener's answer: ``STOP`` sent, its ``RESULT <json>`` line parsed, and the
        process ended with status 0. With ``counts`` (messages published per topic) the
        listener first waits for them (tests/support/listener_loop.py, ``STOP_WAIT_S``
        at most), so messages still in flight are counted."""
        self.send("STOP" + (" " + json.dumps(counts) if counts else ""))
        wait = STOP_WAIT_S if counts else 0.0
        out = json.loads(self.expect("RESULT", timeout=wait + timeout))
        assert self.finish() == 0
        return out

    def finish(self, timeout: float = 10.0) -> int:
        try:
            rc = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            rc = self.proc.wait()
        self._stderr.close()
        return rc


def run_paced_for(sim: Any, listener: Child, topics: list[str], until_s: float,
                  real_time_factor: float, on_frame: Any = None) -> Any:
    """Start the simulation ``sim`` (its first hook a ROS 2 bridge hook), wait for
    ``listener``'s ``READY`` and its subscriptions to ``topics``, step ``sim`` paced at
    ``real_time_factor`` until simulated ``until_s`` (``on_frame(frame)`` after each
    step), and return the listener's result once it has taken every message published on
    ``topics`` meanwhile; ``sim`` is closed and ``listener`` gone either way."""
    from uhrisim.sim.pacing import Pacer

    try:
        sim.start()
        listener.expect("READY")
        bridge = sim.hooks[0].bridge
        assert bridge.wait_for_subscribers(topics, 120.0), topics
        before = bridge.stats()["published"]
        pacer = Pacer(real_time_factor=real_time_factor)
        pacer.reset(sim.t)
        while sim.t < until_s:
            frame = sim.step()
            if on_frame is not None:
                on_frame(frame)
            pacer.wait(frame.t)
        after = bridge.stats()["published"]
        return listener.result(counts={t: after.get(t, 0) - before.get(t, 0) for t in topics})
    finally:
        sim.close()
        if listener.proc.poll() is None:
            listener.proc.kill()
