"""The mutable state a :class:`~uhrisim.sim.simulation.Simulation` owns: its agents (with
their sonars and cameras) and its scheduled events.

These are the Simulation's own records: it hands out snapshots
(:class:`~uhrisim.sim.hooks.AgentSnapshot`), never these objects. The builders
(:mod:`uhrisim.sim.build`), drivers and truth contacts work on them while the
Simulation advances. Units and frames: ``docs/conventions.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

from numpy.typing import NDArray

from uhrisim.dynamics.plants import NavState
from uhrisim.scenario.schema import AgentConfig, EventConfig
from uhrisim.sim.community import Community
from uhrisim.sim.hooks import HelmRecord
from uhrisim.vehicles import Controller, Driver, Plant, Sensor, VehicleModel


@dataclass
class SonarSlot:
    """A sonar on an agent with its tick period."""

    name: str
    sonar: Sensor  # uhrisim.sensors.sonar.sonar.ImagingSonar
    period: int


@dataclass
class CameraSlot:
    """A camera on an agent with its tick period."""

    name: str
    camera: Sensor  # uhrisim.sensors.camera.UnderwaterCamera
    period: int


@dataclass
class Agent:
    """Mutable per-agent state owned by the Simulation (hand out snapshots, not this)."""

    config: AgentConfig
    model: VehicleModel
    plant: Plant
    controller: Controller
    community: Community
    state: NDArray
    inputs: NDArray
    driver: Driver | None = None
    driver_period: int = 1
    control_period: int = 1
    sonars: list[SonarSlot] = field(default_factory=list)
    cameras: list[CameraSlot] = field(default_factory=list)
    kick_phase: float = 0.0
    actuator_override: NDArray | None = None
    actuator_override_until: float = -1.0
    in_contact: bool = False  # touching another body or the scene since the last tick
    last_helm: HelmRecord | None = None
    # a diver carrying out orders: the inputs its executor's directive chose (the
    # teamwork stage sets them; they replace the controller's)
    directed: NDArray | None = None
    _nav: NavState | None = None  # cache; cleared by every change of state or inputs

    @property
    def name(self) -> str:
        return self.config.name

    @property
    def radius(self) -> float:
        """The collision sphere's radius (m), the model's."""
        return self.model.collision_radius

    def update(self, state: NDArray | None = None, inputs: NDArray | None = None) -> None:
        """Replace the state and/or the actuator inputs (the only way the loop changes them)."""
        if state is not None:
            self.state = state
        if inputs is not None:
            self.inputs = inputs
        self._nav = None

    @cached_property
    def is_diver_body(self) -> bool:
        """Does this agent look like a diver in the scene (kicking legs and fins)? (Its
        configuration is frozen: asked every tick, answered once.)"""
        return self.config.scene_body == "diver"

    def nav(self) -> NavState:
        """Navigation truth now (cached until the state or the inputs change)."""
        if self._nav is None:
            self._nav = self.plant.nav(self.state, self.inputs)
        return self._nav

    def desired(self) -> tuple[float, float, float]:
        """DESIRED_HEADING (deg), DESIRED_SPEED (m/s), DESIRED_DEPTH (m) now."""
        c = self.community
        start = self.config.start
        return (float(c.get("DESIRED_HEADING", start.heading_deg % 360.0)),
                float(c.get("DESIRED_SPEED", 0.0)),
                float(c.get("DESIRED_DEPTH", start.depth)))


@dataclass
class ScheduledEvent:
    """A scripted event of the scenario, its index there, parsed condition, and whether
    it has fired (each fires once)."""

    config: EventConfig
    index: int
    condition: Any = None
    fired: bool = False
