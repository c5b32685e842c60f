"""Turn a validated scenario into live agents and scheduled events.

The builders take the simulation under construction as a :class:`BuildContext` — what
they read of it — so that they sit below :class:`~uhrisim.sim.simulation.Simulation`,
which calls them; what they build are the records of :mod:`uhrisim.sim.state`.
"""

from __future__ import annotations

import difflib
import math
from typing import Protocol

import numpy as np

from uhrisim.autonomy.bhv import load_bhv
from uhrisim.autonomy.community import VehicleAutonomy
from uhrisim.autonomy.conditions import parse_condition
from uhrisim.autonomy.config import HelmConfig, parse_domain
from uhrisim.autonomy.contacts import AlertSpec, ContactManagerConfig
from uhrisim.autonomy.moos_file import load_helm_from_moos
from uhrisim.core.clock import ticks_for_rate
from uhrisim.core.errors import ConfigError, warn_user
from uhrisim.core.frames import rot_z
from uhrisim.dynamics.diver_body import DiverSkeleton
from uhrisim.scenario.build_world import material_named, object_mesh
from uhrisim.scenario.load import ScenarioFile
from uhrisim.scenario.schema import AgentConfig, CameraSensor, Scenario, SonarSensor
from uhrisim.scenario.sections import part_settings
from uhrisim.sim.community import Community
from uhrisim.sim.drivers import HelmDriver, ScriptedDriver
from uhrisim.sim.script import ScriptDriver
from uhrisim.sim.state import Agent, CameraSlot, ScheduledEvent, SonarSlot
from uhrisim.vehicles import MODELS, Plant, VehicleModel
from uhrisim.world.assets import diver_parts, videoray_mesh
from uhrisim.world.diver_figure import diver_figure
from uhrisim.world.materials import DIVER_PART_MATERIALS, DRY_SUIT, NEOPRENE, ROV_PLASTIC
from uhrisim.world.scene import Scene

#: the rate of a helm the scenario does not set up (the assistant's; Hz, the paper's)
HELM_RATE_HZ = 4.0


class BuildContext(Protocol):
    """What the builders read of the simulation they build for (a Simulation is one): the
    scenario and its file, the physics step ``dt`` (s), the scene the agents' bodies are
    added to, and the named random streams."""

    source: ScenarioFile
    scenario: Scenario
    dt: float
    scene: Scene

    def rng(self, component: str) -> np.random.Generator: ...


def _sonar(sim: BuildContext, cfg: AgentConfig, index: int, sensor: SonarSensor):
    from uhrisim.sensors.sonar.config import SonarConfig
    from uhrisim.sensors.sonar.sonar import ImagingSonar

    water = sim.scenario.world.water
    where = sim.source.where("agents", _agent_index(sim, cfg.name), "sensors", index)
    try:
        config = SonarConfig(**part_settings(sensor), water_temperature_c=water.temperature_c,
                             salinity_psu=water.salinity_psu, ph=water.ph)
    except ConfigError as error:
        raise ConfigError(str(error), where=where) from None
    if config.effective_rate_hz < sensor.rate_hz - 1e-9:
        period = math.ceil(1.0 / (config.effective_rate_hz * sim.dt) - 1e-9)
    else:
        period = ticks_for_rate(sensor.rate_hz, sim.dt, f"{where}: rate_hz")
    # the random stream keeps its name by position (seeds reproduce the runs before names)
    sonar = ImagingSonar(config, sim.rng(f"{cfg.name}/sonar{index}"))
    return SonarSlot(sensor.name, sonar, period)


def _camera(sim: BuildContext, cfg: AgentConfig, index: int, sensor: CameraSensor):
    from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov, measured

    where = sim.source.where("agents", _agent_index(sim, cfg.name), "sensors", index)
    w = sensor.water
    try:
        water = (measured(w.attenuation, w.single_scattering_albedo) if w.attenuation
                 else jerlov(w.jerlov or "IB"))
        config = CameraConfig(**part_settings(sensor), water=water)
    except ConfigError as error:
        raise ConfigError(str(error), where=where) from None
    period = ticks_for_rate(sensor.rate_hz, sim.dt, f"{where}: rate_hz")
    camera = UnderwaterCamera(config, sim.rng(f"{cfg.name}/camera{index}"))  # as the sonar's
    return CameraSlot(sensor.name, camera, period)


def _agent_index(sim: BuildContext, name: str) -> int:
    return [a.name for a in sim.scenario.agents].index(name)


def known_external_vars(sim: BuildContext, agent_name: str) -> set[str]:
    """Variables posted into this agent's community from outside its helm."""
    s = sim.scenario
    known = {b.var for b in s.buttons if b.agent == agent_name}
    known |= {e.post.var for e in s.events if e.post and e.post.agent == agent_name}
    known |= {"NODE_REPORT", "MOOS_MANUAL_OVERRIDE"}
    return known


def _engages(scenario: Scenario, agent_name: str) -> bool:
    """Whether an event or a button of the scenario posts MOOS_MANUAL_OVERRIDE = false."""
    posts = [e.post for e in scenario.events if e.post] + list(scenario.buttons)
    return any(p.agent == agent_name and p.var == "MOOS_MANUAL_OVERRIDE"
               and str(p.value).lower() == "false" for p in posts)


def _helm_driver(sim: BuildContext, cfg: AgentConfig, community: Community) -> HelmDriver:
    index = _agent_index(sim, cfg.name)
    section = cfg.helm
    alerts = tuple(AlertSpec(id=a.var.lower(), var=a.var, pattern=a.pattern,
                             alert_range=a.alert_range, cpa_range=a.cpa_range)
                   for a in cfg.contacts.alerts)
    known = known_external_vars(sim, cfg.name) | {a.var for a in alerts}
    if section is None:  # the assistant's helm (docs/hri.md): the shipped assistant.bhv
        from uhrisim.assistant import HELM_DOMAIN, assistant_bhv
        helm_config = load_bhv(assistant_bhv(), known, parse_domain(list(HELM_DOMAIN)))
    elif section.moos_file:
        helm_config = load_helm_from_moos(sim.source.resolve(section.moos_file),
                                          section.moos_process)
    elif section.bhv_file:
        domain = parse_domain(dict(section.domain), sim.source.where(
            "agents", index, "helm", "domain")) if section.domain else None
        helm_config = load_bhv(sim.source.resolve(section.bhv_file), known, domain,
                               section.macros)
    else:
        mapping = {"initialize": dict(section.initialize), "modes": list(section.modes),
                   "behaviors": [dict(b) for b in section.behaviors]}
        if section.domain:
            mapping["domain"] = dict(section.domain)
        helm_config = HelmConfig.from_mapping(
            mapping, where=sim.source.where("agents", index, "helm"), known_vars=known)
    if not helm_config.settings.start_engaged and not _engages(sim.scenario, cfg.name):
        msg = (f"{sim.source.where('agents', index, 'helm')}: {cfg.name}'s helm starts "
               "parked (pHelmIvP's start_engaged is false) and no event or button posts "
               "MOOS_MANUAL_OVERRIDE = false: it drives only if a bridge posts it")
        warn_user(msg)
    autonomy = VehicleAutonomy(cfg.name, helm_config, ContactManagerConfig(alerts=alerts))
    return HelmDriver(autonomy, community.mailbox())


def _add_body(sim: BuildContext, cfg: AgentConfig, model: VehicleModel, plant: Plant,
              state) -> None:
    position, rotation = state[:3], rot_z(state[3])
    material = material_named(cfg.material, f"agents.{cfg.name}.material") \
        if cfg.material else None
    if cfg.scene_body == "figure":  # the articulated diver, posed by the teamwork stage
        skeleton = (model.diver.skeleton(cfg, plant) if model.diver is not None
                    else DiverSkeleton())
        sim.scene.add_dynamic(cfg.name, diver_figure(skeleton, part_materials=(
                                  None if material else DIVER_PART_MATERIALS)),
                              cfg.label or "diver",
                              material or NEOPRENE, position, rotation)
    elif cfg.scene_body == "diver":  # dressed as the figure unless given a material
        parts = (diver_parts(material) if material else
                 diver_parts(DRY_SUIT, DIVER_PART_MATERIALS["tank"], DIVER_PART_MATERIALS["fins"]))
        sim.scene.add_dynamic(cfg.name, parts, cfg.label or "diver",
                              material or DRY_SUIT, position, rotation, 0.0)
    else:
        sim.scene.add_dynamic(cfg.name, videoray_mesh(), cfg.label or "rov",
                              material or ROV_PLASTIC, position, rotation)


def build_agents(sim: BuildContext, raycast_sensors: bool) -> dict[str, Agent]:
    """The scenario's agents; ``raycast_sensors`` False builds none of their sonars and
    cameras (the sensors that cast rays into the scene)."""
    rec = sim.scenario.recording
    if rec.enabled:  # the recorder's odometry rate, like every rate: whole steps
        ticks_for_rate(rec.odometry_rate_hz, sim.dt,
                       sim.source.where("recording", "odometry_rate_hz"))
    agents: dict[str, Agent] = {}
    floor = sim.scene.depth_at if sim.scene.seafloor is not None else None
    for index, cfg in enumerate(sim.scenario.agents):
        model = MODELS[cfg.model]
        try:
            plant = model.make_plant(cfg, sim.dt, cfg.name, floor)
        except ConfigError as error:  # e.g. a model too stiff for the step
            raise ConfigError(str(error), sim.source.where("agents", index, "model")) from None
        _check_start(sim, index, cfg, agents)
        start = cfg.start
        state = plant.initial_state(np.array([start.north, start.east, start.depth]),
                                    math.radians(start.heading_deg))
        community = Community(cfg.name)
        agent = Agent(config=cfg, model=model, plant=plant,
                      controller=model.make_controller(cfg, plant), community=community,
                      state=state, inputs=np.zeros(plant.input_size))
        _add_body(sim, cfg, model, plant, state)
        if cfg.control_rate_hz is not None:
            agent.control_period = ticks_for_rate(
                cfg.control_rate_hz, sim.dt,
                sim.source.where("agents", index, "control_rate_hz"))
        if cfg.driver == "helm":
            agent.driver = _helm_driver(sim, cfg, community)
            agent.driver_period = ticks_for_rate(
                cfg.helm.rate_hz if cfg.helm is not None else HELM_RATE_HZ, sim.dt,
                sim.source.where("agents", index, "helm", "rate_hz"))
        elif cfg.driver == "script":
            agent.driver = ScriptedDriver(ScriptDriver(cfg.script))
            agent.driver_period = ticks_for_rate(4.0, sim.dt, f"agents.{cfg.name}.script")
        if raycast_sensors:
            agent.sonars = [_sonar(sim, cfg, i, s) for i, s in enumerate(cfg.sensors)
                            if s.type == "sonar"]
            agent.cameras = [_camera(sim, cfg, i, s) for i, s in enumerate(cfg.sensors)
                             if s.type == "camera"]
        agents[cfg.name] = agent
    return agents


def _check_start(sim: BuildContext, index: int, cfg: AgentConfig,
                 placed: dict[str, Agent]) -> None:
    """An agent starts in the water: not in the sea floor or a solid object, and clear of
    the agents placed before it (their collision spheres do not overlap)."""
    where = sim.source.where("agents", index, "start")
    start = np.array(cfg.start.as_list())
    inside = sim.scene.inside_solid(start)
    if inside is not None:
        raise ConfigError(f"agents[{index}].start: {cfg.name} would start {inside}", where)
    radius = MODELS[cfg.model].collision_radius
    for other in placed.values():
        gap = float(np.linalg.norm(other.nav().position_ned - start))
        if gap < radius + other.radius:
            raise ConfigError(
                f"agents[{index}].start: {cfg.name} starts {gap:.2f} m from {other.name}, "
                f"inside its collision distance {radius + other.radius:.2f} m", where)


def build_events(sim: BuildContext) -> list[ScheduledEvent]:
    events = []
    movable = sim.scenario.movable_labels()
    for index, cfg in enumerate(sim.scenario.events):
        # what an event acts on must exist now, not only when it fires
        if cfg.add_object is not None:
            object_mesh(cfg.add_object, sim.source, sim.source.where("events", index, "add_object"))
        if cfg.move_object is not None and cfg.move_object.label not in movable:
            close = difflib.get_close_matches(cfg.move_object.label, sorted(movable), n=1)
            hint = (f"; did you mean {close[0]!r}?" if close else
                    "; only movable objects (movable: true) can be moved")
            raise ConfigError(f"events[{index}].move_object names no movable object "
                              f"{cfg.move_object.label!r}{hint}",
                              sim.source.where("events", index, "move_object"))
        condition = None
        if cfg.when is not None:
            condition = parse_condition(cfg.when, sim.source.where("events", index, "when"))
        events.append(ScheduledEvent(cfg, index, condition))
    return events
