"""Files that are not ours, and stops (issue 29): only a regular text file of a sane size
is read, a file that is not a cut MCAP is never touched, and SIGTERM, SIGHUP and Ctrl-C
all end a run the same clean way (the rosbag2 folder complete, metrics.json saying why),
each in one line. The command runs in its own process, as a user's shell runs it."""

from __future__ import annotations

import json
import os
import resource
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "track_and_trail.yaml"


def uhrisim(*args: str, timeout: float = 300.0) -> subprocess.CompletedProcess:
    """The command in a child process (a FIFO that blocked would time out, not hang)."""
    return subprocess.run([sys.executable, "-m", "uhrisim", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=ROOT)


def one_error_line(done: subprocess.CompletedProcess, status: int = 2) -> str:
    assert done.returncode == status, done.stderr
    lines = [line for line in (done.stdout + done.stderr).splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    return lines[0]


def test_only_a_regular_text_file_of_a_sane_size_is_read(tmp_path):
    fifo = tmp_path / "scenario.yaml"
    os.mkfifo(fifo)  # opening it would block until a writer came: never opened
    big = tmp_path / "big.yaml"
    big.write_bytes(b"#" * (17 * 1024 * 1024))
    for path, why in ((fifo, "a FIFO"), (Path("/dev/zero"), "a device"), (tmp_path, "a folder"),
                      (big, "larger than 16 MiB")):
        line = one_error_line(uhrisim("validate", str(path)))
        assert line == f"error: {path}: cannot read scenario file: {why}" + (
            ", not a file to read" if why.startswith("a ") else ""), line


def test_a_key_that_is_not_a_name_is_one_line(tmp_path):
    path = tmp_path / "keys.yaml"
    path.write_text("name: x\n? [a, b]\n: 3\n")
    assert one_error_line(uhrisim("validate", str(path))) == (
        f"error: {path}:2: a key must be a name, not a list ('? ...' keys)")


@pytest.mark.parametrize("command", ["recover", "view"])
def test_a_file_that_is_no_recording_is_never_touched(tmp_path, command):
    notes = tmp_path / "notes.txt"
    notes.write_text("the user's own notes\n" * 100)
    before = notes.read_bytes()
    line = one_error_line(uhrisim(command, str(notes)))
    assert "not an MCAP recording" in line and "left as it is" in line
    assert notes.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]  # no .partial


def test_a_warning_is_said_once(tmp_path):
    scenario = tmp_path / "warns.yaml"
    scenario.write_text(f"name: w\nduration: 1\nagents:\n  - name: rov\n    model: videoray\n"
                        f"    start: {{north: 0, east: 0, depth: 1}}\n"
                        f"    helm: {{bhv_file: {ROOT / 'scenarios' / 'videoray_trail.bhv'}}}\n")
    done = uhrisim("validate", str(scenario))
    assert done.returncode == 0, done.stderr
    said = [line for line in done.stderr.splitlines() if "no decision domain given" in line]
    assert len(said) == 1, done.stderr


@pytest.mark.parametrize(("stop", "line", "reason"), [
    (signal.SIGTERM, "error: stopped by SIGTERM", "stopped by SIGTERM"),
    (signal.SIGHUP, "error: stopped by SIGHUP", "stopped by SIGHUP"),
    (signal.SIGINT, "error: interrupted", "interrupted (SIGINT)"),
])
def test_a_stop_signal_ends_the_run_cleanly(tmp_path, stop, line, reason):
    out = tmp_path / "run"
    run = subprocess.Popen(
        [sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "-o", str(out), "-q",
         "--duration", "600"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        cwd=ROOT, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    recording = out / "recording.mcap"

    def size() -> int:
        return recording.stat().st_size if recording.exists() else 0

    deadline = time.monotonic() + 300.0  # start-up on a busy machine; then it records
    while size() < 2 * 1024 * 1024:  # the static scene at the start is 1.6 MB: more
        assert run.poll() is None and time.monotonic() < deadline, run.stderr.read()
        time.sleep(0.1)  # is the mission's messages as it flies
    run.send_signal(stop)
    stdout, stderr = run.communicate(timeout=300)
    assert run.returncode == 128 + stop, stderr
    assert [x for x in (stdout + stderr).splitlines() if x.strip()] == [line]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["completed"] is False and 0 < metrics["simulated_s"] < 600
    assert metrics["stopped_by"] == reason
    with AnyReader([out]) as bag:  # a complete rosbag2 folder: metadata.yaml and all
        assert "/videoray/odom" in {c.topic for c in bag.connections}
        assert bag.message_count > 0


def test_a_second_run_into_a_used_folder_is_refused_unless_overwrite(tmp_path):
    out = tmp_path / "run"
    first = uhrisim("run", str(SCENARIO), "-o", str(out), "-q", "--duration", "1",
                    "--no-raycast-sensors")
    assert first.returncode == 0, first.stderr
    (out / "recording.mcap.partial").write_bytes(b"left by an earlier killed run")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert "trajectory.png" in before  # figures are drawn by default
    line = one_error_line(uhrisim("run", str(SCENARIO), "-o", str(out), "-q", "--duration",
                                  "1", "--no-raycast-sensors"))
    assert "not empty" in line and "--overwrite" in line, line
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # nothing touched
    again = uhrisim("run", str(SCENARIO), "-o", str(out), "-q", "--duration", "2",
                    "--no-raycast-sensors", "--overwrite", "--no-figures")
    assert again.returncode == 0, again.stderr
    assert not (out / "recording.mcap.partial").exists()  # the earlier run's files went
    assert not list(out.glob("*.png"))  # ... its figures too, and --no-figures drew none
    assert json.loads((out / "metrics.json").read_text())["simulated_s"] == pytest.approx(2.0)
    (out / "notes").mkdir()  # a folder of the user's, not a run's output folder
    line = one_error_line(uhrisim("run", str(SCENARIO), "-o", str(out), "-q", "--duration",
                                  "1", "--no-raycast-sensors", "--overwrite"))
    assert "holds folders (notes)" in line and (out / "metrics.json").exists(), line


def test_command_lines_the_file_system_refuses_are_one_line(tmp_path):
    long_path = tmp_path / ("a" * 5000)  # a name longer than any file system allows
    cases = [
        (("run", str(SCENARIO), "-o", str(tmp_path / "o"), "--ros-args=\"x"),
         "error: --ros-args: No closing quotation in '\"x'"),
        (("figure", "openloop", "--out", "/dev/null"),
         "error: /dev/null: the output folder is a file"),
        (("run", str(SCENARIO), "-o", str(long_path)), "(File name too long)"),
        (("recover", str(long_path)), "File name too long"),
    ]
    for args, says in cases:
        line = one_error_line(uhrisim(*args))
        assert says in line and len(line) < 600, line


def _with_mount(mount: list[str], command: list[str], then: str = "") -> list[str]:
    """``command`` run in a mount namespace of its own where ``mount`` (the arguments of
    ``mount``) was mounted first, and the shell line ``then`` after it (the mount goes
    with the namespace); the test is skipped where that is not allowed."""
    probe = subprocess.run(["unshare", "-m", "mount", *mount], capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"no mount namespace here: {probe.stderr.decode().strip()}")
    line = " ".join(shlex.quote(part) for part in ["mount", *mount]) + " && " + " ".join(
        shlex.quote(part) for part in command)
    return ["unshare", "-m", "sh", "-c", f"{line}; status=$?; {then or 'true'}; exit $status"]


def _read_only(folder: Path, command: list[str]) -> list[str]:
    """``command`` run where ``folder`` cannot be written: its mode for a user; for root
    (who writes anyway) a read-only bind mount of it."""
    if os.geteuid() != 0:
        folder.chmod(0o555)
        return command
    return _with_mount(["--bind", "-o", "ro", str(folder), str(folder)], command)


def test_recover_in_a_read_only_folder_is_one_line_and_leaves_the_file(tmp_path):
    """A cut recording in a folder that cannot be written: refused, the file untouched."""
    out = tmp_path / "run"
    done = uhrisim("run", str(SCENARIO), "-o", str(out), "-q", "--duration", "2",
                   "--no-raycast-sensors")
    assert done.returncode == 0, done.stderr
    cut = (out / "recording.mcap").read_bytes()[:-2000]  # no footer: a killed run's file
    folder = tmp_path / "read-only"
    folder.mkdir()
    (folder / "recording.mcap").write_bytes(cut)
    try:
        command = _read_only(folder, [sys.executable, "-m", "uhrisim", "recover", str(folder)])
        line = one_error_line(subprocess.run(command, capture_output=True, text=True,
                                             timeout=300, cwd=ROOT))
        assert "cannot recover it here" in line, line
        assert "Permission denied" in line or "Read-only file system" in line, line
        assert (folder / "recording.mcap").read_bytes() == cut
        assert sorted(p.name for p in folder.iterdir()) == ["recording.mcap"]
    finally:
        folder.chmod(0o755)


def _file_size_limit(limit: int) -> Callable[[], None]:
    """``ulimit -f``: a write past ``limit`` bytes fails with EFBIG (SIGXFSZ, which would
    kill the process instead, is ignored, as shells running under a limit often do)."""

    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


def test_a_file_size_limit_ends_the_run_with_one_line_and_a_readable_recording(tmp_path):
    out = tmp_path / "run"
    done = subprocess.run(
        [sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "-o", str(out), "-q",
         "--duration", "120"], capture_output=True, text=True, timeout=600, cwd=ROOT,
        preexec_fn=_file_size_limit(3 * 1024 * 1024))  # the static scene and ~10 s fit
    line = one_error_line(done)
    assert "recording.mcap: cannot write the recording on (File too large)" in line, line
    assert "the recording is complete up to there" in line, line
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["completed"] is False and 0 < metrics["simulated_s"] < 120
    assert "File too large" in metrics["stopped_by"]
    with AnyReader([out]) as bag:  # complete up to the failure: metadata.yaml and all
        odometry = [c for c in bag.connections if c.topic == "/videoray/odom"]
        last = max(t for _, t, _ in bag.messages(connections=odometry))
    assert 0 < last / 1e9 <= metrics["simulated_s"] + 1.0


def test_a_repeated_warning_is_summarised(tmp_path):
    """199 spheres of 1280 triangles overrun the recording's 200 000-triangle budget for
    the scene: 43 objects left out, said three times and then counted in one line."""
    spheres = "".join(f"    - {{type: sphere, label: s{i}, radius: 0.2, position: "
                      f"{{north: {i % 20}, east: {i // 20 + 3}, depth: 6}}}}\n" for i in range(199))
    scenario = tmp_path / "spheres.yaml"
    scenario.write_text("name: spheres\nduration: 1\nworld:\n  seafloor: {type: flat, depth: 8}\n"
                        f"  objects:\n{spheres}agents:\n  - name: rov\n    model: videoray\n"
                        "    driver: none\n    start: {north: -5, east: 0, depth: 1}\n")
    done = uhrisim("run", str(scenario), "-o", str(tmp_path / "run"), "-q", "--duration", "0.5",
                   "--no-raycast-sensors")
    assert done.returncode == 0, done.stderr
    said = [line for line in done.stderr.splitlines() if "triangle budget" in line]
    assert len(said) == 4, done.stderr
    assert said[3].startswith("... and 40 more like: scene object 's156' (1280 triangles)")


def test_a_full_disk_ends_the_run_with_one_line_and_a_complete_recording(tmp_path):
    """An 18 MiB tmpfs (a run starts with 16 MiB free) fills mid-run, ~70 simulated s
    in: one line; metrics.json says why; the recording is completed where it lies, in
    the room its headroom file held (gone afterwards), so every reader opens it without
    uhrisim recover."""
    disk = tmp_path / "disk"
    disk.mkdir()
    out = disk / "run"
    done = subprocess.run(_with_mount(
        ["-t", "tmpfs", "-o", "size=18m", "tmpfs", str(disk)],
        [sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "-o", str(out), "-q",
         "--duration", "600"],
        then=f"cp -r {shlex.quote(str(out))} {shlex.quote(str(tmp_path))}"),
        capture_output=True, text=True, timeout=600, cwd=ROOT)
    line = one_error_line(done)
    assert "cannot write the recording on (No space left on device)" in line, line
    assert "the recording is complete up to there" in line, line
    copy = tmp_path / "run"  # the folder copied off the full disk, as a user would
    assert not any(p.name.endswith(".headroom") for p in copy.iterdir())
    metrics = json.loads((copy / "metrics.json").read_text())
    assert metrics["completed"] is False and "No space left" in metrics["stopped_by"]
    with AnyReader([copy]) as bag:  # rosbags: metadata.yaml, summary and footer
        odometry = [c for c in bag.connections if c.topic == "/videoray/odom"]
        last = max(t for _, t, _ in bag.messages(connections=odometry))
        count = bag.message_count
    assert 0 < last / 1e9 <= metrics["simulated_s"] + 1.0
    with (copy / "recording.mcap").open("rb") as f:  # mcap's seeking reader: the summary
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics.message_count == count > 0
