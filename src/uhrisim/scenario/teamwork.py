"""The scenario's teamwork sections: tools, work sites, silt, a diver's orders, the ROV's
gripper and the diver's skeleton (docs/teamwork.md, "In a scenario").

Tools and sites live under ``world`` (``world.tools``, ``world.sites``, ``world.silt``);
a diver's ``orders`` and ``skeleton`` and a vehicle's ``gripper`` under its agent. Each
order is a mapping named by its first key (``{use: wrench1, at: flange1, seconds: 20,
bolt: 0}``; YAML reads a bare ``on`` key as true, so the keys are ``at`` and ``onto``)
and becomes one :mod:`uhrisim.teamwork.orders` order (its ``order()``). What can only
be checked against the built world (names, reach, walking paths, the tools' whereabouts)
is checked when the simulation is built (:mod:`uhrisim.sim.teamwork`),
each problem one line with its order's file:line — ``uhrisim validate`` does that too.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Discriminator, Field, PositiveFloat, Tag, model_validator

from uhrisim.core.errors import ConfigError
from uhrisim.scenario.sections import scenario_section
from uhrisim.scenario.strict import Strict
from uhrisim.teamwork import orders as od
from uhrisim.teamwork.gripper import GripperSpec
from uhrisim.world.tool_kinds import TOOL_KINDS

ObjectName = Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_]*$")]
Angle = Annotated[float, Field(ge=-360.0, le=360.0)]


class Place(Strict):
    """A point in world NED (m); ``depth`` left out: the object rests on whatever is
    under it (the floor, a platform's top, a basket's bottom)."""

    north: float = 0.0
    east: float = 0.0
    depth: float | None = None


class ToolConfig(Strict):
    """A tool (``uhrisim.world.tools``: its mass, size, grasp point and label by kind),
    where it starts: ``at`` (its reference point), heading and pitch (deg; -90 stands a
    tool on its working end), and what it rests in or on (``in: basket1``,
    ``onto: stand1``; default: the floor; YAML reads a bare ``on`` key as true). A
    ``lift_bag`` is also a lift bag site with ``capacity_litres`` and
    ``inflate_rate_lps``. ``mass_kg`` (in air): a lighter or heavier one than the
    catalogue's, of the same material (e.g. a folded 50 L bag of 1.5 kg)."""

    kind: Literal[TOOL_KINDS]  # type: ignore[valid-type]
    name: ObjectName
    at: Place
    heading_deg: Angle = 0.0
    pitch_deg: Annotated[float, Field(ge=-90.0, le=90.0)] = 0.0
    in_: ObjectName | None = Field(None, alias="in")
    onto: ObjectName | None = None
    capacity_litres: Annotated[float, Field(gt=0.0, le=2000.0)] = 100.0
    inflate_rate_lps: Annotated[float, Field(gt=0.0, le=50.0)] = 1.5
    mass_kg: Annotated[float, Field(gt=0.0, le=500.0)] | None = None

    @model_validator(mode="after")
    def _one_support(self) -> ToolConfig:
        if self.in_ is not None and self.onto is not None:
            raise ValueError("a tool rests either in a basket or on a platform, not both")
        return self

    @property
    def where(self) -> str:
        """Where it starts, in the workspace's words (``floor``, ``in:x``, ``on:x``)."""
        return f"in:{self.in_}" if self.in_ else f"on:{self.onto}" if self.onto else "floor"


class SiteBase(Strict):
    """A work site or structure: its name, where it is (``at``), its heading (deg)."""

    name: ObjectName
    at: Place
    heading_deg: Angle = 0.0


class FlangeSite(SiteBase):
    """A bolted blind flange (``uhrisim.world.worksites.FlangeSpec``): the centre of its
    cover at ``at``, facing ``heading_deg``; ``bolts`` loosened by ``loosen_s`` of wrench
    work each."""

    type: Literal["flange"]
    bolts: Annotated[int, Field(ge=1, le=16)] = 4
    loosen_s: PositiveFloat = 20.0


class HatchSite(SiteBase):
    """A hatch (``HatchSpec``): latched until ``latch_s`` of hammer work."""

    type: Literal["hatch"]
    size: Annotated[float, Field(gt=0.1, le=3.0)] = 0.6
    latch_s: PositiveFloat = 10.0


class LoadSite(SiteBase):
    """A flooded steel load (``steel_load``) of ``mass_kg`` inside ``size`` (m)."""

    type: Literal["load"]
    mass_kg: Annotated[float, Field(gt=0.0, le=5000.0)]
    size: tuple[PositiveFloat, PositiveFloat, PositiveFloat] = (0.6, 0.4, 0.4)


class PlatformSite(SiteBase):
    """A work stand: a level top (``at``: its centre) of ``size`` (m, along and across
    its heading) on a column down to the floor — objects can be put on it."""

    type: Literal["platform"]
    size: tuple[PositiveFloat, PositiveFloat] = (0.4, 0.4)


Site = Annotated[FlangeSite | HatchSite | LoadSite | PlatformSite, Field(discriminator="type")]


class Silt(Strict):
    """Silt on a soft floor (``uhrisim.world.silt``): every footfall of a diver on boots
    stirs a puff that settles at the Stokes speed and spreads; the sensors see it."""

    soft: bool = True
    current_ne: tuple[float, float] = (0.0, 0.0)  # m/s the clouds drift with


# ---------------------------------------------------------------------------- orders

class GoToOrder(Strict):
    go_to: ObjectName | tuple[float, float]
    standoff: PositiveFloat = 0.6

    def order(self) -> od.Order:
        return od.GoTo(self.go_to, self.standoff)


class PickUpOrder(Strict):
    pick_up: ObjectName
    hand: Literal["left", "right"] = "right"

    def order(self) -> od.Order:
        return od.PickUp(self.pick_up, self.hand)


class UseOrder(Strict):
    use: ObjectName
    at: ObjectName
    seconds: PositiveFloat = 1.0
    bolt: Annotated[int, Field(ge=0)] = 0

    def order(self) -> od.Order:
        return od.UseOn(self.use, self.at, self.seconds, self.bolt)


class RemoveOrder(Strict):
    remove: ObjectName
    part: Annotated[int, Field(ge=0)] | Literal["cover"]

    def order(self) -> od.Order:
        return od.Remove(self.remove, self.part)


class OperateOrder(Strict):
    operate: ObjectName
    action: Literal["open", "close", "inflate", "stop"]

    def order(self) -> od.Order:
        return od.Operate(self.operate, self.action)


class PutDownOrder(Strict):
    put_down: ObjectName
    onto: ObjectName

    def order(self) -> od.Order:
        return od.PutDown(self.put_down, self.onto)


class HandOrder(Strict):
    hand: ObjectName
    to: Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_]*/[a-z_]+$")]

    def order(self) -> od.Order:
        return od.HandTo(self.hand, self.to)


class WaitOrder(Strict):
    wait_until: ObjectName
    state: str
    timeout_s: PositiveFloat = 600.0

    def order(self) -> od.Order:
        return od.WaitUntil(self.wait_until, self.state, self.timeout_s)


class SignalOrder(Strict):
    """A signal: a placeholder pose (one of ``od.SIGNALS``) held ``seconds``, or, with a
    ``channel``, a command to the ROV (docs/hri.md: ``bring_tool lift_bag`` as a gesture,
    a slate's marker or the sonar wave) that his body performs; ``seconds`` then defaults
    to how long the gesture or the slate takes."""

    signal: str
    channel: Literal["gesture", "marker", "sonar"] | None = None
    seconds: PositiveFloat | None = None

    @model_validator(mode="after")
    def _known(self) -> SignalOrder:
        if self.channel is None:
            if self.signal not in od.SIGNALS:
                raise ValueError(f"unknown signal {self.signal!r} (have "
                                 f"{', '.join(od.SIGNALS)}; or give a command and a channel)")
            return self
        from uhrisim.perception.signalling import signal_duration
        from uhrisim.perception.signals import Command
        try:
            duration = signal_duration(Command.parse(self.signal), self.channel)
        except ConfigError as error:
            raise ValueError(error.problem) from None
        if self.seconds is None:
            object.__setattr__(self, "seconds", duration)
        return self

    def order(self) -> od.Order:
        return od.Signal(self.signal, 2.0 if self.seconds is None else self.seconds,
                         self.channel)


class ModeOrder(Strict):
    mode: Literal["walk", "swim"]

    def order(self) -> od.Order:
        return od.SetMode(self.mode)


#: Each order's first key names it.
_ORDER_KEYS = {"go_to": GoToOrder, "pick_up": PickUpOrder, "use": UseOrder,
               "remove": RemoveOrder, "operate": OperateOrder, "put_down": PutDownOrder,
               "hand": HandOrder, "wait_until": WaitOrder, "signal": SignalOrder,
               "mode": ModeOrder}


def _order_kind(value: Any) -> str | None:
    """The tag of an order: its first key and "order" (a tag that is no key of the
    mapping, so error paths go on to the field)."""
    if isinstance(value, dict):
        key = next((k for k in value if k in _ORDER_KEYS), None)
    else:
        key = next((k for k, cls in _ORDER_KEYS.items() if isinstance(value, cls)), None)
    return None if key is None else f"{key} order"


OrderConfig = Annotated[
    Annotated[GoToOrder, Tag("go_to order")] | Annotated[PickUpOrder, Tag("pick_up order")]
    | Annotated[UseOrder, Tag("use order")] | Annotated[RemoveOrder, Tag("remove order")]
    | Annotated[OperateOrder, Tag("operate order")] | Annotated[PutDownOrder, Tag("put_down order")]
    | Annotated[HandOrder, Tag("hand order")] | Annotated[WaitOrder, Tag("wait_until order")]
    | Annotated[SignalOrder, Tag("signal order")] | Annotated[ModeOrder, Tag("mode order")],
    Discriminator(_order_kind, custom_error_type="order",
                  custom_error_message="an order is a mapping whose first key is one of "
                  + ", ".join(_ORDER_KEYS)),
]


# ---------------------------------------------------------------------------- agents

GripperSettings = scenario_section(
    GripperSpec, "GripperSettings",
    doc="The VideoRay's gripper (uhrisim.teamwork.gripper.GripperSpec), every setting "
        "under its own name.")


class GripperSection(GripperSettings):  # type: ignore[misc, valid-type]
    """A single-function gripper under the vehicle's bow (docs/teamwork.md): its settings
    (docs/settings.md), what it ``holds`` when the run starts, and its command when the
    run starts (``command``: the agent's ``GRIPPER`` variable — ``open``, ``close``,
    ``catch`` (close as soon as an object lies between the jaws) or ``give`` (let go once
    someone else holds what it holds)). Helms, scripts' events, MOOS and ROS 2 post
    ``GRIPPER`` to change it."""

    holds: ObjectName | None = None
    command: Literal["open", "close", "catch", "give"] = "open"


class SkeletonSection(Strict):
    """The articulated diver's body (``uhrisim.dynamics.diver_body.DiverSkeleton``):
    stature (m) and the range-of-motion factor of its suit (0.8: a dry suit)."""

    stature_m: Annotated[float, Field(ge=1.4, le=2.1)] = 1.75
    rom_factor: Annotated[float, Field(ge=0.3, le=1.0)] = 0.8
