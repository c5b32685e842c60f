"""Labelled sonar datasets: randomised scenes → fan and polar images, labels, COCO.

A dataset file (YAML; mesh files beside it) says what to draw; every frame is drawn from
its own stream ``component_rng(seed, "dataset/frame/<index>")`` (the sonar's speckle from
``.../sonar``), so a frame does not depend on the others, on the shard size or on the
number of workers: the same file and seed give byte-identical files (PNG written by
OpenCV carry no time stamp; JSON is written with sorted keys). A value given as ``[low,
high]`` is drawn uniformly; a list of names is a choice; ``{uniform|log_uniform|integers|
choice: ...}`` works for any sonar setting.

A frame: a sea floor (flat, sloped or procedural, its depth drawn), the sonar
``altitude`` above it looking along a random heading with a drawn tilt, and ``count``
objects from ``kinds`` placed in the insonified band of the floor (between the ranges where
the lower and upper edges of the vertical beam meet it) within the middle of the fan,
resting on the floor or ``altitude`` above it. Each object is one instance with its own
scene label ``<class>/<k>``; the floor is instance ``seafloor``.

Outputs (``DIR``): ``fan/NNNNNN.png`` and ``polar/NNNNNN.png`` (8-bit, as the sonar forms
them: polar row 0 is the nearest range bin, column 0 the port beam; fan apex at the
bottom centre), ``labels_fan/`` and ``labels_polar/`` (16-bit PNG: 0 no echo, k the
frame's instance k), ``frames/NNNNNN.json`` (sonar pose and settings, water, floor, every
instance with its class, pose and pixel counts, and the frame's ``world`` as a scenario
section), ``annotations_coco.json`` (COCO instance segmentation of the fan images, RLE
masks; the sea floor is background, not a category), ``README.md`` (the dataset card) and
``preview.png``.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import cv2
import numpy as np
import yaml
from pydantic import Field, field_validator, model_validator

import uhrisim
from uhrisim.batch.cluster import check_address, ray_session, run_tasks
from uhrisim.batch.params import Draw, read_yaml
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.core.rng import component_rng
from uhrisim.scenario.build_world import (
    add_object,
    build_static_scene,
    material_named,
    object_mesh,
)
from uhrisim.scenario.load import ScenarioFile, validate_data
from uhrisim.scenario.schema import (
    AgentConfig,
    Scenario,
    SceneObject,
    Strict,
    Vec3,
    Water,
    World,
)
from uhrisim.world.assets import diver_parts, videoray_mesh
from uhrisim.world.materials import NEOPRENE, ROV_PLASTIC
from uhrisim.world.scene import Scene

#: A number, or [low, high] drawn uniformly.
Span = float | tuple[float, float]
FLOOR_TYPES = ("flat", "sloped", "procedural")
SEAFLOOR = "seafloor"
#: Objects lie within this fraction of the half field of view, so they are in the fan.
BEARING_FRACTION = 0.8
#: The elevation (fraction of the half vertical beam width) that bounds the insonified
#: band of the floor where objects are placed.
BAND_FRACTION = 0.8
PREVIEW_FRAMES = 16
PREVIEW_TILE_PX = 192
LEGEND_ROW_PX = 26  # one row of the preview's class legend
#: Sonar settings the frame generator sets itself.
_OWN_SETTINGS = ("preset", "spec", "range_max_m", "tilt_deg", "yaw_deg", "mount_position_frd",
                 "labels", "water_temperature_c", "salinity_psu", "water_depth_m", "ph")


def draw_span(span: Span, rng: np.random.Generator) -> float:
    """``span`` if a number, else a uniform draw from [low, high]."""
    if isinstance(span, tuple):
        return float(rng.uniform(*span))
    return float(span)


def _check_span(span: Span) -> Span:
    if isinstance(span, tuple) and not span[0] <= span[1]:
        raise ValueError(f"[low, high] with low {span[0]} above high {span[1]}")
    return span




class FloorSection(Strict):
    types: tuple[Literal["flat", "sloped", "procedural"], ...] = FLOOR_TYPES
    material: tuple[str, ...] = ("sand",)
    depth: Span = (6.0, 15.0)
    slope: Span = (-0.1, 0.1)
    roughness: Span = (0.1, 0.8)

    _spans = field_validator("depth", "slope", "roughness")(_check_span)


class ObjectKind(Strict):
    """One kind of object: a primitive (box, cylinder, sphere, torus, capsule), a mesh
    file, or the built-in diver or ROV; ``class`` names its category (default: type)."""

    type: Literal["box", "cylinder", "sphere", "torus", "capsule", "mesh", "diver", "rov"]
    category: str | None = Field(None, alias="class")
    material: tuple[str, ...] = ("concrete",)
    altitude: Span = 0.0  # m from the floor to the object's lowest point
    radius: Span | None = None
    height: Span | None = None
    size: tuple[Span, Span, Span] | None = None
    major_radius: Span | None = None
    minor_radius: Span | None = None
    file: str | None = None
    scale: Span = 1.0

    _spans = field_validator("altitude", "radius", "height", "major_radius", "minor_radius",
                             "scale")(_check_span)

    @property
    def class_name(self) -> str:
        return self.category or self.type

    @model_validator(mode="after")
    def _dimensions(self) -> ObjectKind:
        need = {"box": ("size",), "cylinder": ("radius", "height"), "sphere": ("radius",),
                "capsule": ("radius", "height"), "torus": ("major_radius", "minor_radius"),
                "mesh": ("file",)}.get(self.type, ())
        missing = [n for n in need if getattr(self, n) is None]
        if missing:
            raise ValueError(f"a {self.type} needs {' and '.join(missing)}")
        if self.class_name == SEAFLOOR:
            raise ValueError(f"'{SEAFLOOR}' is the floor's class; name the object otherwise")
        return self


class ObjectsSection(Strict):
    count: tuple[Annotated[int, Field(ge=0)], Annotated[int, Field(ge=0)]] = (1, 3)
    kinds: tuple[ObjectKind, ...] = Field(min_length=1)


class SonarSection(Strict):
    preset: tuple[str, ...] = ("P900-45",)
    altitude: Span = (1.0, 3.0)  # m above the floor below the sonar
    tilt_deg: Span = (5.0, 20.0)
    range_max_m: Span = 15.0
    settings: dict[str, Any] = Field(default_factory=dict)

    _spans = field_validator("altitude", "tilt_deg", "range_max_m")(_check_span)


class WaterSection(Strict):
    temperature_c: Span = (5.0, 25.0)
    salinity_psu: Span = (30.0, 37.0)
    ph: Span = 8.0

    _spans = field_validator("temperature_c", "salinity_psu", "ph")(_check_span)


class DatasetFile(Strict):
    name: str
    frames: Annotated[int, Field(ge=1, le=10_000_000)]
    seed: Annotated[int, Field(ge=0)] = 0
    floors: FloorSection = FloorSection()
    objects: ObjectsSection
    sonar: SonarSection = SonarSection()
    water: WaterSection = WaterSection()
    description: str = ""

    @property
    def classes(self) -> list[str]:
        """Object categories in the order the kinds first name them (COCO ids 1, 2, …)."""
        return list(dict.fromkeys(kind.class_name for kind in self.objects.kinds))


@dataclass(frozen=True)
class DatasetPlan:
    """A checked dataset file and the folder its relative paths (mesh files) are in."""

    spec: DatasetFile
    folder: Path


def load_dataset(path: str | Path) -> DatasetPlan:
    """Read and check a dataset file; frame 0 is drawn and built here, so a bad sonar
    setting, material or mesh file is a one-line ConfigError before Ray starts."""
    path = Path(path)
    data, lines = read_yaml(path, "dataset")
    spec: DatasetFile = validate_data(data, str(path), lines, model=DatasetFile, kind="dataset")
    low, high = spec.objects.count
    if low > high:
        raise ConfigError(f"objects.count: low {low} is above high {high}", where=str(path))
    plan = DatasetPlan(spec, path.resolve().parent)
    try:
        FrameBuilder(plan, 0).build()
    except ConfigError as error:
        raise ConfigError(str(error), where=str(path)) from None
    return plan


def _setting(value: Any, rng: np.random.Generator) -> Any:
    """A sonar setting: fixed, or drawn when it is a ``{uniform|…: …}`` mapping."""
    if isinstance(value, dict):
        return Draw.model_validate(value).sample(rng)
    return value


class FrameBuilder:
    """Draws frame ``index`` of a dataset: its scene, sonar and instances."""

    def __init__(self, plan: DatasetPlan, index: int) -> None:
        self.plan = plan
        self.spec = plan.spec
        self.index = index
        self.rng = component_rng(self.spec.seed, f"dataset/frame/{index}")

    def _choice(self, options: tuple[Any, ...]) -> Any:
        return options[int(self.rng.integers(len(options)))]

    def build(self) -> dict[str, Any]:
        """The frame: ``scene``, ``sonar_config``, vehicle pose and its JSON record."""
        from uhrisim.sensors.sonar import SonarConfig

        spec, rng = self.spec, self.rng
        water = {k: draw_span(getattr(spec.water, k), rng)
                 for k in ("temperature_c", "salinity_psu", "ph")}
        s = spec.sonar
        preset = self._choice(s.preset)
        range_max = draw_span(s.range_max_m, rng)
        tilt = draw_span(s.tilt_deg, rng)
        heading = float(rng.uniform(0.0, 360.0))
        altitude = draw_span(s.altitude, rng)
        floor = self._floor(range_max)
        floor_material = self._choice(spec.floors.material)
        source = ScenarioFile(Scenario(name=f"{spec.name}/{self.index}",
                                       world=World(water=Water(**water), seafloor=floor),
                                       agents=(AgentConfig(name="sonar", model="kinematic",
                                                           driver="none"),)),
                              self.plan.folder / "dataset.yaml")
        scene = build_static_scene(source, material_named(floor_material, "floors.material"))
        depth = float(scene.depth_at(0.0, 0.0)) - altitude
        if depth < 0.2:
            raise ConfigError(f"frame {self.index}: the sonar, {altitude:.2f} m above a floor "
                              f"{depth + altitude:.2f} m deep, is out of the water",
                              where="sonar.altitude")
        settings = {k: _setting(v, rng) for k, v in s.settings.items()}
        own = sorted(set(settings) & set(_OWN_SETTINGS))
        if own:
            raise ConfigError(f"{own[0]} is drawn by the dataset itself (see its own key)",
                              where="sonar.settings")
        try:
            config = SonarConfig(preset=preset, range_max_m=range_max, tilt_deg=tilt,
                                 mount_position_frd=(0.0, 0.0, 0.0), labels=True,
                                 water_temperature_c=water["temperature_c"],
                                 salinity_psu=water["salinity_psu"], ph=water["ph"],
                                 water_depth_m=depth, **settings)
        except TypeError as error:  # an unknown setting
            raise ConfigError(str(error).split("__init__() ")[-1], where="sonar.settings"
                              ) from None
        position = np.array([0.0, 0.0, depth])
        yaw = math.radians(heading)
        instances = [{"id": 1, "label": SEAFLOOR, "class": SEAFLOOR, "category_id": None}]
        objects = self._objects(scene, source, config, yaw, altitude, instances)
        record = {
            "frame": self.index,
            "sonar": {"preset": preset, "position_ned": position.tolist(),
                      "heading_deg": heading, "tilt_deg": tilt, "altitude_m": altitude,
                      "range_min_m": config.range_min_m, "range_max_m": range_max,
                      "range_bin_m": config.bin_m, "settings": settings},
            "water": water,
            "floor_material": floor_material,
            "world": World(water=Water(**water), seafloor=floor,
                           objects=tuple(objects)).model_dump(mode="json"),
            "instances": instances,
        }
        return {"scene": scene, "config": config, "position": position, "yaw": yaw,
                "record": record}

    def _floor(self, range_max: float) -> Any:
        f, rng = self.spec.floors, self.rng
        kind = self._choice(f.types)
        data: dict[str, Any] = {"type": kind, "depth": draw_span(f.depth, rng),
                                "extent": range_max + 10.0}
        if kind == "sloped":
            data |= {"slope": draw_span(f.slope, rng),
                     "direction_deg": float(rng.uniform(0.0, 360.0))}
        elif kind == "procedural":
            data |= {"roughness": draw_span(f.roughness, rng),
                     "seed": int(rng.integers(2**31))}
        return World.model_validate({"seafloor": data}).seafloor

    def _band(self, config: Any, altitude: float) -> tuple[float, float]:
        """Horizontal ranges (m) between which the vertical beam meets a flat floor
        ``altitude`` below, inside the range window (the whole window if none)."""
        half = BAND_FRACTION * config.sonar_spec.beam_width_v_deg / 2.0
        low_edge, high_edge = config.tilt_deg + half, config.tilt_deg - half
        near = altitude / math.tan(math.radians(min(low_edge, 89.0)))
        far = altitude / math.tan(math.radians(high_edge)) if high_edge > 0.5 else math.inf
        lo, hi = max(near, config.range_min_m + 1.0), min(far, 0.9 * config.range_max_m)
        return (lo, hi) if lo < hi else (config.range_min_m + 1.0, 0.9 * config.range_max_m)

    def _objects(self, scene: Scene, source: ScenarioFile, config: Any, yaw: float,
                 altitude: float, instances: list[dict[str, Any]]) -> list[SceneObject]:
        rng = self.rng
        classes = self.spec.classes
        near, far = self._band(config, altitude)
        half_fov = math.radians(config.sonar_spec.fov_h_deg) / 2.0 * BEARING_FRACTION
        placed: list[SceneObject] = []
        count = int(rng.integers(self.spec.objects.count[0], self.spec.objects.count[1],
                                 endpoint=True))
        for k in range(count):
            kind = self._choice(self.spec.objects.kinds)
            label = f"{kind.class_name}/{k}"
            r = float(rng.uniform(near, far))
            bearing = yaw + float(rng.uniform(-half_fov, half_fov))
            north, east = r * math.cos(bearing), r * math.sin(bearing)
            heading = float(rng.uniform(0.0, 360.0))
            floor = float(scene.depth_at(north, east)) - draw_span(kind.altitude, rng)
            where = f"objects.kinds[{self.spec.objects.kinds.index(kind)}]"
            if kind.type in ("diver", "rov"):
                centre = self._add_body(scene, kind, label, north, east, floor, heading)
            else:
                obj = self._primitive(kind, label, heading, where)
                lowest = object_mesh(obj, source, where, posed=False).bounds[1][2]
                obj = obj.model_copy(update={"position": Vec3(north=north, east=east,
                                                              depth=floor - lowest)})
                add_object(scene, obj, source, where)
                placed.append(obj)
                centre = obj.position.as_list()
            instances.append({"id": len(instances) + 1, "label": label,
                              "class": kind.class_name,
                              "category_id": classes.index(kind.class_name) + 1,
                              "type": kind.type, "position_ned": centre,
                              "heading_deg": heading, "range_m": r})
        return placed

    def _add_body(self, scene: Scene, kind: ObjectKind, label: str, north: float,
                  east: float, floor: float, heading: float) -> list[float]:
        """The built-in diver (with a random kick phase) or ROV, lowest point at ``floor``."""
        if kind.type == "diver":
            phase = float(self.rng.uniform(0.0, 2.0 * math.pi))
            body, material = diver_parts(), NEOPRENE
            lowest = body.mesh_at(phase).bounds[1][2]
        else:
            phase, body, material = 0.0, videoray_mesh(), ROV_PLASTIC
            lowest = body.bounds[1][2]
        centre = [north, east, floor - lowest]
        scene.add_dynamic(label, body, label, material, centre, rot_z(math.radians(heading)),
                          phase)
        return centre

    def _primitive(self, kind: ObjectKind, label: str, heading: float,
                   where: str) -> SceneObject:
        rng = self.rng
        data: dict[str, Any] = {"type": kind.type, "label": label, "heading_deg": heading,
                                "material": self._choice(kind.material)}
        for name in ("radius", "height", "major_radius", "minor_radius"):
            if getattr(kind, name) is not None:
                data[name] = draw_span(getattr(kind, name), rng)
        if kind.size is not None:
            data["size"] = [draw_span(s, rng) for s in kind.size]
        if kind.file is not None:
            # as written: the frame's world resolves it beside the dataset file, and its
            # JSON does not depend on where the dataset sits
            data |= {"file": kind.file, "scale": draw_span(kind.scale, rng)}
        world = validate_data({"objects": [data]}, where, model=World, kind="dataset")
        return world.objects[0]


def render_frame(plan: DatasetPlan, index: int, out: Path) -> dict[str, Any]:
    """Draw, ping and write frame ``index``; its record (instances with pixel counts and
    their fan masks as COCO RLE)."""
    from pycocotools import mask as coco_mask

    from uhrisim.sensors.sonar import ImagingSonar

    frame = FrameBuilder(plan, index).build()
    sonar = ImagingSonar(frame["config"], component_rng(plan.spec.seed,
                                                        f"dataset/frame/{index}/sonar"))
    ping = sonar.ping(frame["scene"].raycaster(), frame["position"], rot_z(frame["yaw"]), 0.0)
    record = frame["record"]
    # Scene label ids follow the instances' order (floor first): instance id = label id + 1.
    assert frame["scene"].labels == [i["label"] for i in record["instances"]]
    label_fan = (ping.label_fan.astype(np.int32) + 1).astype(np.uint16)
    label_polar = (ping.label_polar.astype(np.int32) + 1).astype(np.uint16)
    stem = f"{index:06d}"
    files = {"fan": f"fan/{stem}.png", "polar": f"polar/{stem}.png",
             "labels_fan": f"labels_fan/{stem}.png", "labels_polar": f"labels_polar/{stem}.png"}
    for key, image in (("fan", ping.fan_u8), ("polar", ping.polar_u8),
                       ("labels_fan", label_fan), ("labels_polar", label_polar)):
        _write_png(out / files[key], image)
    fan_counts = np.bincount(label_fan.ravel(), minlength=len(record["instances"]) + 1)
    polar_counts = np.bincount(label_polar.ravel(), minlength=len(record["instances"]) + 1)
    annotations = []
    for instance in record["instances"]:
        instance["pixels_fan"] = int(fan_counts[instance["id"]])
        instance["pixels_polar"] = int(polar_counts[instance["id"]])
        if instance["category_id"] is None or not instance["pixels_fan"]:
            continue
        rle = coco_mask.encode(np.asfortranarray(label_fan == instance["id"], dtype=np.uint8))
        annotations.append({
            "category_id": instance["category_id"], "instance_id": instance["id"],
            "segmentation": {"size": [int(s) for s in rle["size"]],
                             "counts": rle["counts"].decode("ascii")},
            "area": float(coco_mask.area(rle)),
            "bbox": [float(v) for v in coco_mask.toBbox(rle)], "iscrowd": 0})
    record |= {"files": files, "fan_size_px": [int(ping.fan_u8.shape[1]),
                                               int(ping.fan_u8.shape[0])],
               "fan_px_per_m": ping.fan_px_per_m, "fan_apex_px": list(ping.fan_apex_px),
               "polar_shape": [int(s) for s in ping.polar_u8.shape]}
    _write_json(out / "frames" / f"{stem}.json", record)
    return record | {"annotations": annotations}


def _write_png(path: Path, image: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    ok, data = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, 6])
    if not ok:
        raise ConfigError(f"{path}: OpenCV could not encode the image")
    path.write_bytes(data.tobytes())


def _write_json(path: Path, value: Any) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(value, sort_keys=True, indent=1, allow_nan=False) + "\n",
                    encoding="utf-8")


def render_shard(task: tuple[DatasetPlan, int, int, str]) -> list[dict[str, Any]]:
    """Frames [start, stop) of the dataset into ``out`` (a Ray task): their records."""
    plan, start, stop, out = task
    return [render_frame(plan, i, Path(out)) for i in range(start, stop)]


@dataclass
class DatasetResult:
    frames: int
    annotations: int
    files: list[Path]
    nodes: dict[str, int] = field(default_factory=dict)  # shards rendered per Ray node id


def run_dataset(dataset_path: str | Path, out: str | Path, *, address: str | None = None,
                workers: int | None = None, shard_frames: int = 25,
                frames: int | None = None,
                progress: Callable[[int, int], None] | None = None) -> DatasetResult:
    """Render the dataset on Ray (``shard_frames`` frames a task) and write the COCO
    file, the dataset card and the preview. ``frames``: that many frames instead of the
    file's count (frame i is the same frame either way: a small try, or more).
    ``progress(frames done, frames)``."""
    for option, value in (("--shard-frames", shard_frames), ("--frames", frames)):
        if value is not None and value < 1:
            raise ConfigError(f"must be an integer >= 1, got {value!r}", where=option)
    plan = load_dataset(dataset_path)
    check_address(address)  # before anything is written
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    total = plan.spec.frames if frames is None else frames
    shards = [(plan, a, min(a + shard_frames, total), str(out))
              for a in range(0, total, shard_frames)]
    records: list[dict[str, Any]] = []
    if progress:
        progress(0, total)

    def finished(_: int, shard: list[dict[str, Any]]) -> None:
        records.extend(shard)
        if progress:
            progress(len(records), total)

    with ray_session(address, workers) as in_flight:
        nodes = dict(run_tasks(render_shard, shards, in_flight, finished))
    records.sort(key=lambda r: r["frame"])
    coco = coco_document(plan.spec, records)
    _write_json(out / "annotations_coco.json", coco)
    files = [out / "annotations_coco.json", write_card(plan.spec, records, coco, out),
             write_preview(records, out, coco["categories"])]
    return DatasetResult(len(records), len(coco["annotations"]), files, nodes)


def coco_document(spec: DatasetFile, records: list[dict[str, Any]]) -> dict[str, Any]:
    """The COCO instance-segmentation document of the fan images (ids from 1, in frame
    order)."""
    images, annotations = [], []
    for record in records:
        image_id = record["frame"] + 1
        width, height = record["fan_size_px"]
        images.append({"id": image_id, "file_name": record["files"]["fan"],
                       "width": width, "height": height})
        for ann in record["annotations"]:
            annotations.append({"id": len(annotations) + 1, "image_id": image_id} | ann)
    return {
        "info": {"description": spec.description or spec.name,
                 "version": uhrisim.__version__,
                 "contributor": "uhrisim (DeMarco, West & Howard 2013 sonar re-creation)"},
        "licenses": [],
        "images": images,
        "annotations": annotations,
        "categories": [{"id": i + 1, "name": name, "supercategory": "object"}
                       for i, name in enumerate(spec.classes)],
    }


def write_card(spec: DatasetFile, records: list[dict[str, Any]], coco: dict[str, Any],
               out: Path) -> Path:
    """``README.md``: what the dataset holds (counts, classes, parameters, layout)."""
    per_class = Counter(a["category_id"] for a in coco["annotations"])
    placed = Counter(i["class"] for r in records for i in r["instances"][1:])
    floors = Counter(f'{r["world"]["seafloor"]["type"]} {r["floor_material"]}'
                     for r in records)
    presets = Counter(r["sonar"]["preset"] for r in records)
    empty = sum(not r["annotations"] for r in records)
    lines = [f"# {spec.name}", "", spec.description or "A labelled forward-looking sonar "
             "dataset generated by uhrisim (`uhrisim dataset`).", "",
             "## Counts", "",
             f"- frames: {len(records)} (seed {spec.seed}); frames without any visible "
             f"object: {empty}",
             f"- annotated instances (COCO, fan images): {len(coco['annotations'])}",
             f"- sea floors: {_counts(floors)}", f"- sonar presets: {_counts(presets)}", "",
             "## Classes", "", "| id | class | objects placed | visible instances |",
             "| --- | --- | --- | --- |"]
    lines += [f"| {c['id']} | {c['name']} | {placed[c['name']]} | {per_class[c['id']]} |"
              for c in coco["categories"]]
    lines += ["", "The sea floor is instance 1 of every frame's label images, not a COCO "
              "category.", "", "## Files", "",
              "- `fan/NNNNNN.png`, `polar/NNNNNN.png`: 8-bit sonar images (fan: apex at the "
              "bottom centre, forward up; polar: row 0 the nearest range bin, column 0 the "
              "port beam)",
              "- `labels_fan/`, `labels_polar/`: 16-bit PNG, 0 = no echo, k = instance k of "
              "`frames/NNNNNN.json`",
              "- `frames/NNNNNN.json`: sonar pose and settings, water, the world (a scenario "
              "`world` section), instances with class, pose and pixel counts",
              "- `annotations_coco.json`: COCO instance segmentation of the fan images (RLE)",
              "- `preview.png`: the first frames with their instances outlined", "",
              "## Parameters", "", "```yaml",
              yaml.safe_dump(spec.model_dump(mode="json", by_alias=True), sort_keys=True,
                             default_flow_style=None).rstrip(), "```", "",
              f"Generated by uhrisim {uhrisim.__version__}; the same file and seed give "
              "byte-identical files.", ""]
    path = out / "README.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def _counts(counter: Counter) -> str:
    return ", ".join(f"{k} {v}" for k, v in sorted(counter.items())) or "none"


def preview_legend(categories: list[dict[str, Any]], width: int) -> np.ndarray:
    """Rows of ``[swatch] name`` for each category, :data:`LEGEND_ROW_PX` high, four to
    a row (BGR, dark background)."""
    per_row = 4
    rows = max(1, math.ceil(len(categories) / per_row))
    legend = np.full((rows * LEGEND_ROW_PX, width, 3), 24, np.uint8)
    cell = width // per_row
    for i, category in enumerate(categories):
        x, y = (i % per_row) * cell + 8, (i // per_row) * LEGEND_ROW_PX
        legend[y + 6:y + LEGEND_ROW_PX - 6, x:x + 16] = category_colour(category["id"])
        cv2.putText(legend, f"{category['id']} {category['name']}", (x + 22, y + 18),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.45, (235, 235, 235), 1, cv2.LINE_AA)
    return legend


#: Outline and legend colours of the categories in ``preview.png``, BGR (matplotlib's
#: "tab10": ten colours told apart at a glance), cycled.
CATEGORY_COLOURS = ((180, 119, 31), (14, 127, 255), (44, 160, 44), (40, 39, 214),
                    (189, 103, 148), (75, 86, 140), (194, 119, 227), (127, 127, 127),
                    (34, 189, 188), (207, 190, 23))


def category_colour(category_id: int) -> tuple[int, int, int]:
    """The BGR colour of a category's outlines and legend swatch in ``preview.png``."""
    return CATEGORY_COLOURS[(category_id - 1) % len(CATEGORY_COLOURS)]


def write_preview(records: list[dict[str, Any]], out: Path,
                  categories: list[dict[str, Any]]) -> Path:
    """``preview.png``: the first frames' fan images (colour-mapped) in a grid, each
    instance outlined in its category's colour, and below them the legend of the
    categories (COCO ``categories``: id, name)."""
    tiles = []
    for record in records[:PREVIEW_FRAMES]:
        fan = cv2.imread(str(out / record["files"]["fan"]), cv2.IMREAD_GRAYSCALE)
        labels = cv2.imread(str(out / record["files"]["labels_fan"]), cv2.IMREAD_UNCHANGED)
        image = cv2.applyColorMap(fan, cv2.COLORMAP_BONE)
        for instance in record["instances"][1:]:
            mask = (labels == instance["id"]).astype(np.uint8)
            contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
            cv2.drawContours(image, contours, -1, category_colour(instance["category_id"]), 1)
        scale = PREVIEW_TILE_PX / max(image.shape[:2])
        image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        tile = np.zeros((PREVIEW_TILE_PX, PREVIEW_TILE_PX, 3), np.uint8)
        y0, x0 = PREVIEW_TILE_PX - image.shape[0], (PREVIEW_TILE_PX - image.shape[1]) // 2
        tile[y0:, x0:x0 + image.shape[1]] = image
        cv2.putText(tile, f"{record['frame']}", (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    (255, 255, 255), 1, cv2.LINE_AA)
        tiles.append(tile)
    columns = min(4, len(tiles))
    while len(tiles) % columns:
        tiles.append(np.zeros_like(tiles[0]))
    grid = np.vstack([np.hstack(tiles[i:i + columns]) for i in range(0, len(tiles), columns)])
    grid = np.vstack([grid, preview_legend(categories, grid.shape[1])])
    path = out / "preview.png"
    _write_png(path, grid)
    return path
