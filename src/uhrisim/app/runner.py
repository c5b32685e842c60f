"""Run a scenario file end to end and write its outputs into a folder.

Outputs: ``recording.mcap`` and ``metadata.yaml`` (if recording is on: the folder is then
a rosbag2 bag, ``uhrisim.record.rosbag2``), ``metrics.json`` (strict JSON: a value
that is not a finite number is ``null``) and the figures ``trajectory.png``,
``range_bearing.png`` (if the scenario names a trail pair) and ``sonar_strip.png`` (if a
sonar ran). The output folder is checked before anything is built. A run that fails
still closes its recording and writes what it measured, marked ``"completed": false``;
if writing those outputs fails too, that is logged and the run's own error is raised.
"""

from __future__ import annotations

import json
import logging
import math
import shutil
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from uhrisim.app.metrics import TrailMetrics
from uhrisim.app.perception_metrics import PerceptionMetrics
from uhrisim.app.team_metrics import TeamMetrics
from uhrisim.core.errors import AssetError, StopRequested, shortened
from uhrisim.core.files import write_text_whole
from uhrisim.core.stops import stop_signals_deferred
from uhrisim.scenario.load import ScenarioFile, load_scenario
from uhrisim.sim.hooks import BaseHook, Hook, TickFrame, sensor_key
from uhrisim.viz.fan_plot import FanView, in_sonar_plane

if TYPE_CHECKING:  # imported where a run is built: the world needs trimesh, a recording mcap
    from uhrisim.record.hook import McapRecordingHook
    from uhrisim.sim.simulation import Simulation

SONAR_STRIP_FRAMES = 6

log = logging.getLogger(__name__)


class SonarStripHook(BaseHook):
    """Keeps a few fan images of each sonar spread over the run, for the sonar strip
    figure: ``frames[key]`` for each sonar key ``"<agent>/<sensor>"`` of ``titles``
    (key -> the figure's title of its row), each ``(t, FanView, target)`` with the
    ``target`` agent's place in the fan (starboard m, forward m; None without a target)."""

    def __init__(self, titles: Mapping[str, str], duration: float,
                 count: int = SONAR_STRIP_FRAMES, target: str | None = None) -> None:
        times = list(np.linspace(0.0, duration, count + 1)[1:] - duration / (2 * count))
        self.titles = dict(titles)
        self.target = target
        self.times = {key: list(times) for key in titles}
        self.frames: dict[str, list[tuple[float, FanView, tuple[float, float] | None]]] = {
            key: [] for key in titles}

    def on_tick(self, frame: TickFrame) -> None:
        for key, due in self.times.items():
            ping = frame.pings.get(key)
            if ping is not None and due and frame.t >= due[0]:
                due.pop(0)
                agent = frame.agents.get(self.target) if self.target else None
                where = None if agent is None else in_sonar_plane(ping, agent.nav.position_ned)
                self.frames[key].append((frame.t, FanView.of_ping(ping), where))


@dataclass
class RunResult:
    """What a run produced."""

    out_dir: Path
    metrics: dict[str, Any] | None
    files: list[Path] = field(default_factory=list)


def run_scenario(source: ScenarioFile | str | Path, out_dir: Path, *,
                 duration: float | None = None, seed: int | None = None,
                 raycast_sensors: bool = True,
                 figures: bool = True,
                 extra_hooks: Sequence[Hook] = (),
                 progress: Callable[[float], None] | None = None,
                 should_stop: Callable[[], bool] | None = None,
                 configure: Callable[[Simulation], None] | None = None) -> RunResult:
    """Build the simulation, run it, and write recording, metrics and figures
    (``raycast_sensors`` False: no sonars and cameras, :class:`Simulation`; ``figures``
    False: no figures, the rest the same)."""
    from uhrisim.record.hook import McapRecordingHook
    from uhrisim.record.mcap_recorder import RecordingCutError
    from uhrisim.sim.simulation import Simulation

    if not isinstance(source, ScenarioFile):
        source = load_scenario(source)
    scenario = source.scenario
    duration = scenario.duration if duration is None else duration
    prepare_out_dir(out_dir)
    hooks: list[Hook] = []
    files: list[Path] = []
    recording: McapRecordingHook | None = None
    if scenario.recording.enabled:
        recording = McapRecordingHook.for_scenario(scenario, out_dir / "recording.mcap")
        hooks.append(recording)
        files += [out_dir / "recording.mcap", out_dir / "metadata.yaml"]
    measuring = _Measuring(scenario, duration, raycast_sensors)
    metrics, strip = measuring.metrics, measuring.strip
    extra_hooks = [*measuring.reports, *extra_hooks]
    hooks += [*measuring.hooks, *extra_hooks]
    sim = Simulation(source, seed=seed, raycast_sensors=raycast_sensors, hooks=hooks)
    if sim.team is not None:  # a team mission: its summary joins metrics.json
        team = TeamMetrics()
        sim.hooks.append(team)
        extra_hooks = [*extra_hooks, team]
    if sim.assistance is not None:  # an assisted mission: its summary joins metrics.json
        extra_hooks = [*extra_hooks, sim.assistance]  # type: ignore[list-item]
    if configure is not None:
        configure(sim)
    try:
        sim.run(duration, progress=progress, should_stop=should_stop)
    except BaseException as error:
        disk_full = isinstance(error, RecordingCutError)
        stopped = isinstance(error, KeyboardInterrupt | StopRequested)
        try:  # what was measured until the failure, without masking it
            with stop_signals_deferred():  # a second Ctrl-C must not cut the bag
                sim.close(error)
                # stopped by a signal: out at once (ros2 launch escalates after 5 s), the
                # figures (seconds of matplotlib) are left out
                _write_outputs(sim, out_dir, metrics, strip, files, False, extra_hooks,
                               error, figures=figures and not stopped)
        except Exception as cleanup:  # on a full disk the figures cannot be: said below
            (log.info if disk_full else log.error)(
                "after the run failed, its outputs could not all be written: %s", cleanup)
        if disk_full and recording is not None and recording.cut_outcome:
            raise AssetError(f"{error}; {recording.cut_outcome}") from None
        raise
    sim.close(None)
    summary = _write_outputs(sim, out_dir, metrics, strip, files, True, extra_hooks,
                             figures=figures)
    return RunResult(out_dir, summary, files)


#: Free space an output folder must have before a run starts (a run records ~1 MB per
#: simulated second with a sonar; this only catches a disk that is already full).
MIN_FREE_BYTES = 16 * 1024 * 1024


class _Measuring:
    """What a run measures besides its recording: the trail metrics, the perception
    metrics (their summaries join metrics.json) and the sonar strip."""

    def __init__(self, scenario: Any, duration: float, raycast_sensors: bool) -> None:
        self.metrics = TrailMetrics(scenario.metrics) if scenario.metrics else None
        observers = [a for a in scenario.agents
                     if a.contacts.source == "sonar" and a.perception_sonar is not None]
        self.reports: list[Hook] = [
            PerceptionMetrics(observers[0].name, scenario.metrics.target,
                              sonar=str(observers[0].perception_sonar))
        ] if scenario.metrics and observers and raycast_sensors else []
        sonars = {sensor_key(a.name, str(s.name)): f"{a.name}/{s.name} ({s.preset})"
                  for a in scenario.agents for s in a.sensors if s.type == "sonar"}
        self.strip = SonarStripHook(sonars, duration, target=scenario.metrics.target
                                    if scenario.metrics else None) \
            if raycast_sensors and sonars else None
        self.hooks: list[Hook] = [h for h in (self.metrics, self.strip) if h is not None]


def build_run(source: ScenarioFile, raycast_sensors: bool = True) -> Simulation:
    """Everything :func:`run_scenario` builds but its output files: the simulation (scene,
    sensors, helms, drivers) with the metrics it measures (``uhrisim validate``: a scene
    that validates, runs)."""
    from uhrisim.sim.simulation import Simulation

    scenario = source.scenario
    measuring = _Measuring(scenario, scenario.duration, raycast_sensors)
    return Simulation(source, raycast_sensors=raycast_sensors,
                      hooks=[*measuring.hooks, *measuring.reports])


def prepare_out_dir(out_dir: Path, used: Literal["keep", "refuse", "clear"] = "keep") -> None:
    """Create the output folder, or say in one line why a run could not write there.

    ``used``: what to do with a folder that already holds files: ``keep`` them (the
    library's runs, figures), ``refuse`` (``uhrisim run``: a second run must not silently
    replace the first), ``clear`` them first (``uhrisim run --overwrite``; only a folder of
    files, as a run leaves it: a folder holding folders is refused)."""
    try:
        if out_dir.exists() and not out_dir.is_dir():
            raise AssetError(f"{out_dir}: the output folder is a file")
        held = sorted(out_dir.iterdir()) if out_dir.is_dir() else []
        if held and used == "refuse":
            raise AssetError(f"{out_dir}: the output folder is not empty ({len(held)} "
                             "entries, a run's outputs?); give --overwrite to replace them, "
                             "or another --out")
        if held and used == "clear":
            folders = [p.name for p in held if p.is_dir() and not p.is_symlink()]
            if folders:
                raise AssetError(f"{out_dir}: --overwrite clears only a run's output folder, "
                                 f"and this one holds folders ({', '.join(folders[:3])}); "
                                 "choose another --out")
            for path in held:
                path.unlink()
        out_dir.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out_dir):
            pass
        free = shutil.disk_usage(out_dir).free
    except AssetError:
        raise
    except OSError as error:
        raise AssetError(f"{shortened(str(out_dir), 200)}: cannot write the run's outputs "
                         f"here ({error.strerror or error})") from None
    if free < MIN_FREE_BYTES:
        raise AssetError(f"{out_dir}: the disk is full ({free // 1024} KiB free)")


def strict_json(value: Any) -> Any:
    """``value`` with every number that is not finite (NaN, infinity) as None, numpy
    scalars as Python numbers: what ``json.dumps(allow_nan=False)`` accepts."""
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [strict_json(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _write_outputs(sim: Simulation, out_dir: Path, metrics: TrailMetrics | None,
                   strip: SonarStripHook | None, files: list[Path],
                   completed: bool, extra_hooks: Sequence[Hook],
                   error: BaseException | None = None,
                   figures: bool = True) -> dict[str, Any]:
    summary: dict[str, Any] = {"scenario": sim.scenario.name, "seed": sim.seed,
                               "completed": completed, "simulated_s": sim.t,
                               "collisions": sim.collisions,
                               "real_time_factor": sim.t / sim.wall_time if sim.wall_time
                               else None}
    measured = metrics is not None and sim.tick > 0
    if measured:
        summary |= metrics.summary()
    for hook in extra_hooks:  # perception; live bridges: messages, failures, rounds
        report = getattr(hook, "summary", None)
        if report is not None:
            summary |= report()
    if error is not None:  # why the run ended early
        summary["stopped_by"] = ("interrupted (SIGINT)" if isinstance(error, KeyboardInterrupt)
                                 else str(error) or type(error).__name__)
    # first: on a full disk the figures may not fit; whole: a restarted sweep reads it
    files.append(write_text_whole(out_dir / "metrics.json",
                                  json.dumps(strict_json(summary), indent=2, allow_nan=False)
                                  + "\n"))
    if not figures:
        return summary
    from uhrisim.viz import mission_figures as figs  # matplotlib: ~1 s to import

    if measured:
        series = metrics.series()
        acquired = summary["time_to_acquire_s"]
        acquired_at = None if acquired is None else float(series["t"][0] + acquired)
        files.append(figs.plot_tracks(series, metrics.config.follower, metrics.config.target,
                                      out_dir / "trajectory.png", acquired_at))
        files.append(figs.plot_range_bearing(series, metrics.config.range,
                                             out_dir / "range_bearing.png", acquired_at))
    if strip is not None and any(strip.frames.values()):
        rows = {strip.titles[key]: frames for key, frames in strip.frames.items() if frames}
        files.append(figs.plot_sonar_strip(rows, out_dir / "sonar_strip.png"))
    return summary
