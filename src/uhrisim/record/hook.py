"""The recorder as a simulation publish hook (``uhrisim.sim.simulation.Hook``).

:class:`McapRecordingHook` writes each :class:`~uhrisim.sim.hooks.TickFrame` through an
:class:`~uhrisim.record.McapRecorder` with the ROS translation's
:class:`~uhrisim.ros.tick.TickWriter`, the same the live ROS 2 bridge uses: agent
odometry, pose, ``/tf`` and ``/clock`` (every ``odom_every`` ticks), every sonar's pings
(images, hits, pose and the marine_acoustic_msgs/ProjectedSonarImage; every
``sonar_every``-th), the sonar perception's markers, every camera's frames (every
``camera_every``-th), helm decisions, community posts and events; at start the static
scene as triangle-list markers, every sensor mount on ``/tf_static``, the run's
seed/step as MCAP metadata and, in a team mission, the teamwork layout (:func:`team_layout`)
as a ``teamwork`` metadata record; at the end it closes the file (recording an ``error`` event
if the run failed). So every topic the live bridge publishes is recorded under the same
name, type and frame (docs/bridges-ros2.md).

It only reads what it is handed (hooks are read-only) and touches the simulation object
only in ``on_start``/``on_end`` for ``seed``, ``dt``, ``t``, ``agents`` and ``scene``, by
attribute, so it stays importable without the simulation package.
"""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path
from typing import Any

from uhrisim.core.errors import ConfigError, UhrisimError
from uhrisim.record.finish import finish_in_place
from uhrisim.record.mcap_recorder import McapRecorder
from uhrisim.record.rosbag2 import write_metadata
from uhrisim.ros.tick import TickWriter
from uhrisim.ros.topics import ros_name

logger = logging.getLogger(__name__)

__all__ = ["McapRecordingHook", "team_layout"]


def team_layout(workspace: Any) -> dict[str, Any]:
    """What a replay needs to know of a teamwork world that its ``/tf`` frames and events
    do not say (JSON-ready; NED metres): every tool's and load's kind by its ``/tf``
    frame name (``{"name", "kind", "held_by"}``: a tool kind or ``"load"``, its holders
    at the start, e.g. a tool the ROV's gripper carries from the outset), every flange's
    ``position`` and ``bolts``, every hatch's ``position`` and ``open_angle_deg``, every
    lift bag's ``capacity_litres`` (by name)."""
    def where(spec: Any) -> list[float]:
        return [round(float(v), 4) for v in spec.position_ned]

    objects = {ros_name(name): {"name": name, "kind": workspace.tools[name].kind
                                if name in workspace.tools else "load",
                                "held_by": list(workspace.holders_of(name))}
               for name in workspace.things}
    return {
        "objects": objects,
        "flanges": {name: {"position": where(spec), "bolts": int(spec.n_bolts)}
                    for name, spec in workspace.flanges.items()},
        "hatches": {name: {"position": where(spec),
                           "open_angle_deg": round(math.degrees(spec.open_angle), 3)}
                    for name, spec in workspace.hatches.items()},
        "bags": {name: {"capacity_litres": float(spec.capacity_litres)}
                 for name, spec in workspace.bags.items()},
    }


class McapRecordingHook:
    """Record a simulation run to ``path`` (see :mod:`uhrisim.record.mcap_recorder`).

    Parameters
    ----------
    path:
        Output ``.mcap`` file.
    odom_every:
        Record odometry every this many ticks (1: every physics tick).
    record_images, record_points:
        Whether sonar pings write their polar/fan images and hit points.
    record_scene:
        Write the static scene as markers at start (``scene_markers``).
    sonar_every:
        Record every this-many-th ping of each sonar (1: all; images are large).
    record_camera, camera_every:
        Whether camera frames are recorded (image, camera info, depth, labels, pose), and
        every this-many-th frame of each camera.
    chunk_size, flush_period_s:
        Passed to :class:`McapRecorder`; by default a chunk is also closed at least every
        simulated second, so a killed run loses at most about one second.
    rosbag2_metadata:
        At the end, write ``metadata.yaml`` beside the file: its folder becomes a rosbag2
        bag (:mod:`uhrisim.record.rosbag2`; keep one recording per folder then).
    """

    def __init__(
        self,
        path: Path | str,
        *,
        odom_every: int = 1,
        record_images: bool = True,
        record_points: bool = True,
        record_scene: bool = True,
        sonar_every: int = 1,
        record_camera: bool = True,
        camera_every: int = 1,
        chunk_size: int = 256 * 1024,
        flush_period_s: float | None = 1.0,
        rosbag2_metadata: bool = True,
    ) -> None:
        if int(odom_every) < 1:
            raise ConfigError(f"odom_every must be >= 1, got {odom_every}",
                              where="McapRecordingHook")
        self.path = Path(path)
        self.odom_every = int(odom_every)
        self.record_images = record_images
        self.record_points = record_points
        self.record_scene = record_scene
        if int(sonar_every) < 1:
            raise ConfigError(f"sonar_every must be >= 1, got {sonar_every}",
                              where="McapRecordingHook")
        self.sonar_every = int(sonar_every)
        self._pings_seen: dict[str, int] = {}
        if int(camera_every) < 1:
            raise ConfigError(f"camera_every must be >= 1, got {camera_every}",
                              where="McapRecordingHook")
        self.record_camera = record_camera
        self.camera_every = int(camera_every)
        self._images_seen: dict[str, int] = {}
        self._chunk_size = chunk_size
        self.rosbag2_metadata = rosbag2_metadata
        self._flush_period_s = flush_period_s
        self._rec: McapRecorder | None = None
        self._tick: TickWriter | None = None
        #: After the file could not be written on (a full disk): what became of it.
        self.cut_outcome: str | None = None

    @classmethod
    def for_scenario(cls, scenario: Any, path: Path | str) -> McapRecordingHook:
        """The recorder of a run of ``scenario`` (``uhrisim run``'s): its ``recording``
        settings (sonar and camera frames and their spacing, chunk size, odometry rate)."""
        rec = scenario.recording
        return cls(path, record_images=rec.sonar, sonar_every=rec.sonar_every,
                   record_camera=rec.camera, camera_every=rec.camera_every,
                   chunk_size=rec.chunk_kib * 1024,
                   odom_every=max(1, round(scenario.physics_rate_hz / rec.odometry_rate_hz)))

    @property
    def recorder(self) -> McapRecorder | None:
        return self._rec

    def on_start(self, sim: Any) -> None:
        meta = {"seed": str(getattr(sim, "seed", "")), "dt": repr(getattr(sim, "dt", ""))}
        scenario = getattr(sim, "scenario", None)
        if scenario is not None and getattr(scenario, "name", None):
            meta["scenario"] = str(scenario.name)
        # a live ROS 2 bridge in a namespace: the bag's topics are its live names
        namespace = next((h.ros_namespace for h in getattr(sim, "hooks", ())
                          if getattr(h, "ros_namespace", "")), "")
        records = {"uhrisim": meta}
        workspace = getattr(getattr(sim, "team", None), "workspace", None)
        if workspace is not None:
            records["teamwork"] = {"layout": json.dumps(team_layout(workspace))}
        self._rec = McapRecorder(
            self.path, chunk_size=self._chunk_size, flush_period_s=self._flush_period_s,
            metadata=records, namespace=namespace,
        )
        self._tick = TickWriter(self._rec)
        self._tick.start(sim, scene=self.record_scene)

    def on_tick(self, frame: Any) -> None:
        rec, out = self._rec, self._tick
        if rec is None or out is None:
            return
        t = float(frame.t)
        if frame.tick % self.odom_every == 0:
            rec.write_clock(t)
            out.odometry(t, frame.agents)
            out.joints(t, getattr(frame, "joints", {}))
            out.objects(t)
        for key, ping in frame.pings.items():
            seen = self._pings_seen.get(key, 0)
            self._pings_seen[key] = seen + 1
            if seen % self.sonar_every == 0:
                out.ping(key, ping, images=self.record_images, points=self.record_points)
        for key, image in getattr(frame, "images", {}).items():
            seen = self._images_seen.get(key, 0)
            self._images_seen[key] = seen + 1
            if self.record_camera and seen % self.camera_every == 0:
                out.image(key, image)
        for agent, h in frame.helm.items():
            out.helm(agent, t, h)
        out.posts(frame.posts)
        out.events(frame.events)
        for key, seen in getattr(frame, "perception", {}).items():
            out.perception(key, t, seen, frame.pings[key])

    def on_end(self, sim: Any, error: BaseException | None) -> None:
        rec = self._rec
        if rec is None:
            return
        if error is not None and not rec.closed and not rec.cut:
            rec.write_event(float(getattr(sim, "t", 0.0)), "error",
                            f"{type(error).__name__}: {error}")
        was_open = not rec.closed
        rec.close()
        if rec.cut and was_open:  # a full disk: completed where it lies, in the headroom
            try:
                finish_in_place(self.path)
                write_metadata(self.path)
                self.cut_outcome = "the recording is complete up to there"
            except (UhrisimError, OSError):
                self.cut_outcome = ("the recording ends at its last whole chunk; no room to "
                                    "complete it: free some and run uhrisim recover")
            return
        if self.rosbag2_metadata and was_open:
            write_metadata(self.path)

    def summary(self) -> dict[str, Any]:
        rec = self._rec
        if rec is None:
            return {"path": str(self.path), "messages": 0}
        counts = rec.message_counts
        return {"path": str(self.path), "messages": sum(counts.values()),
                "topics": counts, "bytes": rec.bytes_written}

