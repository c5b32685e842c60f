"""The scenes of DeMarco, West & Howard (OCEANS 2013), plus a one-piling test scene.

* :func:`pier_scene` — two rows of rectangular pier support beams reaching from the sea
  floor to the surface, over gently sloping, rough bathymetry (paper Figs 12–14).
* :func:`torus_scene` — a torus lying on the sea floor (paper Figs 15–16).
* :func:`single_piling_scene` — one square piling at a given range and bearing from a
  sonar, for tests.

The paper gives no dimensions; the numbers here (0.4 m beams, 8 m of water, 6 m spacing)
are plausible harbour values, chosen so that the structures fall inside a 45° fan at
2–30 m. Each builder returns a :class:`PaperScene`: the Scene plus suggested sensor poses
(level sonar head poses, FRD→NED; the downward tilt belongs to the sonar config and is
suggested separately).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.world import primitives as prim
from uhrisim.world import seafloor as sf
from uhrisim.world.assets import diver_parts, videoray_mesh
from uhrisim.world.materials import CONCRETE, NEOPRENE, ROV_PLASTIC, SAND, Material
from uhrisim.world.scene import Scene


@dataclass(frozen=True)
class SensorPose:
    """A suggested sensor/vehicle pose: position (NED, m) and rotation (FRD→NED)."""

    position_ned: NDArray[np.float64]
    rotation: NDArray[np.float64]
    tilt_deg: float = 0.0  # suggested sonar tilt (> 0 down), applied by the sonar mount

    @staticmethod
    def level(north: float, east: float, depth: float, heading_deg: float, tilt_deg: float = 0.0):
        """Level pose at (north, east, depth) facing compass ``heading_deg``."""
        return SensorPose(
            np.array([north, east, depth], dtype=float),
            rot_z(math.radians(heading_deg)),
            float(tilt_deg),
        )


@dataclass(frozen=True)
class PaperScene:
    """A built scene with suggested sonar poses keyed by name."""

    scene: Scene
    sonar_poses: dict[str, SensorPose] = field(default_factory=dict)
    description: str = ""


def add_videoray(
    scene: Scene,
    name: str = "videoray",
    position_ned: ArrayLike = (0.0, 0.0, 3.0),
    heading_deg: float = 0.0,
    material: Material = ROV_PLASTIC,
) -> None:
    """Add the procedural VideoRay Pro 4 as dynamic body ``name`` with label "rov"."""
    scene.add_dynamic(
        name, videoray_mesh(), "rov", material, position_ned, rot_z(math.radians(heading_deg))
    )


def add_diver(
    scene: Scene,
    name: str = "diver",
    position_ned: ArrayLike = (10.0, 0.0, 4.0),
    heading_deg: float = 0.0,
    kick_phase: float = 0.0,
    material: Material = NEOPRENE,
) -> None:
    """Add the articulated diver (``assets.diver_parts``) as body ``name``, label "diver"."""
    scene.add_dynamic(
        name,
        diver_parts(material),
        "diver",
        material,
        position_ned,
        rot_z(math.radians(heading_deg)),
        kick_phase,
    )


def _square_beam(north: float, east: float, floor_depth: float, width: float, yaw: float = 0.0):
    """Square beam from 0.5 m above the surface to 0.5 m into the floor (NED z down)."""
    top, bottom = -0.5, floor_depth + 0.5
    return prim.box((width, width, bottom - top), (north, east, 0.5 * (top + bottom)), yaw=yaw)


def pier_scene(
    seed: int = 2013,
    water_depth: float = 8.0,
    beam_width: float = 0.4,
    rows_east: tuple[float, ...] = (-3.0, 3.0),
    beams_north: tuple[float, ...] = (8.0, 14.0, 20.0, 26.0, 32.0),
    with_diver: bool = False,
    with_rov: bool = False,
) -> PaperScene:
    """Two rows of square pier beams (label "piling") over rough, sloping sand ("seafloor").

    Bathymetry: ``procedural(seed)`` relief (0.15 m rms, 4 m correlation) on a floor
    ``water_depth`` deep at the origin that deepens 2 % towards the north; 1 m grid over
    north −10…60 m, east −30…30 m. Beams reach from the floor to above the surface.
    ``with_diver`` adds the diver ("diver", 10 m ahead at 4 m); ``with_rov`` adds the
    VideoRay ("videoray") at the "approach" pose.
    """
    base = sf.procedural(seed, (-10.0, 60.0, -30.0, 30.0), water_depth, 0.15, 4.0, 1.0)
    floor = sf.SeaFloor(base.north, base.east, base.depth + 0.02 * base.north[:, None])
    scene = Scene()
    scene.add_static(floor, "seafloor", SAND)
    for e in rows_east:
        for n in beams_north:
            depth_here = float(floor.depth_at(n, e))
            scene.add_static(_square_beam(n, e, depth_here, beam_width), "piling", CONCRETE)
    poses = {
        "approach": SensorPose.level(0.0, 0.0, 3.0, 0.0, tilt_deg=10.0),
        "oblique": SensorPose.level(2.0, -9.0, 3.0, 25.0, tilt_deg=10.0),
    }
    if with_rov:
        p = poses["approach"]
        add_videoray(scene, "videoray", p.position_ned, 0.0)
    if with_diver:
        add_diver(scene, "diver", (10.0, 0.0, 4.0), 0.0)
    return PaperScene(scene, poses, "pier support beams over bathymetry (paper Figs 12-14)")


def torus_scene(
    water_depth: float = 8.0,
    major_radius: float = 1.5,
    minor_radius: float = 0.3,
    distance: float = 10.0,
) -> PaperScene:
    """A torus (label "torus") lying on a flat sand floor, ``distance`` m north of the sonar.

    The sonar pose looks north from 4 m depth, tilted 20° down so the fan covers the floor
    around the torus (the inner ring and the torus cast shadows, paper Figs 15–16).
    """
    scene = Scene()
    scene.add_static(sf.flat(water_depth, (-10.0, 40.0, -20.0, 20.0)), "seafloor", SAND)
    scene.add_static(
        prim.torus(major_radius, minor_radius, (distance, 0.0, water_depth - minor_radius)),
        "torus",
        CONCRETE,
    )
    poses = {"front": SensorPose.level(0.0, 0.0, 4.0, 0.0, tilt_deg=20.0)}
    return PaperScene(scene, poses, "torus on the sea floor (paper Figs 15-16)")


def single_piling_scene(
    range_m: float,
    bearing_deg: float = 0.0,
    width: float = 0.4,
    water_depth: float = 8.0,
    sonar_depth: float = 4.0,
    with_floor: bool = True,
    face_sonar: bool = True,
) -> PaperScene:
    """One square piling (label "piling") whose centre is ``range_m`` from the sonar.

    The sonar sits at (0, 0, ``sonar_depth``) facing north; the piling's centre is at
    compass bearing ``bearing_deg`` from it. With ``face_sonar`` the piling is turned so
    one face is perpendicular to the line of sight (the nearest surface is then at
    ``range_m - width / 2``).
    """
    if not range_m > 0.5 * width:
        raise ConfigError(
            f"must exceed half the piling width ({0.5 * width} m), got {range_m}",
            where="single_piling_scene.range_m",
        )
    if not 0.0 < sonar_depth < water_depth:
        raise ConfigError(
            f"must lie between the surface and the floor ({water_depth} m), got {sonar_depth}",
            where="single_piling_scene.sonar_depth",
        )
    b = math.radians(bearing_deg)
    n, e = range_m * math.cos(b), range_m * math.sin(b)
    scene = Scene()
    if with_floor:
        half = range_m + 20.0
        scene.add_static(sf.flat(water_depth, half), "seafloor", SAND)
    yaw = b if face_sonar else 0.0
    scene.add_static(_square_beam(n, e, water_depth, width, yaw), "piling", CONCRETE)
    poses = {"origin": SensorPose.level(0.0, 0.0, sonar_depth, 0.0)}
    return PaperScene(
        scene, poses, f"one {width} m piling at {range_m} m, bearing {bearing_deg} deg"
    )
