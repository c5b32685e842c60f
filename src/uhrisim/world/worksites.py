"""Work sites with state that tools change: a bolted flange, a hatch, a lift bag and its load.

Each site is an immutable *spec* (where it is, its sizes and timings) and an immutable
*state*; transitions are pure methods ``spec.something(state, ..., t, actor) -> (state,
events)`` that return the new state and a :class:`~uhrisim.world.events.WorldEvent` for
every change of status (a bolt loosened or out, the cover off, the latch freed, the lid
open or closed, a bag attached, inflating or full), and a failed event with the reason
when the change is not allowed. Progress in between (seconds of work, litres of gas, the
lid's angle) is kept in the state without an event per tick. The simulation owns the
states.

Geometry follows the state: :meth:`parts` gives the site's rigid parts (site frame:
x along the site's heading, y to its right, z down; metres; origin at the site's
``position_ned``) once, and :meth:`part_transforms` a rest→posed 4x4 per part for a
state. A part that is gone (a removed bolt, the cover set aside, a bag size not in use) is
*parked* far above the water (:data:`PARKED`), so a scene keeps one body per site and
its ray casters never rebuild a BVH; :func:`posed_mesh` drops parked parts.

Numbers:

* **Flange**: an NPS 4 class 150 blind flange after ASME B16.5 (outside diameter 229 mm,
  thickness 23.9 mm, four 5/8 in (15.9 mm) bolts on a 190.5 mm bolt circle) on a 4 in
  pipe (114.3 mm outside diameter). The wrench work that frees one bolt, 20 s, is an
  assumption (breaking out and running off a nut in gloves).
* **Hatch**: a 0.6 m square lid on a hinge; freeing its latch takes 10 s of hammer work
  and swinging it 110° open 2 s (assumptions).
* **Lift bag**: a 100 L open-bottom bag (in the tool catalogue folded) inflated at 1.5
  surface litres a second (assumed: a diver's low-pressure inflator hose); its gas
  follows Boyle's law and spills beyond the capacity
  (:func:`uhrisim.dynamics.free_body.gas_volume`).
  The swelling bag is drawn as a parachute bag (a prolate ellipsoid 1.6 times as tall as
  wide) of the current volume, in :data:`BAG_SIZES` steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.checks import require_positive
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.dynamics.free_body import ATMOSPHERE_PA, GRAVITY, WATER_DENSITY, Hydro, gas_volume
from uhrisim.world import primitives as prim
from uhrisim.world.assets import ellipsoid
from uhrisim.world.bodies import ArticulatedMesh, Part
from uhrisim.world.events import WorldEvent
from uhrisim.world.tools import CATALOGUE

#: Work times compare with this slack (s): a tick's dt summed up stays a float.
_SLACK_S = 1e-9
#: Where parts that are gone wait (translation, m): far above the water, out of any view
#: (beyond bodies.HIDDEN_BEYOND_M: the ray caster skips them).
PARKED = np.array([0.0, 0.0, -1.0e4])
_ALONG_X = {"pitch": math.pi / 2.0}


def _parked() -> NDArray[np.float64]:
    m = np.eye(4)
    m[:3, 3] = PARKED
    return m


def _check_name(name: str, kind: str) -> None:
    if not isinstance(name, str) or not name:
        raise ConfigError(f"must be a non-empty string, got {name!r}", where=f"{kind}.name")


def _site_pose(position_ned: ArrayLike, yaw: float) -> NDArray[np.float64]:
    """4x4 site frame → NED (read-only)."""
    m = np.eye(4)
    m[:3, :3] = rot_z(yaw)
    m[:3, 3] = np.asarray(position_ned, dtype=float)
    m.setflags(write=False)
    return m


def posed_mesh(parts: ArticulatedMesh, transforms: NDArray[np.float64],
               pose: NDArray[np.float64] | None = None) -> trimesh.Trimesh:
    """The parts present (not parked) as one Trimesh, in the site frame or via ``pose``."""
    keep = [i for i, t in enumerate(transforms) if t[2, 3] > 0.5 * PARKED[2]]
    meshes = []
    for i in keep:
        m = parts.parts[i].mesh.copy()
        m.apply_transform(transforms[i] if pose is None else pose @ transforms[i])
        meshes.append(m)
    return trimesh.util.concatenate(meshes)


# =========================================================================== flange


@dataclass(frozen=True)
class FlangeState:
    """Seconds of wrench work each bolt has had, which bolts are out, whether the cover
    is on."""

    work_s: tuple[float, ...]
    removed: tuple[bool, ...]
    cover_on: bool = True


@dataclass(frozen=True)
class FlangeSpec:
    """A blind flange on a horizontal pipe end (module docstring). The flange face looks
    along the site's +x; ``position_ned`` is the centre of its face, ``yaw`` (rad) the
    compass direction the face looks."""

    name: str
    position_ned: tuple[float, float, float]
    yaw: float = 0.0
    n_bolts: int = 4
    bolt_circle_radius: float = 0.5 * 0.1905
    flange_radius: float = 0.5 * 0.229
    cover_thickness: float = 0.0239
    bolt_diameter: float = 0.0159
    pipe_radius: float = 0.5 * 0.1143
    loosen_time_s: float = 20.0
    tool_kind: str = "wrench"

    def __post_init__(self) -> None:
        _check_name(self.name, "FlangeSpec")
        if not isinstance(self.n_bolts, int) or not 1 <= self.n_bolts <= 32:
            raise ConfigError(f"must be an integer in [1, 32], got {self.n_bolts!r}",
                              where=f"flange {self.name!r}.n_bolts")
        require_positive(self, ("loosen_time_s", "bolt_circle_radius", "flange_radius",
                                "cover_thickness", "bolt_diameter", "pipe_radius"),
                         f"flange {self.name!r}")

    def initial_state(self) -> FlangeState:
        return FlangeState((0.0,) * self.n_bolts, (False,) * self.n_bolts)

    def pose(self) -> NDArray[np.float64]:
        """4x4 site frame → NED."""
        return self._pose.copy()

    @cached_property
    def _pose(self) -> NDArray[np.float64]:
        """:meth:`pose`, worked out once (read-only)."""
        return _site_pose(self.position_ned, self.yaw)

    def bolt_status(self, state: FlangeState, bolt: int) -> str:
        """'tight', 'loose' or 'removed'."""
        if state.removed[bolt]:
            return "removed"
        return "loose" if state.work_s[bolt] >= self.loosen_time_s - _SLACK_S else "tight"

    def bolt_position_site(self, bolt: int) -> NDArray[np.float64]:
        """The nut of ``bolt`` (where a wrench goes), site frame (m). Bolts are numbered
        clockwise seen from the front, bolt 0 at the top."""
        a = 2.0 * math.pi * bolt / self.n_bolts
        r = self.bolt_circle_radius
        return np.array([self.cover_thickness + 0.02, r * math.sin(a), -r * math.cos(a)])

    def bolt_position(self, bolt: int) -> NDArray[np.float64]:
        """The nut of ``bolt``, NED (m)."""
        pose = self._pose
        return pose[:3, :3] @ self.bolt_position_site(bolt) + pose[:3, 3]

    def cover_grasp_position(self) -> NDArray[np.float64]:
        """Where a hand takes the cover (its rim at the top), NED (m)."""
        pose = self._pose
        rim = np.array([0.5 * self.cover_thickness, 0.0, -0.9 * self.flange_radius])
        return pose[:3, :3] @ rim + pose[:3, 3]

    def _bolt(self, state: FlangeState, bolt: int, t: float, actor: str
              ) -> WorldEvent | None:
        if not 0 <= bolt < self.n_bolts:
            return WorldEvent(t, "work_failed", self.name, actor, False,
                              f"no bolt {bolt} (bolts 0 to {self.n_bolts - 1})")
        if state.removed[bolt]:
            return WorldEvent(t, "work_failed", self.name, actor, False,
                              f"bolt {bolt} is already out")
        return None

    def work(self, state: FlangeState, bolt: int, dt: float, t: float, actor: str = ""
             ) -> tuple[FlangeState, list[WorldEvent]]:
        """``dt`` s of wrench work on ``bolt``: it loosens after ``loosen_time_s`` s in all
        (an event when it does)."""
        failed = self._bolt(state, bolt, t, actor)
        if failed:
            return state, [failed]
        before = state.work_s[bolt]
        work = list(state.work_s)
        work[bolt] = before + dt
        new = replace(state, work_s=tuple(work))
        if before < self.loosen_time_s - _SLACK_S <= work[bolt]:
            return new, [WorldEvent(t, "bolt_loosened", self.name, actor,
                                    detail={"bolt": bolt, "work_s": work[bolt]})]
        return new, []

    def remove_bolt(self, state: FlangeState, bolt: int, t: float, actor: str = ""
                    ) -> tuple[FlangeState, list[WorldEvent]]:
        """Take out a loose bolt; a tight one stays (failed event with its progress)."""
        failed = self._bolt(state, bolt, t, actor)
        if failed:
            return state, [replace(failed, kind="remove_failed")]
        if self.bolt_status(state, bolt) == "tight":
            return state, [WorldEvent(
                t, "remove_failed", self.name, actor, False,
                f"bolt {bolt} is still tight ({state.work_s[bolt]:.1f} of "
                f"{self.loosen_time_s:.1f} s of {self.tool_kind} work)")]
        removed = list(state.removed)
        removed[bolt] = True
        return replace(state, removed=tuple(removed)), [
            WorldEvent(t, "bolt_removed", self.name, actor, detail={"bolt": bolt})]

    def remove_cover(self, state: FlangeState, t: float, actor: str = ""
                     ) -> tuple[FlangeState, list[WorldEvent]]:
        """Take the cover off: only when every bolt is out."""
        if not state.cover_on:
            return state, [WorldEvent(t, "remove_failed", self.name, actor, False,
                                      "the cover is already off")]
        left = [i for i in range(self.n_bolts) if not state.removed[i]]
        if left:
            return state, [WorldEvent(t, "remove_failed", self.name, actor, False,
                                      f"{len(left)} bolt(s) still in: "
                                      f"{', '.join(map(str, left))}")]
        return replace(state, cover_on=False), [
            WorldEvent(t, "cover_removed", self.name, actor)]

    def parts(self) -> ArticulatedMesh:
        """Pipe stub, flange ring, cover, one part per bolt (site frame, at rest)."""
        ct = self.cover_thickness
        parts = [
            Part("pipe", prim.cylinder(self.pipe_radius, 0.4, (-0.2 - ct, 0.0, 0.0),
                                       sections=24, **_ALONG_X)),
            Part("ring", prim.cylinder(self.flange_radius, ct, (-0.5 * ct, 0.0, 0.0),
                                       sections=32, **_ALONG_X)),
            Part("cover", prim.cylinder(self.flange_radius, ct, (0.5 * ct, 0.0, 0.0),
                                        sections=32, **_ALONG_X), label="cover"),
        ]
        for bolt in range(self.n_bolts):
            nut = self.bolt_position_site(bolt)
            shank = prim.cylinder(0.5 * self.bolt_diameter, 2.0 * ct + 0.04,
                                  (ct - 0.0, nut[1], nut[2]), sections=8, **_ALONG_X)
            head = prim.cylinder(self.bolt_diameter, 0.014, (nut[0] - 0.007, nut[1], nut[2]),
                                 sections=6, **_ALONG_X)
            parts.append(Part(f"bolt{bolt}", trimesh.util.concatenate([shank, head]),
                              label="bolt"))
        return ArticulatedMesh(tuple(parts), posed_apart=True)

    def part_transforms(self, state: FlangeState) -> NDArray[np.float64]:
        """Rest→posed transform of every part: a loose bolt backed out 2 cm, a removed bolt
        and a removed cover parked."""
        out = [np.eye(4), np.eye(4), np.eye(4) if state.cover_on else _parked()]
        for bolt in range(self.n_bolts):
            status = self.bolt_status(state, bolt)
            m = _parked() if status == "removed" else np.eye(4)
            if status == "loose":
                m[0, 3] = 0.02
            out.append(m)
        return np.array(out)


# =========================================================================== hatch


@dataclass(frozen=True)
class HatchState:
    """Hammer work on the latch so far (s), the lid's angle (rad, 0 closed), and where
    the lid is going (True: open)."""

    latch_work_s: float = 0.0
    angle: float = 0.0
    opening: bool = False


@dataclass(frozen=True)
class HatchSpec:
    """A horizontal hatch: the hinge runs along the site's y axis through
    ``position_ned``; the closed lid lies flat towards +x and swings up (−z)."""

    name: str
    position_ned: tuple[float, float, float]
    yaw: float = 0.0
    size: float = 0.6
    thickness: float = 0.02
    latch_time_s: float = 10.0
    open_angle: float = math.radians(110.0)
    swing_time_s: float = 2.0
    tool_kind: str = "hammer"

    def __post_init__(self) -> None:
        _check_name(self.name, "HatchSpec")
        require_positive(self, ("size", "thickness", "swing_time_s", "open_angle"),
                         f"hatch {self.name!r}")
        require_positive(self, ("latch_time_s",), f"hatch {self.name!r}", allow_zero=True)

    def initial_state(self) -> HatchState:
        return HatchState()

    def pose(self) -> NDArray[np.float64]:
        """4x4 site frame → NED."""
        return self._pose.copy()

    @cached_property
    def _pose(self) -> NDArray[np.float64]:
        """:meth:`pose`, worked out once (read-only)."""
        return _site_pose(self.position_ned, self.yaw)

    def status(self, state: HatchState) -> str:
        """'latched', 'closed', 'opening', 'open' or 'closing'."""
        if state.latch_work_s < self.latch_time_s - _SLACK_S:
            return "latched"
        if state.opening:
            return "open" if state.angle >= self.open_angle else "opening"
        return "closed" if state.angle <= 0.0 else "closing"

    def latch_position(self) -> NDArray[np.float64]:
        """The latch on the lid's free edge (where the hammer goes), NED (m)."""
        pose = self._pose
        return pose[:3, :3] @ np.array([self.size, 0.0, -self.thickness]) + pose[:3, 3]

    def handle_position(self, state: HatchState) -> NDArray[np.float64]:
        """The lid's handle (its free edge's middle) at the current angle, NED (m)."""
        pose = self._pose
        a = state.angle
        edge = np.array([self.size * math.cos(a), 0.0, -self.size * math.sin(a)])
        return pose[:3, :3] @ edge + pose[:3, 3]

    def work(self, state: HatchState, dt: float, t: float, actor: str = ""
             ) -> tuple[HatchState, list[WorldEvent]]:
        """``dt`` s of hammer work on the latch; it frees after ``latch_time_s``."""
        before = state.latch_work_s
        new = replace(state, latch_work_s=before + dt)
        if before < self.latch_time_s - _SLACK_S <= new.latch_work_s:
            return new, [WorldEvent(t, "latch_freed", self.name, actor)]
        return new, []

    def command(self, state: HatchState, open_: bool, t: float, actor: str = ""
                ) -> tuple[HatchState, list[WorldEvent]]:
        """Start opening (``open_``) or closing the lid; a latched lid does not move."""
        if self.status(state) == "latched":
            return state, [WorldEvent(
                t, "open_failed", self.name, actor, False,
                f"the latch is still fast ({state.latch_work_s:.1f} of "
                f"{self.latch_time_s:.1f} s of {self.tool_kind} work)")]
        if state.opening == open_:
            return state, []
        kind = "hatch_opening" if open_ else "hatch_closing"
        return replace(state, opening=open_), [WorldEvent(t, kind, self.name, actor)]

    def advance(self, state: HatchState, dt: float, t: float
                ) -> tuple[HatchState, list[WorldEvent]]:
        """Swing the lid for ``dt`` s at ``open_angle / swing_time_s``."""
        rate = self.open_angle / self.swing_time_s
        if state.opening and state.angle < self.open_angle:
            angle = min(self.open_angle, state.angle + rate * dt)
            events = ([WorldEvent(t, "hatch_opened", self.name)]
                      if angle >= self.open_angle else [])
            return replace(state, angle=angle), events
        if not state.opening and state.angle > 0.0:
            angle = max(0.0, state.angle - rate * dt)
            events = [WorldEvent(t, "hatch_closed", self.name)] if angle <= 0.0 else []
            return replace(state, angle=angle), events
        return state, []

    def parts(self) -> ArticulatedMesh:
        """The coaming (a square frame) and the lid (site frame, closed)."""
        s, th = self.size, self.thickness
        frame = []
        for x, y, lx, ly in ((0.5 * s, -0.5 * s, s, 0.04), (0.5 * s, 0.5 * s, s, 0.04),
                             (0.0, 0.0, 0.04, s), (s, 0.0, 0.04, s)):
            frame.append(prim.box((lx, ly, 0.1), (x, y, 0.05 + th)))
        lid = prim.box((s, s, th), (0.5 * s, 0.0, 0.5 * th))
        return ArticulatedMesh((Part("coaming", trimesh.util.concatenate(frame)),
                                Part("lid", lid, label="lid")), posed_apart=True)

    def part_transforms(self, state: HatchState) -> NDArray[np.float64]:
        """The lid rotated about the hinge (the site's y axis) by its angle, free edge up."""
        a = state.angle
        lid = np.eye(4)
        lid[:3, :3] = [[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0],
                       [-math.sin(a), 0.0, math.cos(a)]]
        return np.array([np.eye(4), lid])


# =========================================================================== lift bag

#: Drawn bag volumes (litres at depth): the nearest not below the gas shows.
BAG_SIZES = (5.0, 10.0, 20.0, 35.0, 50.0, 70.0, 100.0)


@dataclass(frozen=True)
class LiftBagState:
    """The load the bag is fast to (None: free), its gas in surface litres, and whether
    it is being inflated."""

    attached_to: str | None = None
    gas_surface_litres: float = 0.0
    inflating: bool = False
    full: bool = False


@dataclass(frozen=True)
class LiftBagSpec:
    """An open-bottom lift bag (module docstring)."""

    name: str
    capacity_litres: float = 100.0
    inflate_rate_lps: float = 1.5
    rigging_m: float = 0.3  # from the attachment point to the bag's mouth

    def __post_init__(self) -> None:
        _check_name(self.name, "LiftBagSpec")
        require_positive(self, ("capacity_litres", "inflate_rate_lps", "rigging_m"),
                         f"lift bag {self.name!r}")

    @property
    def fabric(self) -> Hydro:
        """The folded bag's own mass, volume and drag (the tool catalogue's lift bag)."""
        return CATALOGUE["lift_bag"].hydro

    def initial_state(self) -> LiftBagState:
        return LiftBagState()

    def gas_m3(self, state: LiftBagState, depth: float) -> float:
        """Gas volume (m³) at ``depth`` (m), capped at the capacity."""
        return gas_volume(state.gas_surface_litres, depth, 1e-3 * self.capacity_litres)

    def lift_n(self, state: LiftBagState, depth: float) -> float:
        """Buoyancy of the gas (N) at ``depth``: rho g V."""
        return WATER_DENSITY * GRAVITY * self.gas_m3(state, depth)

    def attach(self, state: LiftBagState, load: str, t: float, actor: str = ""
               ) -> tuple[LiftBagState, list[WorldEvent]]:
        """Make the bag fast to ``load``."""
        if state.attached_to is not None:
            return state, [WorldEvent(t, "attach_failed", self.name, actor, False,
                                      f"already attached to {state.attached_to}")]
        return replace(state, attached_to=load), [
            WorldEvent(t, "bag_attached", self.name, actor, reason=f"on {load}",
                       detail={"load": load})]

    def set_inflating(self, state: LiftBagState, on: bool, t: float, actor: str = ""
                      ) -> tuple[LiftBagState, list[WorldEvent]]:
        """Open or close the inflation valve."""
        if state.inflating == on:
            return state, []
        kind = "bag_inflating" if on else "bag_inflation_stopped"
        return replace(state, inflating=on), [WorldEvent(t, kind, self.name, actor)]

    def advance(self, state: LiftBagState, dt: float, t: float, depth: float
                ) -> tuple[LiftBagState, list[WorldEvent]]:
        """Inflate for ``dt`` s at ``depth`` (m): gas grows until the bag is full there
        (what more goes in spills: the gas is capped at the capacity compressed to depth)."""
        if not state.inflating or state.full:
            return state, []
        pressure_ratio = 1.0 + WATER_DENSITY * GRAVITY * max(depth, 0.0) / ATMOSPHERE_PA
        full_at_depth = self.capacity_litres * pressure_ratio
        gas = min(state.gas_surface_litres + self.inflate_rate_lps * dt, full_at_depth)
        if gas >= full_at_depth:
            return replace(state, gas_surface_litres=gas, full=True), [
                WorldEvent(t, "bag_full", self.name, detail={"litres": self.capacity_litres})]
        return replace(state, gas_surface_litres=gas), []

    def parts(self) -> ArticulatedMesh:
        """The folded bag (the tool catalogue's, as a free or carried bag shows) and one
        swollen bag per size of :data:`BAG_SIZES` (rigged: origin at the load's lifting
        eye, the bag above it on its rigging)."""
        parts = [Part("folded", CATALOGUE["lift_bag"].mesh())]
        for litres in BAG_SIZES:
            a, c = bag_semi_axes(1e-3 * litres)
            parts.append(Part(f"bag{litres:g}", ellipsoid((a, a, c), (0.0, 0.0,
                                                                     -self.rigging_m - c))))
        return ArticulatedMesh(tuple(parts), posed_apart=True)

    def shown_part(self, state: LiftBagState, depth: float) -> int:
        """Which part shows: 0 the folded bag, else the drawn size nearest above the gas
        at ``depth`` (m)."""
        litres = 1e3 * self.gas_m3(state, depth)
        return 0 if litres < 0.5 * BAG_SIZES[0] else 1 + min(
            (i for i, s in enumerate(BAG_SIZES) if s >= litres), default=len(BAG_SIZES) - 1)

    def part_transforms(self, state: LiftBagState, depth: float) -> NDArray[np.float64]:
        """Show the folded bag (rigged: on top of the lifting eye), or the drawn size that
        holds the gas at ``depth`` (m)."""
        shown = self.shown_part(state, depth)
        folded = np.eye(4)
        if state.attached_to is not None:
            folded[2, 3] = -0.05
        return np.array([(folded if i == 0 else np.eye(4)) if i == shown else _parked()
                         for i in range(1 + len(BAG_SIZES))])


def bag_semi_axes(volume_m3: float) -> tuple[float, float]:
    """Semi-axes (a, c) (m) of a swollen bag: prolate, c = 1.6 a, volume 4/3 π a² c."""
    a = (3.0 * volume_m3 / (4.0 * math.pi * 1.6)) ** (1.0 / 3.0)
    return a, 1.6 * a


# =========================================================================== load


@dataclass(frozen=True)
class LoadSpec:
    """A heavy object to be raised (a valve body, a wreck part): a box of ``size`` (m)
    with its hydrodynamics; its position comes from the free-body physics."""

    name: str
    hydro: Hydro
    size: tuple[float, float, float] = (0.6, 0.4, 0.4)

    def __post_init__(self) -> None:
        _check_name(self.name, "LoadSpec")

    def attachment_site(self) -> NDArray[np.float64]:
        """The lifting eye on top, load frame (m)."""
        return np.array([0.0, 0.0, -0.5 * self.size[2]])

    def parts(self) -> ArticulatedMesh:
        eye = prim.torus(0.04, 0.01, (0.0, 0.0, -0.5 * self.size[2] - 0.04), roll=math.pi / 2)
        return ArticulatedMesh((Part("body", prim.box(self.size)), Part("eye", eye)))


def steel_load(name: str, mass_kg: float, size: tuple[float, float, float] = (0.6, 0.4, 0.4)
               ) -> LoadSpec:
    """A flooded steel structure (a valve body, a wreck part) of ``mass_kg`` inside the
    outline ``size`` (m): it displaces only its steel (7850 kg/m³); rising or sinking it
    drags like a bluff box (C_d 1.05 on its top face, Hoerner) with the added mass of
    its displaced water (C_a = 1)."""
    hydro = Hydro(mass_kg, mass_kg / 7850.0, 1.05, size[0] * size[1],
                  added_mass_coefficient=1.0, bottom_offset=0.5 * size[2])
    return LoadSpec(name, hydro, size)
