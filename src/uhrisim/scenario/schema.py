"""The scenario file format: strict, typed, frozen (docs/design.md habit 6).

Every default lives once: here, or for a part of the simulator (sonar, camera, VideoRay,
its controller) in the part's own declaration, which the section embeds
(:mod:`uhrisim.scenario.sections`). Unknown keys are errors with a did-you-mean; values
out of range fail with the field path (the loader adds the file line). Positions are NED
(``north``, ``east``, ``depth``), headings compass degrees, everything else SI.
"""

from __future__ import annotations

import difflib
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (
    AfterValidator,
    Discriminator,
    Field,
    Tag,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from uhrisim.autonomy.params import checked_value
from uhrisim.control.videoray_p import GAIN_PRESETS, PGains
from uhrisim.core.errors import ConfigError
from uhrisim.dynamics.videoray import VideoRayParams
from uhrisim.scenario.assistance import AssistantSection
from uhrisim.scenario.sections import declared_as, scenario_section
from uhrisim.scenario.strict import Strict
from uhrisim.scenario.teamwork import (
    GripperSection,
    OrderConfig,
    Silt,
    Site,
    SkeletonSection,
    ToolConfig,
)
from uhrisim.sensors.camera.config import CameraConfig
from uhrisim.sensors.sonar.config import SonarConfig
from uhrisim.vehicles import MODELS
from uhrisim.world.bubbles import BubbleParams

# -0.0 passes ge=0 but numpy refuses it as a scale ("scale < 0"): made +0.0
NonNegativeFloat = Annotated[float, Field(ge=0.0), AfterValidator(lambda x: x + 0.0)]

# The physical ranges of the scenario's own numbers (the parts' settings declare theirs in
# their dataclasses, docs/settings.md). A value beyond them is a typo or a unit slip, and
# would overflow the models or their cost: refused at load with the field's line.
#: Sizes, extents, ranges and distances, m: up to 10 km.
Length = Annotated[float, Field(gt=0.0, le=1.0e4)]
NonNegativeLength = Annotated[NonNegativeFloat, Field(le=1.0e4)]
#: Depths of water, m: down to the deepest ocean.
WaterDepth = Annotated[float, Field(gt=0.0, le=11_000.0)]
#: Durations and times, s: up to 10^7 s (116 days).
Seconds = Annotated[float, Field(gt=0.0, le=1.0e7)]
NonNegativeSeconds = Annotated[NonNegativeFloat, Field(le=1.0e7)]
#: Rates, Hz.
RateHz = Annotated[float, Field(gt=0.0, le=1000.0)]
#: Speeds through the water, m/s (the VideoRay's top speed is ~1.6 m/s, a diver's ~1).
Speed = Annotated[float, Field(gt=0.0, le=10.0)]
NonNegativeSpeed = Annotated[NonNegativeFloat, Field(le=10.0)]
#: A time-scaling factor (MOOS time warp, real-time factor).
Factor = Annotated[float, Field(gt=0.0, le=1000.0)]
#: A count of steps or cells.
Count = Annotated[int, Field(ge=1, le=1_000_000)]
#: How far from the origin a scene reaches horizontally, m: the local NED frame is a flat
#: tangent plane, good to ~100 km (and a sonar at 10^7 m loses its metres to rounding).
HORIZON_M = 1.0e5
Horizontal = Annotated[float, Field(ge=-HORIZON_M, le=HORIZON_M)]
#: Depth of a point, m: from 100 m above the surface (a pier's top) to the deepest ocean.
PointDepth = Annotated[float, Field(ge=-100.0, le=11_000.0)]
#: Most objects in one scene: each is geometry every ray may hit (200 spheres of 1280
#: triangles take ~170 MB more to validate than none).
MAX_OBJECTS = 200


def _variable_name(name: str) -> str:
    if not name or any(c.isspace() for c in name):
        raise ValueError(f"a MOOS variable name must be one word, got {name!r}")
    return name


#: A MOOS variable name: not empty, no white space.
VarName = Annotated[str, AfterValidator(_variable_name)]
HeadingDeg = Annotated[float, Field(ge=-360.0, le=360.0)]
#: A name that is also one ROS name token: agents, sensors, labels.
Name = Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_]*$")]


class Vec3(Strict):
    """A point in world NED (m)."""

    north: Horizontal = 0.0
    east: Horizontal = 0.0
    depth: PointDepth = 0.0

    def as_list(self) -> list[float]:
        return [self.north, self.east, self.depth]


class Pose(Vec3):
    """A NED position plus compass heading (deg)."""

    heading_deg: HeadingDeg = 0.0


class Water(Strict):
    """The water, as the sonars' absorption and sound speed read it (Francois-Garrison;
    the sound speed follows from temperature and salinity, it is not set)."""

    temperature_c: Annotated[float, Field(ge=-2.0, le=40.0)] = 15.0
    salinity_psu: Annotated[float, Field(ge=0.0, le=45.0)] = 35.0
    ph: Annotated[float, Field(ge=6.0, le=9.5)] = 8.0


class FlatFloor(Strict):
    type: Literal["flat"]
    depth: WaterDepth = 10.0
    extent: Length = 200.0


class SlopedFloor(Strict):
    type: Literal["sloped"]
    depth: WaterDepth = 10.0
    slope: Annotated[float, Field(ge=-1.0, le=1.0)] = 0.05
    direction_deg: HeadingDeg = 0.0
    extent: Length = 200.0


class GridFloor(Strict):
    type: Literal["grid"]
    file: str
    spacing: Length = 1.0


class ProceduralFloor(Strict):
    type: Literal["procedural"]
    depth: WaterDepth = 10.0
    roughness: Annotated[NonNegativeFloat, Field(le=100.0)] = 1.0
    extent: Length = 200.0
    seed: Annotated[int, Field(ge=0)] = 0


SeaFloor = Annotated[FlatFloor | SlopedFloor | GridFloor | ProceduralFloor,
                     Field(discriminator="type")]


class ObjectBase(Strict):
    """A scene object. ``movable`` objects are dynamic bodies named by their label, which
    scripted events can move (``move_object``); the rest are static geometry."""

    label: str
    material: str = "concrete"
    position: Vec3 = Vec3()
    heading_deg: HeadingDeg = 0.0
    movable: bool = False


class BoxObject(ObjectBase):
    type: Literal["box"]
    size: tuple[Length, Length, Length]


class CylinderObject(ObjectBase):
    type: Literal["cylinder"]
    radius: Length
    height: Length


class SphereObject(ObjectBase):
    type: Literal["sphere"]
    radius: Length


class TorusObject(ObjectBase):
    type: Literal["torus"]
    major_radius: Length
    minor_radius: Length


class CapsuleObject(ObjectBase):
    type: Literal["capsule"]
    radius: Length
    height: Length


class MeshObject(ObjectBase):
    type: Literal["mesh"]
    file: str
    scale: Annotated[float, Field(gt=0.0, le=1.0e4)] = 1.0


SceneObject = Annotated[
    BoxObject | CylinderObject | SphereObject | TorusObject | CapsuleObject | MeshObject,
    Field(discriminator="type"),
]


class World(Strict):
    """The water, the sea floor, static objects, and for teamwork the tools, work sites
    and silt (:mod:`uhrisim.scenario.teamwork`)."""

    water: Water = Water()
    seafloor: SeaFloor | None = None
    objects: Annotated[tuple[SceneObject, ...], Field(max_length=MAX_OBJECTS)] = ()
    tools: tuple[ToolConfig, ...] = ()
    sites: tuple[Site, ...] = ()
    silt: Silt | None = None

    @model_validator(mode="after")
    def _unique_names(self) -> World:
        names = [t.name for t in self.tools] + [s.name for s in self.sites]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"tool and site names must be unique; repeated: "
                             f"{', '.join(repeated)}")
        return self


#: The keys a sensor section had before it took its part's names (read with a warning).
_MOUNT_KEYS = {"mount.position": "mount_position_frd", "mount.tilt_deg": "tilt_deg",
               "mount.yaw_deg": "yaw_deg"}


class SonarSensor(scenario_section(
        SonarConfig, "SonarSettings",
        exclude=("spec", "water_temperature_c", "salinity_psu", "water_depth_m", "ph"))):
    """An imaging sonar: every setting of :class:`~uhrisim.sensors.sonar.SonarConfig`
    under its own name, default and bounds (docs/settings.md), the water from
    ``world.water``. ``name``: what its outputs are keyed and published by
    (``<agent>/<name>``; default: :func:`default_sensor_names`)."""

    type: Literal["sonar"] = "sonar"
    name: Name | None = None
    legacy_keys: ClassVar[dict[str, str]] = {
        "min_range": "range_min_m", "max_range": "range_max_m", "fan_width_px": "fan_size_px",
        **_MOUNT_KEYS, "image.*": "*"}


#: A beam attenuation coefficient, 1/m (clearest ocean ~0.05, a turbid harbour ~10).
Attenuation = Annotated[float, Field(gt=0.0, le=100.0)]


class CameraWater(Strict):
    """The water the camera looks through: a Jerlov type (docs/camera.md), or a measured
    beam attenuation c per channel (1/m, R G B) split by the single-scattering albedo."""

    jerlov: Literal["I", "IA", "IB", "II", "III", "1C", "3C", "7C", "9C"] | None = None
    attenuation: tuple[Attenuation, Attenuation, Attenuation] | None = None
    single_scattering_albedo: Annotated[float, Field(ge=0.0, lt=1.0)] = 0.8

    @model_validator(mode="after")
    def _one_source(self) -> CameraWater:
        if self.jerlov is not None and self.attenuation is not None:
            raise ValueError("give either jerlov or attenuation, not both")
        return self


class CameraSensor(scenario_section(CameraConfig, "CameraSettings", exclude=("water",))):
    """An underwater colour camera (docs/camera.md): every setting of
    :class:`~uhrisim.sensors.camera.CameraConfig` under its own name, default and bounds
    (None: the preset's value), and the water it looks through."""

    type: Literal["camera"]
    name: Name | None = None  # default: see default_sensor_names
    water: CameraWater = CameraWater()
    legacy_keys: ClassVar[dict[str, str]] = {"max_range": "max_range_m", "lamps": "lamps_on",
                                             **_MOUNT_KEYS}


def _sensor_kind(value: Any) -> str:
    """The sensor's ``type`` (a sonar may leave it out)."""
    kind = value.get("type", "sonar") if isinstance(value, dict) else getattr(
        value, "type", "sonar")
    return kind if kind in ("sonar", "camera") else "sonar"


Sensor = Annotated[
    Annotated[SonarSensor, Tag("sonar")] | Annotated[CameraSensor, Tag("camera")],
    Discriminator(_sensor_kind),
]


def default_sensor_names(sensors: tuple[SonarSensor | CameraSensor, ...]) -> list[str]:
    """Each sensor's name: its own ``name``, else its type for the first sensor of that
    type on the agent and the type with its ordinal after (``sonar``, ``sonar_2``,
    ``camera``): stable, and the ROS topics of an agent with one sonar stay
    ``/<agent>/sonar/...``."""
    names, seen = [], {"sonar": 0, "camera": 0}
    for sensor in sensors:
        seen[sensor.type] += 1
        ordinal = seen[sensor.type]
        names.append(sensor.name or (sensor.type if ordinal == 1 else f"{sensor.type}_{ordinal}"))
    return names


VideoRayModelConfig = scenario_section(
    VideoRayParams, "VideoRayModelConfig", include=("J", "moment_arm", "thrust_map", "coupling"),
    doc="The VideoRay's model settings a scenario may change (VideoRayParams).")

ControllerConfig = scenario_section(
    PGains, "ControllerConfig", overrides=True,
    fields={"preset": (Literal[tuple(GAIN_PRESETS)], "mission")},  # type: ignore[valid-type]
    doc="P controller of the paper (eqs 5-9): ``preset`` (GAIN_PRESETS), then the gains "
        "given override it (PGains).")


class DiverLimits(Strict):
    max_speed: Speed = 1.0
    max_turn_rate_deg: Annotated[float, Field(gt=0.0, le=360.0)] = 30.0
    max_vertical_rate: Speed = 0.3


class HelmSection(Strict):
    """Behaviors inline (MOOS-IvP vocabulary), from a ``.bhv`` file, or the pHelmIvP block
    of a MOOS mission file (``moos_file``: its Behaviors, Domain and settings); files are
    beside the scenario. ``macros`` feed nsplug's ``$(NAME)`` / ``#ifdef`` in a ``bhv_file``
    (uhrisim's helm expands it); a ``moos_file`` is read as MOOS and pHelmIvP read it,
    without nsplug."""

    rate_hz: RateHz = 4.0
    bhv_file: str | None = None
    moos_file: str | None = None
    moos_process: str = "pHelmIvP"
    macros: dict[str, str | float] = Field(default_factory=dict)
    initialize: dict[VarName, str | float | bool] = Field(default_factory=dict)
    modes: tuple[str, ...] = ()
    behaviors: tuple[dict[str, Any], ...] = ()
    domain: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _one_source(self) -> HelmSection:
        given = [k for k in ("bhv_file", "moos_file") if getattr(self, k)]
        inline = [k for k in ("behaviors", "modes", "initialize") if getattr(self, k)]
        if len(given) > 1:
            raise ValueError("give either bhv_file or moos_file, not both")
        if given and inline:
            raise ValueError(f"give either {given[0]} or inline {inline[0]}, not both")
        if self.moos_file and self.domain:
            raise ValueError("with moos_file the domain comes from its Domain lines")
        if self.macros and not self.bhv_file:
            raise ValueError("macros apply to a bhv_file: a moos_file is read as pHelmIvP "
                             "reads it, without nsplug (expand it with nsplug first)")
        return self


class ScriptLeg(Strict):
    """One leg of a scripted diver: from time ``t`` hold heading/speed/depth, or go to a point."""

    t: NonNegativeSeconds
    heading_deg: HeadingDeg | None = None
    speed: NonNegativeSpeed = 0.5
    depth: Annotated[NonNegativeFloat, Field(le=11_000.0)] | None = None
    goto: Vec3 | None = None

    @model_validator(mode="after")
    def _heading_or_goto(self) -> ScriptLeg:
        if (self.heading_deg is None) == (self.goto is None):
            raise ValueError("a script leg needs exactly one of heading_deg or goto")
        return self


def _legs_in_time_order(legs: tuple[ScriptLeg, ...]) -> tuple[ScriptLeg, ...]:
    for i in range(1, len(legs)):
        if not legs[i].t > legs[i - 1].t:
            raise ValueError(f"script legs must be in time order: leg {i} at t={legs[i].t:g} s "
                             f"does not come after leg {i - 1} at t={legs[i - 1].t:g} s")
    return legs


class AlertConfig(Strict):
    """A contact-manager alert (MOOS pContactMgrV20 style)."""

    var: VarName = "TRAIL_INFO"
    pattern: str = "name=$[VNAME] # contact=$[VNAME]"
    alert_range: Length = 40.0
    cpa_range: Length = 50.0


class SonarContactsConfig(Strict):
    """Contacts from the agent's own sonar (``contacts.source: sonar``): the perception
    chain's settings and how the diver track is reported (docs/perception.md). A
    perception setting left null takes the perception's own default
    (``uhrisim.perception``: DetectorParams, BlobParams, TrackerParams,
    PerceptionParams)."""

    name: Name = "diver"
    vehicle_type: str = "DIVER"
    sensor: Name | None = None  # the sonar perception reads; None: the agent's first sonar
    k_sigma: Annotated[float, Field(gt=0.0, le=1000.0)] | None = None
    min_contrast: Annotated[float, Field(ge=0.0, le=1.0)] | None = None
    min_level: Annotated[float, Field(ge=0.0, le=1.0)] | None = None
    min_range: NonNegativeLength | None = None
    min_cells: Count | None = None
    merge_radius: NonNegativeLength | None = None
    confirm: tuple[Count, Count] | None = None
    max_coast: Seconds | None = None
    accel_std: Annotated[float, Field(gt=0.0, le=1000.0)] | None = None
    diver_probability: Annotated[float, Field(gt=0.0, lt=1.0)] | None = None
    classifier: str | None = None  # JSON file beside the scenario; None: the shipped one
    lost_var: VarName = "DIVER_LOST"
    search_var: VarName = "DIVER_SEARCH_UPDATES"
    silence_warn: Seconds = 30.0  # s without a detection before an event says so

    @model_validator(mode="after")
    def _m_of_n(self) -> SonarContactsConfig:
        if self.confirm is not None and self.confirm[0] > self.confirm[1]:
            raise ValueError(f"confirm: M={self.confirm[0]} hits of N={self.confirm[1]} "
                             "pings needs M <= N")
        return self


class ContactsConfig(Strict):
    """Where contact reports come from: simulation truth (as in the paper), degraded, or
    the agent's own sonar through the perception chain."""

    source: Literal["truth", "sonar"] = "truth"
    sonar: SonarContactsConfig = SonarContactsConfig()
    rate_hz: RateHz = 4.0
    position_noise_std: NonNegativeLength = 0.0
    latency: NonNegativeSeconds = 0.0
    dropout: Annotated[float, Field(ge=0.0, lt=1.0)] = 0.0
    alerts: tuple[AlertConfig, ...] = ()


class BubblesConfig(Strict):
    """A diver's exhaled bubble plume (uhrisim.world.bubbles): a burst every ``period`` s
    of ``clusters`` clouds of ``bubbles_per_cluster`` air spheres (``radius`` m) rising at
    ``rise_speed`` m/s, spreading at ``spread_speed`` m/s (σ per axis) and drifting with
    ``current`` (north, east, m/s) until the surface or ``max_age`` s. Ranges and the
    plume's cost bound: :class:`~uhrisim.world.bubbles.BubbleParams`."""

    period: declared_as(BubbleParams, "period_s") = 4.0
    clusters: declared_as(BubbleParams, "clusters") = 3
    bubbles_per_cluster: declared_as(BubbleParams, "bubbles_per_cluster") = 6
    radius: declared_as(BubbleParams, "radius_m") = 0.03
    rise_speed: declared_as(BubbleParams, "rise_speed") = 0.3
    spread_speed: declared_as(BubbleParams, "spread_speed") = 0.12
    current: declared_as(BubbleParams, "current_ned") = (0.0, 0.0)
    max_age: declared_as(BubbleParams, "max_age_s") = 12.0

    @model_validator(mode="after")
    def _affordable(self) -> BubblesConfig:
        try:
            self.params()  # the plume's cost bound
        except ConfigError as error:
            raise ValueError(error.problem) from None
        return self

    def params(self) -> BubbleParams:
        """The plume's parameters."""
        return BubbleParams(period_s=self.period, clusters=self.clusters,
                            bubbles_per_cluster=self.bubbles_per_cluster, radius_m=self.radius,
                            rise_speed=self.rise_speed, spread_speed=self.spread_speed,
                            current_ned=tuple(self.current), max_age_s=self.max_age)


class AgentConfig(Strict):
    name: Name
    model: Literal[tuple(MODELS)]  # type: ignore[valid-type]  # uhrisim.vehicles
    start: Pose = Pose()
    # "orders": a diver carries out its ``orders`` (uhrisim.teamwork.executor)
    driver: Literal["helm", "script", "external", "orders", "none"] = "helm"
    videoray: VideoRayModelConfig = VideoRayModelConfig()
    controller: ControllerConfig = ControllerConfig()
    # How often the controller turns DESIRED_* into actuator inputs; None: every physics
    # step. (The authors' ROS control node ran at 10 Hz.)
    control_rate_hz: RateHz | None = None
    diver_limits: DiverLimits = DiverLimits()
    helm: HelmSection | None = None
    script: tuple[ScriptLeg, ...] = ()
    contacts: ContactsConfig = ContactsConfig()
    sensors: tuple[Sensor, ...] = ()
    # The 3-D body in the scene (what sonars see); default: the model's own (a kinematic
    # vehicle looks like the VideoRay).
    body: Literal["videoray", "diver", "figure"] | None = None
    material: str | None = None
    bubbles: BubblesConfig | None = None  # exhaled bubble plume (open-circuit scuba)
    # The body's label in the sonar's label images; default: its kind ("diver" or "rov").
    label: Name | None = None
    vehicle_type: str | None = None
    length: Length | None = None
    # teamwork (docs/teamwork.md): a diver's body and orders, a vehicle's gripper
    skeleton: SkeletonSection = SkeletonSection()
    orders: tuple[OrderConfig, ...] = ()
    gripper: GripperSection | None = None
    # the diver's assistant drives this vehicle's helm and gripper (docs/hri.md)
    assistant: AssistantSection | None = None

    _script_order = field_validator("script")(_legs_in_time_order)

    @field_validator("sensors")
    @classmethod
    def _named_sensors(cls, sensors: tuple[SonarSensor | CameraSensor, ...]
                       ) -> tuple[SonarSensor | CameraSensor, ...]:
        """Every sensor named (:func:`default_sensor_names`), no two alike."""
        names = default_sensor_names(sensors)
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"sensor names on one agent must be unique; repeated: "
                             f"{', '.join(repeated)} (give each a 'name')")
        return tuple(s if s.name == n else s.model_copy(update={"name": n})
                     for s, n in zip(sensors, names, strict=True))

    def sensor_named(self, name: str) -> SonarSensor | CameraSensor | None:
        return next((s for s in self.sensors if s.name == name), None)

    @property
    def perception_sonar(self) -> str | None:
        """The name of the sonar whose pings perception reads (``contacts.sonar.sensor``,
        else the first sonar); None without one."""
        return self.contacts.sonar.sensor or next(
            (s.name for s in self.sensors if s.type == "sonar"), None)

    @field_validator("start")
    @classmethod
    def _starts_in_the_water(cls, start: Pose) -> Pose:
        if start.depth < 0.0:
            raise ValueError(f"start.depth {start.depth:g} m is above the surface (depth >= 0)")
        return start

    @property
    def scene_body(self) -> str:
        """The 3-D body the agent has in the scene: ``body``, or its model's own."""
        return self.body or MODELS[self.model].body

    @model_validator(mode="after")
    def _driver_matches(self) -> AgentConfig:
        chosen = self.contacts.sonar.sensor
        if chosen is not None and getattr(self.sensor_named(chosen), "type", None) != "sonar":
            sonars = [s.name for s in self.sensors if s.type == "sonar"]
            raise ValueError(f"contacts.sonar.sensor names no sonar {chosen!r} of agent "
                             f"{self.name!r}; its sonars: {', '.join(sonars) or 'none'}")
        if self.driver == "helm" and self.helm is None and self.assistant is None:
            raise ValueError(f"agent {self.name!r} is driven by its helm but has no 'helm' section")
        if self.driver == "script" and not self.script:
            raise ValueError(f"agent {self.name!r} is driven by a script but has no 'script' legs")
        model = MODELS[self.model]
        if (self.driver == "orders") != bool(self.orders):
            raise ValueError(f"agent {self.name!r}: 'orders' go with driver: orders (and "
                             "driver: orders needs orders)")
        if self.orders and model.diver is None:
            raise ValueError(f"agent {self.name!r}: only a diver carries out orders; "
                             f"{self.model} is not one")
        if self.gripper is not None and model.carrying is None:
            raise ValueError(f"agent {self.name!r}: {self.model} carries no gripper")
        return self


class PostAction(Strict):
    agent: str
    var: VarName
    value: str | float | bool

    @model_validator(mode="after")
    def _value_fits_var(self) -> PostAction:
        checked_value(self.agent, self.var, self.value)  # ConfigError is a ValueError
        return self


class MoveAction(Strict):
    label: str
    position: Vec3


class EventConfig(Strict):
    """A scripted event outside the agents: at a time, or once when a condition holds."""

    at: NonNegativeSeconds | None = None
    when: str | None = None
    post: PostAction | None = None
    move_object: MoveAction | None = None
    add_object: SceneObject | None = None
    script: tuple[ScriptLeg, ...] | None = None
    agent: str | None = None

    @field_validator("script")
    @classmethod
    def _script_order(cls, legs: tuple[ScriptLeg, ...] | None) -> tuple[ScriptLeg, ...] | None:
        return legs if legs is None else _legs_in_time_order(legs)

    @model_validator(mode="after")
    def _trigger_and_action(self) -> EventConfig:
        if (self.at is None) == (self.when is None):
            raise ValueError("an event needs exactly one trigger: 'at' (s) or 'when' (condition)")
        actions = [self.post, self.move_object, self.add_object, self.script]
        if sum(a is not None for a in actions) != 1:
            raise ValueError("an event needs exactly one action: post, move_object, "
                             "add_object or script")
        if (self.script is not None or self.when is not None) and self.agent is None:
            raise ValueError("a 'script' or 'when' event must name its 'agent' (the community "
                             "whose variables the condition reads, or the diver to re-plan)")
        return self


class RecordingConfig(Strict):
    enabled: bool = True
    odometry_rate_hz: RateHz = 10.0
    sonar: bool = True
    sonar_every: Count = 1  # every N-th ping (~300 MB/min at 15 Hz)
    camera: bool = True
    camera_every: Count = 1  # every N-th camera frame
    chunk_kib: Annotated[int, Field(ge=16, le=65536)] = 512


DESIRED_VARS = ("DESIRED_HEADING", "DESIRED_SPEED", "DESIRED_DEPTH")


class Ros2Link(Strict):
    """One agent on ROS 2: what it publishes and which commands it accepts."""

    agent: str
    # Command groups taken from ROS; unset: both for a vehicle or a diver driven from
    # outside (driver external/none), none for any other diver (ground truth only)
    accept: tuple[Literal["desired", "thrusters"], ...] | None = None


class Ros2Section(Strict):
    """ROS 2 bridge (docs/bridges-ros2.md); ``uhrisim run --ros2`` switches it on."""

    enabled: bool = False
    links: tuple[Ros2Link, ...] = ()  # empty: every agent, each accepting its default
    odom_rate_hz: RateHz = 10.0
    domain_id: Annotated[int, Field(ge=0, le=232)] | None = None
    command_timeout_s: Seconds = 1.0
    # Wait each odometry period for the controllers' answers (repeatable runs with
    # outside nodes; docs/bridges-ros2.md "Lockstep"); `uhrisim run --lockstep` too.
    lockstep: bool = False
    lockstep_timeout_s: Seconds = 10.0  # wall s a round may wait for the answers
    # The bridge node: its name, namespace (every topic under it, /clock and /tf too) and
    # ROS arguments as after --ros-args (remappings, -p parameters: docs/bridges-ros2.md)
    node_name: Name = "uhrisim"
    namespace: Annotated[str, Field(pattern=r"^(/?[A-Za-z][A-Za-z0-9_]*)*/?$")] = ""
    ros_args: tuple[str, ...] = ()


class MoosLink(Strict):
    """One agent in a MOOS community (docs/bridges-moos.md)."""

    agent: str
    host: str = "127.0.0.1"
    port: Annotated[int, Field(ge=1, le=65535)] = 9000
    community: str | None = None
    nav_rate_hz: RateHz = 10.0
    subscribe: tuple[VarName, ...] = DESIRED_VARS
    extra_vars: tuple[VarName, ...] = ()
    vehicle_type: str = "UUV"  # NODE_REPORT TYPE (pContactMgrV20 filters may use it)
    node_report_var: VarName = "NODE_REPORT"  # NODE_REPORT_LOCAL when pShare forwards it


class MoosSection(Strict):
    """MOOS-IvP bridge; ``uhrisim run --moos`` switches it on."""

    enabled: bool = False
    time_warp: Factor = 1.0  # MOOSTimeWarp of the community: the run is paced to it
    links: tuple[MoosLink, ...] = ()  # empty: every agent, ports 9000, 9001, ...


class HelmWatchSection(Strict):
    """How loudly an outside helm that does not drive its agent is reported
    (:mod:`uhrisim.bridges.helm_watch`; docs/bridges-moos.md)."""

    silence_s: Seconds = 10.0  # simulated s without commands (or parked) before a warning
    repeat_s: Seconds = 5.0  # a lasting problem is said again at most this often (s)
    required: bool = False  # end the run as failed at the first one (uhrisim run --require-helm)


class BridgesConfig(Strict):
    ros2: Ros2Section = Ros2Section()
    moos: MoosSection = MoosSection()
    helm_watch: HelmWatchSection = HelmWatchSection()
    # Live bridges pace the run to wall clock x this factor; null runs free (lockstep).
    real_time_factor: Factor | None = 1.0


class TrailMetricConfig(Strict):
    """Which pair the mission metrics measure, and the trail geometry they expect."""

    follower: str
    target: str
    range: Length = 2.0
    angle_deg: HeadingDeg = 180.0
    acquire_range_tolerance: Length = 1.0
    acquire_bearing_tolerance_deg: Annotated[float, Field(gt=0.0, le=180.0)] = 30.0
    acquire_hold_s: Seconds = 10.0


class ButtonConfig(PostAction):
    label: str


class Scenario(Strict):
    """A whole mission: world, agents, events, recording, timing and seed."""

    name: str
    description: str = ""
    seed: Annotated[int, Field(ge=0)] = 0
    duration: Seconds = 600.0
    # The physics step is dt = 1 / physics_rate_hz. 60 Hz makes the usual rates whole
    # numbers of steps (sonar 15 Hz = 4, helm 4 Hz = 15, odometry 10 Hz = 6).
    physics_rate_hz: Annotated[float, Field(ge=10.0, le=10000.0)] = 60.0
    lat_origin: Annotated[float, Field(ge=-90.0, le=90.0)] = 43.8253
    long_origin: Annotated[float, Field(ge=-180.0, le=180.0)] = -70.3304
    world: World = World()
    agents: tuple[AgentConfig, ...]
    events: tuple[EventConfig, ...] = ()
    recording: RecordingConfig = RecordingConfig()
    metrics: TrailMetricConfig | None = None
    buttons: tuple[ButtonConfig, ...] = ()
    bridges: BridgesConfig = BridgesConfig()

    @field_validator("agents")
    @classmethod
    def _unique_agents(cls, agents: tuple[AgentConfig, ...]) -> tuple[AgentConfig, ...]:
        if not agents:
            raise ValueError("a scenario needs at least one agent")
        names = [a.name for a in agents]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f"agent names must be unique; repeated: {', '.join(duplicates)}")
        return agents

    @model_validator(mode="after")
    def _walkers_have_a_floor(self) -> Scenario:
        for agent in self.agents:
            diver = MODELS[agent.model].diver
            if diver is not None and diver.walks and self.world.seafloor is None:
                raise ValueError(f"agent {agent.name!r} ({agent.model}) walks on the sea "
                                 "floor: give the scenario a world.seafloor")
        return self

    @model_validator(mode="after")
    def _references_exist(self) -> Scenario:
        names = {a.name for a in self.agents}
        refs = [(e.post.agent, ("events", i, "post", "agent"))
                for i, e in enumerate(self.events) if e.post]
        refs += [(e.agent, ("events", i, "agent")) for i, e in enumerate(self.events) if e.agent]
        refs += [(b.agent, ("buttons", i, "agent")) for i, b in enumerate(self.buttons)]
        refs += [(link.agent, ("bridges", "ros2", "links", i, "agent"))
                 for i, link in enumerate(self.bridges.ros2.links)]
        refs += [(link.agent, ("bridges", "moos", "links", i, "agent"))
                 for i, link in enumerate(self.bridges.moos.links)]
        if self.metrics:
            refs += [(self.metrics.follower, ("metrics", "follower")),
                     (self.metrics.target, ("metrics", "target"))]
        for name, path in refs:
            if name not in names:
                close = difflib.get_close_matches(name, sorted(names), n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise PydanticCustomError(  # at the line of the field that names it
                    "at_path", "names unknown agent {name}{hint}",
                    {"path": path, "name": repr(name), "hint": hint})
        return self

    def all_objects(self) -> tuple[SceneObject, ...]:
        """Every object of the scenario: the world's, then those its events add."""
        added = tuple(e.add_object for e in self.events if e.add_object is not None)
        return (*self.world.objects, *added)

    def movable_labels(self) -> set[str]:
        """Labels of the objects events may move: movable ones, in the world or added."""
        return {o.label for o in self.all_objects() if o.movable}
